"""Direct-dynamic validation (direct_dynamics.py): the written URDF, closed for the Orthoglide,
forward-simulated by Pinocchio under recorded currents.

The closed tree built from the URDF is the closed-form IDIM (inverse dynamics agree to
round-off); with the plant's true parameters it tracks a simulated record over 0.2 s windows to
a fraction of a percent of the motion's drift, and the manufacturer's 2001 N/A visibly worse;
a serial URDF robot identified end to end (slow) tracks its validation record.
"""
from __future__ import annotations

import importlib

import numpy as np
import pytest

from orthoglide_ident.identify import IdentifyOptions, Record, identify_records, read_record
from orthoglide_ident.identify.validate import direct_dynamics as dd
from orthoglide_ident.model.registry import load_robot

ORTHOGLIDE = load_robot("orthoglide")  # the robot these records are of

ROBOT = load_robot(None)
G_TRUE = [2170.0, 2100.0, 2070.0]


@pytest.fixture(scope="module")
def truth() -> np.ndarray:
    return importlib.import_module("orthoglide_sim.orthoglide.truth").default_parameters() \
        .standard_vector()


def test_closed_tree_of_the_urdf_is_the_closed_form_model(truth):
    fwd, engine = ROBOT.forward_model(truth, G_TRUE, None)
    q, qd, qdd = ROBOT.random_states(20, seed=3)
    tau = (ROBOT.standard_regressor(q, qd, qdd) @ truth).reshape(3, -1).T
    Q, V = fwd.lift(q, qd)
    acc = np.array([fwd.acceleration(Q[k], V[k], tau[k])[fwd.iv] for k in range(len(q))])
    assert np.abs(acc - qdd).max() < 1e-11 * np.abs(qdd).max()
    assert "constraint dynamics" in engine


@pytest.fixture(scope="module")
def sim_record() -> Record:
    """The sample loaded bag: 10 s of the simulator with the 1.983 kg payload."""
    return read_record("bags/loaded", model=ORTHOGLIDE)


def test_true_model_tracks_a_simulated_record(truth, sim_record):
    opts = IdentifyOptions()
    good = dd.validate(sim_record, ROBOT, truth, G_TRUE, 1.983, opts)
    bad = dd.validate(sim_record, ROBOT, truth, [637 * np.pi] * 3, 1.983, opts)
    assert good.windows >= 10 and good.horizon_s == dd.HORIZON_S
    rel = np.array([j.relative for j in good.joints])
    rel_bad = np.array([j.relative for j in bad.joints])
    # the plant's smooth Coulomb friction, 1 mA current noise and 1 µm encoder: ≲ 0.5 % of the
    # drift over 0.2 s; 8 % too low gains leave several % of it unexplained
    assert rel.max() < 0.005 and np.all(rel_bad > 5 * rel)
    assert all(j.unit == "m" and j.rms_error < 5e-4 for j in good.joints)


@pytest.mark.slow
def test_serial_urdf_robot_identified_consistent_and_simulated(tmp_path):
    from serial_arm import TRUE_GAINS, SerialArm
    from synthetic import synthetic_record

    arm = SerialArm(tmp_path / "arm3.urdf")
    chi_b = arm.K @ arm.standard_values()
    kw = dict(model=arm, chi=chi_b, g_tau=TRUE_GAINS, amplitude=1.0, f_max=1.0,
              current_noise_a=1e-3, quantum_m=1e-5)
    recs = [synthetic_record(20.0, 0.0, seed=1, **kw), synthetic_record(20.0, 2.0, seed=2, **kw)]
    res = identify_records(recs, model=arm, validation=[synthetic_record(8.0, 0.0, seed=3, **kw)],
                           options=IdentifyOptions.of(consistent=True, lag_model="off"))
    c = res.consistency
    assert c.lay.prior_source == "the robot's description"
    assert c.findings.consistent  # a URDF's bodies, identified from clean data: consistent
    assert np.abs((c.identified.chi_b - c.chi_hat) / c.sigma_b).max() < 0.5
    (ddm,) = c.direct_dynamics
    assert ddm.engine == "Pinocchio ABA on the URDF"
    assert max(j.relative for j in ddm.joints) < 0.01
