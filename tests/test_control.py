"""orthoglide_ident.control: the IDIM feed-forward of the CTC and its parameters."""
from __future__ import annotations

import numpy as np
import pytest

from orthoglide_ident import control as ctl
from orthoglide_ident.control import CTCParameters, feedforward, feedforward_currents
from orthoglide_ident.errors import ConfigError
from orthoglide_ident.model.orthoglide.base import base_model
from orthoglide_ident.model.registry import load_robot
from orthoglide_ident.results import Estimate, IdentificationResult, PayloadMass

ORTHOGLIDE = load_robot("orthoglide")  # the robot these records are of


def true_params(m7: float = 1.983) -> CTCParameters:
    """Base parameters of the simulator's true standard parameters, true drive gains."""
    from orthoglide_sim.orthoglide.truth import load_parameters

    tp = load_parameters()
    bm = base_model()
    return CTCParameters.from_values(bm.names, bm.base_values(tp.standard_vector()), tp.g_tau, m7,
                                     model=ORTHOGLIDE)


def fake_result(params: CTCParameters) -> IdentificationResult:
    names = base_model().names
    return IdentificationResult(
        method="tls",
        joint_names=["q11", "q12", "q13"],
        drive_gains=[
            Estimate(j, float(g), 0.001) for j, g in zip(["q11", "q12", "q13"], params.drive_gains)
        ],
        drive_gains_given=False,
        parameters=[Estimate(n, float(v), 0.01) for n, v in zip(names, params.chi_b)],
        payload_mass=PayloadMass(params.payload_mass, 0.0005, True),
        payloads=[],
        condition_number=100.0,
        residual_rms=[1.0, 1.0, 1.0],
        bags=["a", "b"],
        robot="orthoglide",
    )


def test_feedforward_equals_plant_torque_on_exact_data(monkeypatch):
    """Plant forward dynamics (Pinocchio, independent of the model; sign() friction like the model)
    under random forces, then the feed-forward at the resulting (q, qd, qdd) gives the forces
    back."""
    from orthoglide_sim.orthoglide.plant import Plant
    from orthoglide_sim.orthoglide.truth import load_parameters

    rng = np.random.default_rng(1)
    n = 12
    q, qd = 0.04 + rng.uniform(-0.08, 0.08, (n, 3)), rng.uniform(-1.0, 1.0, (n, 3))  # the safe box
    tau = np.random.default_rng(3).uniform(-300.0, 300.0, (n, 3))
    qdd = Plant(load_parameters(), "1.983", coulomb="sign").forward_dynamics(q, qd, tau)
    monkeypatch.setattr(ctl, "FF_CHUNK", 3)  # several chunks
    tau_ff = feedforward(q, qd, qdd, true_params(1.983))
    assert np.abs(tau_ff - tau).max() / np.abs(tau).max() < 1e-8


def test_feedforward_matches_the_plant_and_ignores_absent_parameters():
    """The feed-forward of the true parameters is the simulator's plant's inverse dynamics
    (Pinocchio's constraint dynamics of the legs, not the model's closed form); a subset of the
    parameters counts the absent ones as 0."""
    from ff_reference import orthoglide_currents

    from orthoglide_ident.model.orthoglide.base import random_states

    bm = base_model()
    rng = np.random.default_rng(0)
    q, qd, qdd = random_states(7, seed=5)
    p = true_params(1.0)
    # a reference of two equal samples has its "middle of the hold" at that sample
    tau_plant = np.array([orthoglide_currents(np.ones(3), 1.0, *(np.repeat(a[k:k + 1], 2, axis=0)
                                                                 for a in (q, qd, qdd)))[0]
                          for k in range(len(q))])
    np.testing.assert_allclose(feedforward(q, qd, qdd, p), tau_plant, rtol=1e-9,
                               atol=1e-9 * np.abs(tau_plant).max())
    keep = sorted(rng.choice(bm.n_b, 20, replace=False))  # an essential-like subset
    sub = CTCParameters.from_values([bm.names[i] for i in keep], p.chi_b[keep], p.drive_gains, 1.0,
                                    model=ORTHOGLIDE)
    chi = np.zeros(bm.n_b)
    chi[keep] = p.chi_b[keep]
    assert np.allclose(sub.chi_b, chi)
    padded = CTCParameters.from_values(bm.names, chi, p.drive_gains, 1.0, model=ORTHOGLIDE)
    np.testing.assert_array_equal(feedforward(q, qd, qdd, sub), feedforward(q, qd, qdd, padded))


def test_feedforward_currents_in_the_middle_of_each_hold_over_the_gains():
    """Tick k's current is the model force at the mean of samples k and k+1 (t_k + T/2 for a
    smooth reference) divided by g_tau; N samples give N - 1 ticks."""
    from orthoglide_ident.model.orthoglide.base import random_states

    q, qd, qdd = random_states(6, seed=2)
    p = true_params()
    v_ff = feedforward_currents(q, qd, qdd, p)
    mid = [0.5 * (a[:-1] + a[1:]) for a in (q, qd, qdd)]
    assert v_ff.shape == (5, 3)
    np.testing.assert_allclose(v_ff * p.drive_gains, feedforward(*mid, p), rtol=1e-12)


def test_feedforward_currents_of_a_quintic_are_the_half_tick_model():
    """On a smooth test trajectory the mean of two ticks is the reference at t_k + T/2 to ~1e-6
    m."""
    from orthoglide_sim.common.trajectories import get_trajectory

    traj = get_trajectory("test2")
    t = np.arange(0.0, 0.5, 1e-3)
    p = true_params()
    v_ff = feedforward_currents(*traj.evaluate(t), p)
    exact = feedforward(*traj.evaluate(t[:-1] + 0.5e-3), p) / p.drive_gains
    assert np.abs(v_ff - exact).max() < 2e-3 * np.abs(exact).max()


def test_parameters_from_result_and_message_agree():
    p = true_params()
    res = fake_result(p)
    a = CTCParameters.from_result(res, model=ORTHOGLIDE)
    b = CTCParameters.from_message_fields(res.message_fields(), model=ORTHOGLIDE)
    for x in (a, b):
        np.testing.assert_array_equal(x.chi_b, p.chi_b)
        np.testing.assert_array_equal(x.drive_gains, p.drive_gains)
        assert x.payload_mass == p.payload_mass
    c = CTCParameters.from_result(res, payload_mass=1.136, drive_gains=[2001.0] * 3,
                                  model=ORTHOGLIDE)
    assert c.payload_mass == 1.136 and list(c.drive_gains) == [2001.0] * 3
    d = a.with_gains([1.0, 2.0, 3.0])
    np.testing.assert_array_equal(d.chi_b, a.chi_b)
    with pytest.raises(ConfigError, match="essential"):
        CTCParameters.from_result(res, essential=True, model=ORTHOGLIDE)


@pytest.mark.parametrize("change, match", [
    ({"names": ["m_11R", "not_a_parameter"], "values": [1.0, 2.0]}, "unknown base parameter"),
    ({"names": ["m_11R"], "values": [1.0, 2.0]}, "1 parameter names but 2 values"),
    ({"names": [], "values": []}, "no dynamic parameters"),
    ({"names": ["m_11R", "m_11R"], "values": [1.0, 2.0]}, "repeated"),
    ({"names": ["m_11R"], "values": [float("nan")]}, "non-finite"),
    ({"drive_gains": [2001.0, 2001.0]}, "drive_gains"),
    ({"drive_gains": [2001.0, -1.0, 2001.0]}, "drive_gains"),
    ({"payload_mass": -1.0}, "payload mass"),
    ({"values": ["heavy"]}, "not numbers"),
])
def test_bad_parameters_raise_config_error(change, match):
    fields = {
        "names": ["m_11R"],
        "values": [1.0],
        "drive_gains": [2001.0] * 3,
        "payload_mass": 1.983,
    }
    fields.update(change)
    with pytest.raises(ConfigError, match=match):
        CTCParameters.from_message_fields(fields, model=ORTHOGLIDE)


def test_missing_field_raises_config_error():
    with pytest.raises(ConfigError, match="lack field"):
        CTCParameters.from_message_fields({"names": ["m_11R"], "values": [1.0]}, model=ORTHOGLIDE)


COUPLED_N = np.array([[32, 0, 0, 0, 0, 0], [0, 32, 0, 0, 0, 0], [0, 0, 45, 0, 0, 0],
                      [0, 0, 0, -48, 0, 0], [0, 0, 0, 0, 45, 0], [0, 0, 0, 0, 32, 32]], float)


def _coupled_ur5(tmp_path):
    """The UR5 behind the issue's coupled wrist (the last motor turns with q5 + q6)."""
    import yaml

    from orthoglide_ident.model.registry import ROBOTS_DIR

    data = yaml.safe_load((ROBOTS_DIR / "ur5.yaml").read_text())
    data.pop("excitation")
    data.update(name="ur5_coupled_ctc", description=str(ROBOTS_DIR / "ur5.urdf"),
                nominal_gains=[0.13, 0.13, 0.1, 0.1, 0.1, 0.1],
                transmission={"actuators": [f"m{k}" for k in range(1, 7)],
                              "reduction": COUPLED_N.tolist(),
                              "offset": [0.0, 0.0, 0.0, 1.0, 0.0, -2.0]})
    path = tmp_path / "ur5_coupled_ctc.yaml"
    path.write_text(yaml.safe_dump(data))
    return load_robot(path)


def test_feedforward_currents_through_a_coupled_transmission_are_per_motor(tmp_path):
    """The identified actuator-space model fed a joint-side reference gives each motor's current
    v_m = diag(g)⁻¹ (N⁻ᵀ τ_j + ia q̈_m + fv q̇_m + fs sign(q̇_m) + off), τ_j from Pinocchio's
    RNEA of the URDF (not the regressor), the motor states q̇_m = N q̇_j at mid-hold."""
    import pinocchio as pin

    from orthoglide_ident.model.registry import ROBOTS_DIR

    robot = _coupled_ur5(tmp_path)
    assert robot.joint_names == tuple(f"m{k}" for k in range(1, 7))
    ia, fv = np.full(6, 2e-5), np.linspace(1e-4, 3e-4, 6)
    fs, off = np.linspace(0.02, 0.05, 6), np.linspace(-0.003, 0.003, 6)
    chi_st = robot.standard_values()
    index = {n: k for k, n in enumerate(robot.standard_names)}
    for a, m in enumerate(robot.joint_names):
        for kind, val in (("ia", ia), ("fv", fv), ("fs", fs), ("tauoff", off)):
            chi_st[index[f"{kind}_{m}"]] = val[a]
    g = np.array([0.134, 0.126, 0.102, 0.096, 0.104, 0.097])
    params = CTCParameters.from_values(robot.names, robot.K @ chi_st, g, 0.0, model=robot)
    rng = np.random.default_rng(4)
    q, qd, qdd = rng.uniform(-1, 1, (9, 6)), rng.uniform(-2, 2, (9, 6)), rng.uniform(-5, 5, (9, 6))
    v = feedforward_currents(q, qd, qdd, params)
    assert v.shape == (8, 6)
    pm = pin.buildModelFromUrdf(str(ROBOTS_DIR / "ur5.urdf"))
    pm.gravity = pin.Motion(np.array(robot.gravity), np.zeros(3))  # the robot file's
    pd = pm.createData()
    mid = [0.5 * (a[:-1] + a[1:]) for a in (q, qd, qdd)]
    tau_j = np.array([pin.rnea(pm, pd, *s) for s in zip(*mid)])
    qd_m, qdd_m = mid[1] @ COUPLED_N.T, mid[2] @ COUPLED_N.T
    tau_m = tau_j @ np.linalg.inv(COUPLED_N) + ia * qdd_m + fv * qd_m + fs * np.sign(qd_m) + off
    np.testing.assert_allclose(v, tau_m / g, rtol=1e-9, atol=1e-9 * np.abs(tau_m / g).max())
