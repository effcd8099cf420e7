"""A URDF's mimic joints follow their leader (issue 32): not actuated, q_m = r q_l + o in the
tree states, the mimic's torque added r times to the leader's; checked against Pinocchio's RNEA
on the open tree (a second algorithm), and what is not supported is said."""
from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.model.registry import load_robot

R, OFFSET = -0.5, 0.1
URDF = f"""<?xml version="1.0"?>
<robot name="pinch">
  <link name="base"/>
  <link name="a"><inertial><origin xyz="0.02 0.01 0.1"/><mass value="2.0"/>
    <inertia ixx="0.02" ixy="0.001" ixz="0.0" iyy="0.03" iyz="0.0" izz="0.01"/></inertial></link>
  <link name="b"><inertial><origin xyz="0.1 0.0 0.01"/><mass value="1.0"/>
    <inertia ixx="0.003" ixy="0.0" ixz="0.0002" iyy="0.01" iyz="0.0" izz="0.01"/></inertial></link>
  <link name="c"><inertial><origin xyz="0.05 0.02 0.0"/><mass value="0.5"/>
    <inertia ixx="0.001" ixy="0.0" ixz="0.0" iyy="0.002" iyz="0.0001"
    izz="0.002"/></inertial></link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="a"/><origin xyz="0 0 0.1"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="10" velocity="3"/></joint>
  <joint name="j2" type="revolute"><parent link="a"/><child link="b"/>
    <origin xyz="0 0 0.2" rpy="1.5707963267948966 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-2" upper="2" effort="10" velocity="3"/></joint>
  <joint name="j3" type="revolute"><parent link="b"/><child link="c"/><origin xyz="0.25 0 0"/>
    <axis xyz="1 0 0"/><limit lower="-2" upper="2" effort="10" velocity="3"/>
    <mimic joint="j2" multiplier="{R}" offset="{OFFSET}"/></joint>
</robot>
"""


@pytest.fixture(scope="module")
def urdf(tmp_path_factory):
    path = tmp_path_factory.mktemp("mimic") / "pinch.urdf"
    path.write_text(URDF)
    return path


def test_a_mimic_joint_is_not_actuated(urdf):
    robot = load_robot(urdf)
    assert robot.joint_names == ("j1", "j2")
    assert not any(n.endswith("_3") for n in robot.standard_names if n.startswith(("fv", "ia")))


def test_rows_are_the_open_tree_s_rnea_with_the_mimic_s_torque_on_its_leader(urdf):
    robot = load_robot(urdf)
    model = pin.buildModelFromUrdf(str(urdf))  # j3 an independent joint: the open tree
    model.gravity = pin.Motion(np.array([0.0, 0.0, -9.80665]), np.zeros(3))  # the product's g
    data = model.createData()
    q, qd, qdd = robot.random_states(40, seed=3)
    W = robot.standard_regressor(q, qd, qdd)
    tau = (W @ robot.standard_values()).reshape(2, -1).T  # rows joint by joint
    want = []
    for k in range(len(q)):
        qt = np.array([q[k, 0], q[k, 1], R * q[k, 1] + OFFSET])
        vt = np.array([qd[k, 0], qd[k, 1], R * qd[k, 1]])
        at = np.array([qdd[k, 0], qdd[k, 1], R * qdd[k, 1]])
        t = pin.rnea(model, data, qt, vt, at)
        want.append([t[0], t[1] + R * t[2]])
    assert np.allclose(tau, want, rtol=1e-9, atol=1e-12), np.abs(tau - want).max()


def test_a_mimic_joint_named_actuated_is_refused_naming_it(urdf, tmp_path):
    yaml = tmp_path / "pinch.yaml"
    yaml.write_text(f"description: {urdf}\nactuated_joints: [j1, j3]\n")
    with pytest.raises(ConfigError, match=r"'j3' is a mimic joint .* \(it follows 'j2'\): "
                                          "actuate its leader"):
        load_robot(yaml)


def test_a_mimic_of_a_joint_left_out_is_locked_with_it(urdf, tmp_path):
    """Issue 43: its leader left out of actuated_joints (an open tree), both are locked, the
    leader at 0 (within its limits), the mimic at r·0 + offset: no hand edit of the URDF."""
    yaml = tmp_path / "pinch.yaml"
    yaml.write_text(f"description: {urdf}\nactuated_joints: [j1]\n")
    robot = load_robot(yaml)
    assert robot.joint_names == ("j1",)
    assert [(lj.name, lj.value, lj.why) for lj in robot.locked_joints] == \
        [("j2", 0.0, "unlisted"), ("j3", OFFSET, "mimic")]
