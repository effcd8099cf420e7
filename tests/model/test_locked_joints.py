"""Locked joints (issue 43): a robot file's ``locked_joints`` fixes joints, and the mimic joints
that follow them, before anything else. References: the same URDF reduced by hand (the fingers'
joints written as fixed ones at the locked opening), Pinocchio's RNEA on the full tree with the
fingers held there, and the identified URDF loaded back."""
from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.model.registry import load_robot
from orthoglide_ident.model.urdf import urdf_with_inertials

YAW = 0.3  # rad, the left finger's joint frame about z
OFFSET = 0.001  # m, the right finger's mimic offset
LINKS = """
  <link name="base"/>
  <link name="a"><inertial><origin xyz="0.02 0.01 0.1"/><mass value="2.0"/>
    <inertia ixx="0.02" ixy="0.001" ixz="0.0" iyy="0.03" iyz="0.0" izz="0.01"/></inertial></link>
  <link name="b"><inertial><origin xyz="0.1 0.0 0.01"/><mass value="1.0"/>
    <inertia ixx="0.003" ixy="0.0" ixz="0.0002" iyy="0.01" iyz="0.0" izz="0.01"/>
  </inertial></link>
  <link name="c"><inertial><origin xyz="0.03 0.01 0.0"/><mass value="0.6"/>
    <inertia ixx="0.001" ixy="0.0" ixz="0.0" iyy="0.002" iyz="0.0001" izz="0.002"/>
  </inertial></link>
  <link name="hand"><inertial><origin xyz="0.02 0.0 0.01"/><mass value="0.4"/>
    <inertia ixx="0.0005" ixy="0.0" ixz="0.0" iyy="0.0006" iyz="0.0" izz="0.0004"/>
  </inertial></link>
  <link name="fl"><inertial><origin xyz="0.01 0.005 0.0"/><mass value="0.08"/>
    <inertia ixx="2e-5" ixy="0.0" ixz="0.0" iyy="3e-5" iyz="0.0" izz="2e-5"/></inertial></link>
  <link name="fr"><inertial><origin xyz="0.01 -0.004 0.002"/><mass value="0.07"/>
    <inertia ixx="2e-5" ixy="1e-6" ixz="0.0" iyy="3e-5" iyz="0.0" izz="2e-5"/></inertial></link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="a"/><origin xyz="0 0 0.1"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="10" velocity="3"/></joint>
  <joint name="j2" type="revolute"><parent link="a"/><child link="b"/>
    <origin xyz="0 0 0.2" rpy="1.5707963267948966 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-2" upper="2" effort="10" velocity="3"/></joint>
  <joint name="j3" type="revolute"><parent link="b"/><child link="c"/><origin xyz="0.25 0 0"/>
    <axis xyz="1 0 0"/><limit lower="-3" upper="3" effort="10" velocity="3"/></joint>
  <joint name="hand_fixed" type="fixed"><parent link="c"/><child link="hand"/>
    <origin xyz="0.06 0 0"/></joint>
"""
FINGERS = f"""
  <joint name="f1" type="prismatic"><parent link="hand"/><child link="fl"/>
    <origin xyz="0.05 0.01 0" rpy="0 0 {YAW}"/><axis xyz="1 0 0"/>
    <limit lower="0" upper="0.04" effort="10" velocity="0.2"/></joint>
  <joint name="f2" type="prismatic"><parent link="hand"/><child link="fr"/>
    <origin xyz="0.05 -0.01 0"/><axis xyz="0 -1 0"/>
    <limit lower="0" upper="0.0405" effort="10" velocity="0.2"/>
    <mimic joint="f1" multiplier="1" offset="{OFFSET}"/></joint>
"""


def fixed_fingers(opening: float) -> str:
    """The fingers' joints written by hand as fixed joints at ``opening`` (f2 at its mimic's
    opening + OFFSET): f1 moves along its own x axis, Rz(YAW) in the hand's frame."""
    x, y = 0.05 + opening * math.cos(YAW), 0.01 + opening * math.sin(YAW)
    return f"""
  <joint name="f1" type="fixed"><parent link="hand"/><child link="fl"/>
    <origin xyz="{x!r} {y!r} 0" rpy="0 0 {YAW}"/></joint>
  <joint name="f2" type="fixed"><parent link="hand"/><child link="fr"/>
    <origin xyz="0.05 {-0.01 - (opening + OFFSET)!r} 0"/></joint>
"""


def urdf(tmp_path, name: str, fingers: str) -> str:
    path = tmp_path / f"{name}.urdf"
    path.write_text(f'<?xml version="1.0"?>\n<robot name="{name}">{LINKS}{fingers}</robot>\n')
    return str(path)


def robot_file(tmp_path, body: str, name: str = "gripper") -> str:
    path = tmp_path / f"{name}.yaml"
    path.write_text(f"name: gripper\ndescription: {urdf(tmp_path, 'gripper', FINGERS)}\n{body}")
    return str(path)


def full_rnea(tmp_path, opening: float, q, qd, qdd) -> np.ndarray:
    """τ of j1..j3 by Pinocchio's RNEA on the full tree, the fingers at rest at the opening."""
    model = pin.buildModelFromUrdf(urdf(tmp_path, "full", FINGERS))
    model.gravity = pin.Motion(np.array([0.0, 0.0, -9.80665]), np.zeros(3))
    data, tail, zero = model.createData(), np.array([opening, opening + OFFSET]), np.zeros(2)
    return np.array([pin.rnea(model, data, np.r_[q[k], tail], np.r_[qd[k], zero],
                              np.r_[qdd[k], zero])[:3] for k in range(len(q))])


@pytest.mark.parametrize("body, opening", [
    ("locked_joints: {f1: 0.015}\n", 0.015),
    ("actuated_joints: [j1, j2, j3]\n", 0.0),  # the fingers left out: locked at 0, in limits
])
def test_locked_fingers_are_the_hand_reduced_urdf(tmp_path, body, opening):
    robot = load_robot(robot_file(tmp_path, body))
    hand = load_robot(urdf(tmp_path, "hand", fixed_fingers(opening)))
    assert robot.joint_names == hand.joint_names == ("j1", "j2", "j3")
    assert [lj.name for lj in robot.locked_joints] == ["f1", "f2"]
    assert robot.locked_joints[1].value == pytest.approx(opening + OFFSET, abs=1e-15)
    assert robot.names == hand.names
    want = hand.base_values(hand.standard_values())
    assert np.allclose(robot.base_values(robot.standard_values()), want, rtol=1e-10, atol=1e-13)
    q, qd, qdd = robot.random_states(30, seed=4)
    tau = (robot.standard_regressor(q, qd, qdd) @ robot.standard_values()).reshape(3, -1).T
    assert np.allclose(tau, full_rnea(tmp_path, opening, q, qd, qdd), rtol=1e-9, atol=1e-12)


def test_the_key_round_trips_through_the_model_and_its_identified_urdf(tmp_path):
    robot = load_robot(robot_file(tmp_path, "locked_joints: {j3: 0.4, f1: 0.02}\n"))
    assert robot.joint_names == ("j1", "j2")
    assert robot.description.locked_joints == {"j3": 0.4, "f1": 0.02}
    doc = robot.to_json()["locked_joints"]
    assert doc == [{"joint": "j3", "value": 0.4, "unit": "rad",
                    "reason": "locked_joints of the robot file"},
                   {"joint": "f1", "value": 0.02, "unit": "m",
                    "reason": "locked_joints of the robot file"},
                   {"joint": "f2", "value": 0.02 + OFFSET, "unit": "m",
                    "reason": "mimic joint of f1, locked with it"}]
    assert "Locked joints: j3 = 0.4 rad" in robot.table()
    # the identified URDF (here the description's own values) fixes them: loaded back as a bare
    # URDF it is the same robot, the locked links' inertia in the body they are fixed to
    chi = robot.standard_values()
    out = tmp_path / "identified.urdf"
    out.write_text(urdf_with_inertials(robot, chi, [1.0, 1.0]))
    again = load_robot(out)
    assert again.joint_names == ("j1", "j2") and again.names == robot.names
    assert np.allclose(again.base_values(again.standard_values()), robot.base_values(chi),
                       rtol=1e-10, atol=1e-13)
    text = out.read_text()
    assert "locked at 0.40000000000000002 rad (locked_joints of the robot file)" in text
    assert "<mimic" not in text


@pytest.mark.parametrize("body, reason", [
    ("locked_joints: {nope: 0.1}\n", r"locked_joints: 'nope' is not a movable joint of "
                                     r"gripper\.urdf \(movable 1-DOF joints: j1, j2, j3, f1, f2\)"),
    ("locked_joints: {f1: 0.05}\n", r"locked_joints: f1 = 0\.05 is outside its limits "
                                    r"\[0, 0\.04\] m in gripper\.urdf"),
    ("actuated_joints: [j1, j2, j3]\nlocked_joints: {j3: 0.1}\n",
     r"locked_joints: 'j3' is also in actuated_joints"),
    ("locked_joints: {f2: 0.01}\n", r"locked_joints: 'f2' is a mimic joint of 'f1' in "
                                    r"gripper\.urdf: lock its leader"),
    ("locked_joints: {f1: 0.04}\n", r"mimic joint f2 follows f1 = 0\.04 to 0\.041, outside its "
                                    r"limits \[0, 0\.0405\] m"),
    ("locked_joints: {f1: 0.01, f2: 0.02}\n", r"f2 = 0\.02, but it follows f1 = 0\.01"),
    ("locked_joints: {f1: open}\n", r"locked_joints\.f1: expected a number, got 'open'"),
    ("locked_joints: [f1]\n", r"locked_joints: expected a mapping"),
    ("actuated_joints: [j1, j2, j3]\nreference_configuration: {f1: 0.1}\n",
     r"reference_configuration: f1 = 0\.1 .*outside its limits"),
])
def test_a_wrong_lock_is_refused_naming_the_file_and_the_joint(tmp_path, body, reason):
    path = robot_file(tmp_path, body)
    with pytest.raises(ConfigError, match=reason) as exc:
        load_robot(path)
    assert str(exc.value).startswith(f"robot file {path}: ") and "\n" not in str(exc.value)


def test_a_joint_left_out_that_no_mimic_follows_is_still_refused(tmp_path):
    """Only a gripper's joint (a mimic's leader) is locked when left out: a forgotten arm joint
    would be a silently wrong model."""
    with pytest.raises(ConfigError, match=r"joints \['j3'\] move but are neither actuated nor "
                                          r"closed by a loop: .*lock them \(locked_joints"):
        load_robot(robot_file(tmp_path, "actuated_joints: [j1, j2]\n"))
