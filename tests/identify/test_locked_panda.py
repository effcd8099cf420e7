"""A robot with a gripper as it comes (issue 43): the example-robot-data Panda, whose URDF has two
finger joints, the second a mimic of the first. A robot file naming the 7 arm joints loads with
the fingers locked (``locked_joints``) or left out, and ``orthoglide-ident identify`` on its bags
(a generator that is not the identification model: Pinocchio's RNEA on the full URDF, fingers as
joints held at their opening, tests/locked_panda.py) finds the drive gains within 3 σ, says the
locked joints in its JSON, and writes an identified URDF whose fingers are fixed at that
opening."""
from __future__ import annotations

import contextlib
import io
import json

import numpy as np
import pinocchio as pin
import pytest

from orthoglide_ident import bags
from orthoglide_ident.cli import main
from orthoglide_ident.model.registry import load_robot

L = pytest.importorskip("locked_panda")
if not L.installed():
    pytest.skip("example-robot-data (requirements.txt) is not installed", allow_module_level=True)

SECONDS, NOISE_A = 20.0, 0.002  # per record; current noise (A) on currents of ~0.1-10 A


def test_the_panda_as_it_comes_is_refused_without_a_lock_and_loads_with_one(tmp_path):
    bare = load_robot(L.urdf_path())  # a bare URDF: every joint but the mimic is driven
    assert bare.joint_names == L.ARM + L.FINGERS[:1]
    for locked, opening in ((True, L.FINGER), (False, 0.0)):
        robot = load_robot(L.robot_file(tmp_path, locked))
        assert robot.joint_names == L.ARM and robot.n_b == bare.n_b - 9  # + the finger's 9
        assert [(lj.name, lj.value) for lj in robot.locked_joints] == \
            [(L.FINGERS[0], opening), (L.FINGERS[1], opening)]
        assert robot.payload_frame == L.PAYLOAD_FRAME


@pytest.fixture(scope="module")
def identified(tmp_path_factory):
    d = tmp_path_factory.mktemp("panda")
    paths = []
    for rec in L.records(SECONDS, NOISE_A):
        p = {"payload_frame": L.PAYLOAD_FRAME, "payload_com": L.PAYLOAD_COM,
             "payload_inertia": L.PAYLOAD_INERTIA} if rec.payload_mass else None
        paths.append(str(bags.write_bag(d / rec.source, rec.stamps_q_ns, rec.q, rec.v_tau,
                                        rec.condition, rec.payload_mass, L.ARM, payload=p)))
    (d / "options.yaml").write_text("lag_model: off\n")
    text = io.StringIO()
    with contextlib.redirect_stdout(text):
        code = main(["identify", *paths, "--robot", str(L.robot_file(d)), "--config",
                     str(d / "options.yaml"), "--json", str(d / "r.json"), "--urdf-out",
                     str(d / "identified.urdf")])
    assert code == 0
    return json.loads((d / "r.json").read_text()), d / "identified.urdf", text.getvalue()


def test_the_gains_come_out_within_3_sigma(identified):
    doc, _, text = identified
    g = np.array([x["value"] for x in doc["drive_gains"]])
    sigma = np.array([x["rel_std"] for x in doc["drive_gains"]])
    err = g / L.TRUE_GAINS - 1
    assert all(x["determined"] for x in doc["drive_gains"])
    assert np.all(np.abs(err) < 3 * sigma), (err, sigma)
    assert np.all(np.abs(err) < 1e-3), err  # measured: ≤ 0.02 % (docs/guide/locked_joints.md)
    assert doc["locked_joints"] == [
        {"joint": L.FINGERS[0], "value": L.FINGER, "unit": "m",
         "reason": "locked_joints of the robot file"},
        {"joint": L.FINGERS[1], "value": L.FINGER, "unit": "m",
         "reason": f"mimic joint of {L.FINGERS[0]}, locked with it"}]
    assert f"locked joints: {L.FINGERS[0]} = 0.03 m (locked_joints of the robot file)" in text


def test_the_identified_urdf_holds_the_fingers_at_their_lock(identified):
    _, urdf, _ = identified
    out = pin.buildModelFromUrdf(str(urdf))  # the fingers fixed: 7 joints
    full = pin.buildModelFromUrdf(str(L.urdf_path()))
    assert out.nq == 7 and [out.names[k] for k in range(1, 8)] == list(L.ARM)
    q = np.random.default_rng(5).uniform(-1.0, 1.0, 7)
    d_out, d_full = out.createData(), full.createData()
    pin.framesForwardKinematics(out, d_out, q)
    pin.framesForwardKinematics(full, d_full, np.r_[q, L.FINGER, L.FINGER])
    for link in ("panda_leftfinger", "panda_rightfinger", "panda_hand_tcp"):
        a = d_out.oMf[out.getFrameId(link)]
        b = d_full.oMf[full.getFrameId(link)]
        assert np.allclose(a.homogeneous, b.homogeneous, atol=1e-12), link
