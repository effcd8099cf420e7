"""The identified robot as an MJCF (model/mjcf_out.py), checked against MuJoCo itself: the file
loads, and MuJoCo's inverse dynamics (mj_inverse, friction loss and contacts off) gives the
model's own torques (Pinocchio's regressor times χ_st, Coulomb friction and offsets aside) —
a serial UR5, and the UR5 behind a coupled-wrist transmission (tendons)."""
from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest
import yaml

from orthoglide_ident.model.mjcf_check import inverse_dynamics_rms
from orthoglide_ident.model.mjcf_check import model_torques as _model_torques
from orthoglide_ident.model.mjcf_check import mujoco_torques as _mujoco_torques
from orthoglide_ident.model.mjcf_check import rms_error as _rms_error
from orthoglide_ident.model.mjcf_out import identified_mjcf
from orthoglide_ident.model.registry import ROBOTS_DIR, load_robot

RTOL = 1e-4  # MuJoCo writes 6 significant digits; the bar is 1 % rms per joint
JOINTS = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint",
          "wrist_2_joint", "wrist_3_joint"]
COUPLED = [[32, 0, 0, 0, 0, 0], [0, 32, 0, 0, 0, 0], [0, 0, 45, 0, 0, 0],
           [0, 0, 0, -48, 0, 0], [0, 0, 0, 0, 45, 0], [0, 0, 0, 0, 32, 32]]


def _identified_like(robot, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """A consistent χ_st (the description's inertials, positive drive terms) and gains."""
    rng = np.random.default_rng(seed)
    chi = robot.standard_values().copy()
    for i, name in enumerate(robot.standard_names):
        kind = name.split("_", 1)[0]
        if kind in ("ia", "fv", "fs"):
            chi[i] = rng.uniform(0.01, 0.5) * (1e-3 if robot.transmission is not None else 1.0)
        elif kind == "tauoff":
            chi[i] = 0.2
    return chi, rng.uniform(5.0, 15.0, robot.n_joints)


def test_ur5_mjcf_reproduces_the_model(tmp_path):
    rf = tmp_path / "ur5.yaml"  # the UR5 with its current limits (A) for the ctrlrange
    doc = yaml.safe_load((ROBOTS_DIR / "ur5.yaml").read_text())
    doc["description"] = str(ROBOTS_DIR / "ur5.urdf")
    doc["excitation"]["current_limits"] = [11.5, 11.5, 11.5, 3.0, 3.0, 3.0]
    rf.write_text(yaml.safe_dump(doc))
    robot = load_robot(rf)
    chi, gains = _identified_like(robot)
    text, notes = identified_mjcf(robot, chi, gains)
    assert "torque offsets tauoff have no MJCF element" in notes[-1]
    m = mujoco.MjModel.from_xml_string(text)
    assert [m.joint(i).name for i in range(m.njnt)] == JOINTS  # the URDF's names
    assert text.count("<motor ") == 6
    named = dict(zip(robot.standard_names, chi))
    for a, j in enumerate(JOINTS):
        act, jnt, label = m.actuator(a), m.joint(j), str(a + 1)
        assert m.actuator_trnid[a, 0] == jnt.id
        assert act.gear[0] == pytest.approx(gains[a], rel=1e-5)
        assert m.dof_armature[jnt.dofadr[0]] == pytest.approx(named[f"ia_{label}"], rel=1e-5)
        assert m.dof_damping[jnt.dofadr[0]] == pytest.approx(named[f"fv_{label}"], rel=1e-5)
        assert m.dof_frictionloss[jnt.dofadr[0]] == pytest.approx(named[f"fs_{label}"], rel=1e-5)
        # a stiff friction loss: Coulomb's law turns within ~0.01 rad/s, not MuJoCo's 0.15
        assert m.dof_solref[jnt.dofadr[0]].tolist() == pytest.approx([2e-3, 1.0])
        assert act.ctrlrange.tolist() == [-doc["excitation"]["current_limits"][a],
                                          doc["excitation"]["current_limits"][a]]
    q, qd, qdd = robot.random_states(40, seed=1)
    ref = _model_torques(robot, chi, q, qd, qdd)
    assert np.all(_rms_error(ref, _mujoco_torques(text, JOINTS, q, qd, qdd)) < RTOL)


def test_coupled_wrist_mjcf_reproduces_the_model(tmp_path):
    rf = tmp_path / "coupled.yaml"
    rf.write_text(yaml.safe_dump({
        "name": "ur5_coupled", "description": str(ROBOTS_DIR / "ur5.urdf"),
        "actuated_joints": JOINTS, "payload_frame": "tool0",
        "transmission": {"actuators": [f"motor_{k}" for k in range(1, 7)],
                         "reduction": COUPLED}}))
    robot = load_robot(rf)
    chi, gains = _identified_like(robot, seed=2)
    text, _ = identified_mjcf(robot, chi, gains)
    assert "<tendon>" in text and 'tendon="motor_6_drive"' in text
    q_m, qd_m, qdd_m = robot.random_states(40, seed=3)
    t = robot.transmission
    q, qd, qdd = t.to_joint_position(q_m), t.to_joint_rate(qd_m), t.to_joint_rate(qdd_m)
    tau_j = _mujoco_torques(text, JOINTS, q, qd, qdd)
    tau_m = np.linalg.solve(np.asarray(COUPLED, float).T, tau_j.T).T  # τ_j = Nᵀ τ_m
    ref = _model_torques(robot, chi, q_m, qd_m, qdd_m)
    assert np.all(_rms_error(ref, tau_m) < RTOL)
    assert np.all(inverse_dynamics_rms(text, robot, chi, q_m, qd_m, qdd_m) < RTOL)  # the same
    m = mujoco.MjModel.from_xml_string(text)  # motor a's control u gives τ_j = Nᵀ (g ⊙ u)
    d = mujoco.MjData(m)
    d.ctrl[:] = 0.01  # A: within the URDF's joint effort limits (actuatorfrcrange)
    mujoco.mj_forward(m, d)
    va = m.jnt_dofadr[[m.joint(j).id for j in JOINTS]]
    np.testing.assert_allclose(d.qfrc_actuator[va], np.asarray(COUPLED, float).T @ gains * 0.01,
                               rtol=1e-5)


def test_a_closed_chain_is_refused_in_one_line():
    robot = load_robot("five_bar")
    chi = robot.standard_values()
    with pytest.raises(Exception, match="--mjcf-out: robot .* is a closed chain"):
        identified_mjcf(robot, chi, np.ones(robot.n_joints))


def test_identified_mjcf_file_is_standalone(tmp_path):
    robot = load_robot(ROBOTS_DIR / "ur5.yaml")
    chi, gains = _identified_like(robot)
    path = tmp_path / "ur5.xml"
    path.write_text(identified_mjcf(robot, chi, gains)[0])
    assert mujoco.MjModel.from_xml_path(str(Path(path))).nu == 6


@pytest.mark.slow
def test_identify_writes_an_mjcf_that_reproduces_the_identified_ur5(tmp_path):
    """The CLI on a simulated UR5 run: the written file's inverse dynamics along the record's
    states is the identified (consistent) model's to <= 1 % rms per joint."""
    import json
    import subprocess
    import sys

    from orthoglide_sim.arm_or_chain.bags import write_record
    from orthoglide_sim.arms.record import simulate_arm

    runs = [simulate_arm(10.0, "ur5", payload=p, trajectory=t, seed=s)
            for p, t, s in ((None, "exciting1", 0), ("2.0", "exciting2", 1))]
    bags = [str(write_record(tmp_path / f"r{i}", r)) for i, r in enumerate(runs)]
    out, js = tmp_path / "deep" / "ur5.xml", tmp_path / "r.json"
    p = subprocess.run([sys.executable, "-m", "orthoglide_ident.cli", "identify", "--robot", "ur5",
                        *bags, "--mjcf-out", str(out), "--json", str(js)],
                       capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr
    assert "running the consistency step" in p.stderr and f"wrote {out}" in p.stderr
    robot = load_robot("ur5")
    named = json.loads(js.read_text())["consistency"]["standard"]
    chi = np.array([named[n] for n in robot.standard_names])
    k = slice(100, None, 20)
    q, qd = runs[0].q_true[k], runs[0].qd_true[k]
    qdd = np.gradient(runs[0].qd_true, 1e-3, axis=0)[k]
    ref = _model_torques(robot, chi, q, qd, qdd)
    assert np.all(_rms_error(ref, _mujoco_torques(out.read_text(), JOINTS, q, qd, qdd)) < 0.01)


def test_an_mjcf_robot_comes_back_as_its_own_mjcf():
    mjcf = Path(__file__).resolve().parents[1] / "fixtures" / "mjcf" / "three_link.xml"
    robot = load_robot(mjcf)
    chi, gains = _identified_like(robot, seed=5)
    named = dict(zip(robot.standard_names, chi))
    named["m_2"] *= 1.1  # an identified body differs from the file's
    chi = np.array([named[n] for n in robot.standard_names])
    text, _ = identified_mjcf(robot, chi, gains)
    q, qd, qdd = robot.random_states(30, seed=6)
    ref = _model_torques(robot, chi, q, qd, qdd)
    got = _mujoco_torques(text, list(robot.joint_names), q, qd, qdd)
    assert np.all(_rms_error(ref, got) < RTOL)
    assert mujoco.MjModel.from_xml_string(text).body("link2").mass[0] == pytest.approx(2.75)
