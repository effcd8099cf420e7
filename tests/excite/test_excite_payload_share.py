"""The design says what the payload cannot excite, as the identification would (issue 46): a gain
the payload adds less than min_payload_share of its torque to is refused by ``identify`` ("the
payload adds almost no torque on that axis", identify/solve/partial.py); the design names it
"not excited", leaves it out of its worst-gain σ and shows no number for it. A bare mass at the
UR5's flange sits on wrist_3's axis: no torque on it, whatever the motion."""
from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from orthoglide_ident.cli import main
from orthoglide_ident.excite.design import DesignOptions, design
from orthoglide_ident.excite.limits import read_limits
from orthoglide_ident.excite.trajectory import load_trajectory
from orthoglide_ident.identify.options import MIN_PAYLOAD_SHARE
from orthoglide_ident.identify.solve.factors import RecordFactors
from orthoglide_ident.identify.solve.partial import little_payload
from orthoglide_ident.model.registry import load_robot
from orthoglide_ident.model.robot import Payload

QUICK = ["--collision", "skip", "--restarts", "3", "--search", "walk", "--steps", "5",
         "--periods", "4"]
OFFSET = (0.05, 0.03, 0.06)  # m in tool0: off every wrist axis
NOT_EXCITED = "the payload adds almost no torque on wrist_3_joint's axis"


def _design_cli(tmp_path, capsys, *payload: str):
    out = tmp_path / "traj.yaml"
    assert main(["excite", "design", "--robot", "ur5", "--payload-mass", "1", *payload,
                 "--out", str(out)] + QUICK) == 0
    return capsys.readouterr().out, load_trajectory(out).extra["prediction"]


def test_a_bare_mass_on_the_ur5_leaves_wrist_3_out_and_an_offset_one_keeps_it(tmp_path, capsys):
    text, pred = _design_cli(tmp_path, capsys)
    assert f"not excited: {NOT_EXCITED}" in text and "--payload-com X,Y,Z" in text
    sigma_line = next(s for s in text.splitlines() if "gain σ:" in s)
    assert "wrist_3_joint not determined" in sigma_line, sigma_line
    assert pred["gain_rel_std"]["wrist_3_joint"] is None
    assert any(NOT_EXCITED in u for u in pred["not_excited"])
    assert pred["payload_share"]["wrist_3_joint"] < 1e-9
    assert pred["for_target"].endswith("gives every determined gain ≤ 0.2 %")
    others = [v for j, v in pred["gain_rel_std"].items() if j != "wrist_3_joint"]
    assert all(v is not None and v > 0 for v in others)
    # the worst-gain σ the search and the summary work with is that of the others
    assert pred["payloads"][1]["worst_gain_rel_std"] == pytest.approx(max(others))

    text, pred = _design_cli(tmp_path, capsys, "--payload-com", ",".join(map(str, OFFSET)))
    assert "adds almost no torque" not in text
    assert all(v is not None for v in pred["gain_rel_std"].values())
    assert min(pred["payload_share"].values()) >= MIN_PAYLOAD_SHARE
    assert pred["for_target"].endswith("gives every gain ≤ 0.2 %")


def _pinocchio_share(model: pin.Model, frame: str, mass: float, com, q, qd, qdd, tau):
    """rms payload torque / rms torque per joint: RNEA with a point mass appended at ``frame``
    minus RNEA without it (independent of the product's regressor)."""
    bare, model = model, model.copy()
    data = bare.createData()
    f = model.frames[model.getFrameId(frame)]
    model.appendBodyToJoint(f.parentJoint, pin.Inertia(mass, np.asarray(com, float),
                                                      np.zeros((3, 3))), f.placement)
    loaded_data = model.createData()
    dtau = np.array([pin.rnea(model, loaded_data, *s) - pin.rnea(bare, data, *s)
                     for s in zip(q, qd, qdd)])
    return np.sqrt((dtau ** 2).sum(axis=0) / (tau ** 2).sum(axis=1))


@pytest.mark.parametrize("com,min_share", [((0.0, 0.0, 0.0), MIN_PAYLOAD_SHARE),
                                           (OFFSET, MIN_PAYLOAD_SHARE),
                                           ((0.0, 0.0, 0.0), 0.15)])
def test_the_design_and_the_identification_give_the_same_verdict(com, min_share):
    """On the designed loaded run's states and nominal torques, the identification's rule
    (partial.little_payload on R factors of the rows [W | W_kl | v_τ]) leaves out the very
    gains the design names; the shares agree with Pinocchio's RNEA with and without the mass.
    At 15 % the rule bites on joints of the arm too, not only wrist_3."""
    robot = load_robot("ur5")
    payload = Payload(1.0, com=com)
    d = design(robot, read_limits(robot), None,
               DesignOptions(payload, np.full(robot.n_joints, 0.02), restarts=3, steps=5,
                             search="walk", periods=4, min_payload_share=min_share),
               progress=lambda _: None)
    p = d.problem
    q, qd, qdd = d.trajectory.evaluate("loaded", p.t)
    X = robot.with_payload(payload).observation_block(q, qd, qdd)
    tau = np.tensordot(p.chi_b, X[:-1], axes=(0, 0)) + payload.mass * X[-1]
    v_tau = tau / p.gains[:, None]  # the currents the nominal drives draw
    R = [np.linalg.qr(np.column_stack([X[:-1, j].T, X[-1, j], v_tau[j]]), mode="r")
         for j in range(robot.n_joints)]
    loaded = RecordFactors("loaded", payload.mass, X.shape[0] - 1, R=R)
    names = robot.joint_names
    refused = little_payload([loaded], p.gains, names, min_share)
    assert tuple(names[j] for j in sorted(refused)) == d.prediction.not_loaded
    assert ("wrist_3_joint" in d.prediction.not_loaded) == (not any(com))
    if min_share > MIN_PAYLOAD_SHARE:
        assert len(d.prediction.not_loaded) > 1
    # the search leaves out one fixed set (those free motion does not load), though the random
    # shapes' own verdicts differ at 15 %: no shape gains by unloading a joint
    starts = [e.prediction for e in d.random if e.prediction is not None]
    assert len({e.not_loaded for e in starts}) == 1
    if min_share > MIN_PAYLOAD_SHARE:
        assert len({tuple(e.payload_share < min_share) for e in starts}) > 1
    share = _pinocchio_share(robot.model, robot.payload_frame, payload.mass, com,
                             q, qd, qdd, tau)
    assert np.allclose(d.prediction.payload_share, share, rtol=1e-6, atol=1e-9)
    assert np.isinf(d.prediction.gain_rel_std[list(refused)]).all()
    kept = [j for j in range(robot.n_joints) if j not in refused]
    assert np.isfinite(d.prediction.gain_rel_std[kept]).all()
