"""A payload known by its mass only (paper Sect. 4.3): its CoM and inertia join the unknowns.

The simulated UR5 (MuJoCo, its own true inertials and drives) records 20 s unloaded and 20 s with
a 2 kg payload whose CoM is 5 cm from the flange (3 cm off the last axis), tagged with its mass
only. The product adds the payload's identifiable parameters (found by QR on random states, as
base parameters are) to the unknowns in the loaded rows; the mass column alone fixes the scale
of eq. (34). Taking the payload for a point mass at the flange instead ('point', the product's
former reading of a mass-only tag) puts the wrong known column in W_tot.
"""
from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from orthoglide_ident.errors import IdentificationError, ModelError
from orthoglide_ident.identify import IdentifyOptions, Record, identify, identify_records
from orthoglide_ident.identify.columns.layout import column_layout
from orthoglide_ident.identify.columns.payload_unknowns import payload_basis
from orthoglide_ident.model.registry import load_robot
from orthoglide_ident.model.robot import INERTIAL_KINDS, PAYLOAD_UNKNOWN, Payload, RobotModel
from orthoglide_sim.arms.description import load_arm
from orthoglide_sim.arms.record import simulate_arm
from orthoglide_sim.arms.truth import OFFSET_COM, OFFSET_PAYLOAD, load_truth, with_offset_payload


def _record(sim, name: str, payload: Payload | None) -> Record:
    cond = "unloaded" if sim.payload is None else "loaded"
    return Record.from_arrays(name, sim.stamps_ns, sim.q, sim.v_tau, cond, sim.payload_mass,
                              sim.joint_names, payload)


@pytest.fixture(scope="module")
def ur5():
    truth = with_offset_payload(load_truth(load_arm("ur5")))
    un = simulate_arm(20.0, payload=None, trajectory="exciting1", seed=0, truth=truth)
    lo = simulate_arm(20.0, payload=OFFSET_PAYLOAD, trajectory="exciting2", seed=1, truth=truth)
    model = load_robot("ur5")
    g_true = truth.drive_array("g_tau")
    return model, _record(un, "unloaded", None), lo, g_true, truth


def _gain_errors(res, g_true):
    g = np.array([x.value for x in res.drive_gains])
    return g / g_true - 1, np.array([x.rel_std for x in res.drive_gains])


def test_the_payload_basis_is_found_by_qr_on_random_states():
    """UR5 at tool0: all nine unknowns act and stay apart; every kept combination reproduces the
    columns it regroups on other random states (W_u = W_kept K)."""
    for robot, n_expected in (("ur5", 9),):
        model = load_robot(robot)
        basis = payload_basis(model, "")
        assert len(basis.kinds) == n_expected
        q, qd, qdd = model.random_states(50, seed=11)
        X = model.payload_standard_block(q, qd, qdd, "")
        W_u = np.stack([X[INERTIAL_KINDS.index(k)].ravel() for k in PAYLOAD_UNKNOWN["mass"]], 1)
        W_kept = np.stack([X[INERTIAL_KINDS.index(k)].ravel() for k in basis.kinds], 1)
        chi = np.random.default_rng(1).normal(size=9)
        assert np.allclose(W_u @ chi, W_kept @ (basis.K @ chi), rtol=1e-9, atol=1e-9)


def test_the_payload_columns_are_the_payloads_shape(ur5):
    """The ten columns at the frame, weighted by a payload's parameters per kg, are the column
    the model gives for that payload (RobotModel.with_payload): two routes, one answer."""
    model = ur5[0]
    q, qd, qdd = model.random_states(30, seed=4)
    p = Payload(2.0, "", (0.03, -0.02, 0.05), (4e-3, 1e-4, -2e-4, 3e-3, 1e-4, 2e-3))
    X = model.payload_standard_block(q, qd, qdd, "")
    bound = model.with_payload(p)
    column = bound.observation_block(q, qd, qdd)[-1]
    assert np.allclose(np.tensordot(p.shape(), X, axes=1), column, rtol=1e-12, atol=1e-12)
    # one pass of Pinocchio's regressor for W, W_kl and the ten columns, as two passes give
    both = bound.observation_and_payload_block(q, qd, qdd, "")
    two = RobotModel.observation_and_payload_block(bound, q, qd, qdd, "")
    assert np.allclose(both, two, rtol=1e-12, atol=1e-11)


def test_only_the_parameters_that_act_are_unknowns():
    """The Orthoglide's platform only translates: only the mass acts, the model is left as it
    is (closed form, and the generic Pinocchio model of it by its QR); the planar five-bar's
    tip keeps the in-plane first moments and the inertia about the normal."""
    for robot in (None, "orthoglide_general"):
        model = load_robot(robot)
        layout = column_layout(model)
        assert not layout.has_payload_unknowns and layout.names == model.names, robot
    assert payload_basis(load_robot("five_bar"), "").kinds == ("mx", "my", "zz")


def test_the_orthoglide_sample_bags_give_the_same_answer_whatever_is_known():
    """Mass only (the tag) or a point mass: one and the same identification; 'all' asks for
    the CoM and inertia the tag does not give."""
    bags = ["bags/unloaded", "bags/loaded"]
    orthoglide = load_robot("orthoglide")
    base = identify(bags, model=orthoglide).to_json()
    other = identify(bags, model=orthoglide,
                     options=IdentifyOptions.of(payload_known="point")).to_json()
    for key in ("drive_gains", "parameters", "payload_mass", "residual_rms"):
        assert other[key] == base[key], key
    assert "payload" not in base
    with pytest.raises(IdentificationError, match="bags/loaded: payload_known all needs"):
        identify(bags, model=orthoglide, options=IdentifyOptions.of(payload_known="all"))


def test_mass_only_recovers_the_gains_and_the_centre_of_mass(ur5):
    model, un, lo, g_true, truth = ur5
    res = identify_records([un, _record(lo, "loaded", Payload(2.0, known="mass"))], model=model)
    err, sig = _gain_errors(res, g_true)
    assert np.abs(err).max() < 0.005 and np.all(np.abs(err) <= 3 * sig)
    p = res.payload
    assert p is not None and p.known == "mass" and p.frame == "tool0"
    com, com_std = np.array(p.com), np.array(p.com_std)
    assert np.abs(com - OFFSET_COM).max() < 2e-3
    assert np.all(np.abs(com - OFFSET_COM) <= 3 * com_std + 1e-4)  # honest σ (+0.1 mm: jitter)
    I = truth.payloads[OFFSET_PAYLOAD].body.inertia
    I_true = I[[0, 0, 0, 1, 1, 2], [0, 1, 2, 1, 2, 2]]
    assert np.abs(np.array(p.inertia) - I_true).max() < 3e-4  # kg·m², of moments ~3e-3
    assert not any(x.name.endswith("_L") for x in res.parameters)  # the robot's list unchanged
    doc = json.loads(json.dumps(res.to_json(), allow_nan=False))
    assert doc["payload"]["known"] == "mass" and len(doc["payload"]["com"]) == 3
    assert "payload at tool0 (its mass known, CoM and inertia identified" in res.to_text()
    assert p.summary().startswith("payload at tool0: CoM (+30.0 ± 0.0, ")  # the service's reply


def test_a_point_mass_at_the_flange_is_the_wrong_known_column(ur5):
    """payload_known point: the former reading of a mass-only tag. A point on the wrist_3 axis
    puts no torque on it: a partial answer (wrist_3 not determined), or, unchecked, the gains
    off by far more than with the mass alone known."""
    model, un, lo, g_true, _ = ur5
    recs = [un, _record(lo, "loaded", None)]
    good = identify_records(recs, model=model)
    assert good.complete
    point = identify_records(recs, model=model, options=IdentifyOptions.of(payload_known="point"))
    assert not point.complete
    assert [g.name for g in point.drive_gains if not g.determined] == ["wrist_3_joint"]
    wrong = identify_records(recs, model=model,
                             options=IdentifyOptions.of(payload_known="point",
                                                        check_excitation=False))
    assert wrong.payload is None
    e_good = np.abs(_gain_errors(good, g_true)[0]).max()
    assert np.abs(_gain_errors(wrong, g_true)[0]).max() > 5 * e_good


def test_point_is_the_former_point_mass(ur5):
    """payload_known point gives exactly what a fully known point mass at the frame gives."""
    model, un, lo, _, _ = ur5
    opts = IdentifyOptions.of(check_excitation=False)
    a = identify_records([un, _record(lo, "loaded", Payload(2.0, known="point"))], model=model,
                         options=opts)
    b = identify_records([un, _record(lo, "loaded", Payload(2.0, "tool0"))], model=model,
                         options=opts)
    assert [x.value for x in a.drive_gains] == [x.value for x in b.drive_gains]
    assert [x.value for x in a.parameters] == [x.value for x in b.parameters]


def test_wls_estimates_the_mass_and_the_centre_of_mass(ur5):
    model, un, lo, g_true, _ = ur5
    res = identify_records([un, _record(lo, "loaded", None)], model=model, method="wls",
                           gains=list(g_true))
    assert abs(res.payload_mass.value / 2.0 - 1) < 0.005
    assert np.abs(np.array(res.payload.com) - OFFSET_COM).max() < 2e-3


def test_mass_and_com_known_identifies_the_inertia(ur5):
    model, un, lo, g_true, truth = ur5
    p = Payload(2.0, "", OFFSET_COM, known="com")
    res = identify_records([un, _record(lo, "loaded", p)], model=model)
    assert np.abs(_gain_errors(res, g_true)[0]).max() < 0.005
    assert res.payload.known == "com" and res.payload.com == [None] * 3
    I = truth.payloads[OFFSET_PAYLOAD].body.inertia
    assert np.abs(np.array(res.payload.inertia) - I[[0, 0, 0, 1, 1, 2], [0, 1, 2, 1, 2, 2]]).max() \
        < 3e-4


def test_what_cannot_be_done_is_a_one_line_reason(ur5):
    model, un, lo, _, _ = ur5
    a = _record(lo, "a", Payload(2.0, known="mass"))
    b = dataclasses.replace(a, source="b", payload=Payload(1.5, known="mass"), payload_mass=1.5)
    with pytest.raises(IdentificationError, match="b and a carry payloads .* identify one such"):
        identify_records([un, a, b], model=model)
    with pytest.raises(IdentificationError, match="payload_known all needs the payload's centre"):
        identify_records([un, a], model=model, options=IdentifyOptions.of(payload_known="all"))
    with pytest.raises(IdentificationError, match="--consistent needs the payload's CoM"):
        identify_records([un, a], model=model, options=IdentifyOptions.of(consistent=True))
    assert not hasattr(model, "basis")  # the robot model itself is never changed


def test_a_payload_that_does_not_act_cannot_scale(ur5):
    """A mass column that is zero everywhere (a payload on a body no joint moves) is refused."""
    class Still:
        payload_frame = "tool0"

        def random_states(self, n, seed=0):
            return ur5[0].random_states(n, seed)

        def payload_standard_block(self, q, qd, qdd, frame):
            return np.zeros((10, 6, q.shape[0]))

    with pytest.raises(ModelError, match="puts no force on any actuated joint"):
        payload_basis(Still(), "")


def test_live_follows_the_offline_answer(ur5):
    """The live identification, told the mass only (as the recorder's status carries it), folds
    the same equations and reports the same payload as offline."""
    from live_helpers import live_result, rel_diff

    model, un, lo, _, _ = ur5
    opts = IdentifyOptions.of(lag_model="off")
    records = [un, _record(lo, "loaded", Payload(2.0, known="mass"))]
    offline = identify_records(records, model=model, options=opts)
    live = live_result(model, records, opts)
    assert max(rel_diff(offline, live)) < 1e-6
    assert np.allclose(live.payload.com, offline.payload.com, rtol=1e-6, atol=1e-9)


def test_cross_validation_uses_the_identified_payload(ur5):
    """--validate on a loaded record tagged with the mass only: its torque predicted with the
    payload's identified parameters (0.2-0.5 % of each joint's rms torque here), where the
    point mass leaves the wrist's payload torque out (6-18 %)."""
    model, un, lo, _, _ = ur5
    loaded = _record(lo, "loaded", None)
    res = identify_records([un, loaded], model=model, validation=[loaded])
    point = identify_records(
        [un, loaded],
        model=model,
        validation=[loaded],
        options=IdentifyOptions.of(payload_known="point", check_excitation=False),
    )
    err = np.array([j.relative_error for j in res.validation[0].joints])
    err_point = np.array([j.relative_error for j in point.validation[0].joints])
    assert err.max() < 0.01 and err_point[-1] > 5 * err[-1]
