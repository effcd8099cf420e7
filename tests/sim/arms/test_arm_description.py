"""Reading a serial arm for the simulator: the UR5 as bundled, bad robot files with a reason."""
from __future__ import annotations

import numpy as np
import pytest

from orthoglide_ident.errors import ConfigError
from orthoglide_sim.arms.description import load_arm, rpy_matrix

LINK = ('<link name="{0}"><inertial><mass value="1"/>'
        '<inertia ixx="1" iyy="1" izz="1"/></inertial></link>')
JOINT = (
    '<joint name="{0}" type="revolute"><parent link="{1}"/><child link="{2}"/><axis xyz="0 0 1"/>'
    '<limit lower="-1" upper="1" velocity="2" effort="10"/></joint>'
)


def test_ur5_as_bundled():
    arm = load_arm("ur5")
    assert arm.joint_names == ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint",
                               "wrist_1_joint", "wrist_2_joint", "wrist_3_joint")
    assert np.array_equal(arm.nominal_gains, [13.0, 13.0, 13.0, 9.3, 9.3, 9.3])
    assert arm.payload_frame == "tool0" and arm.joints[2].lower == pytest.approx(-np.pi)
    assert arm.inertials["upper_arm_link"].mass == 8.393
    assert np.allclose(arm.inertials["upper_arm_link"].com, [0, 0, 0.28])


def test_rpy_is_urdf_fixed_axes():
    R = rpy_matrix((0.3, -0.2, 1.1))
    Rx = rpy_matrix((0.3, 0, 0))
    Ry = rpy_matrix((0, -0.2, 0))
    Rz = rpy_matrix((0, 0, 1.1))
    assert np.allclose(R, Rz @ Ry @ Rx) and np.allclose(Rx[1:, 1:], [[np.cos(0.3), -np.sin(0.3)],
                                                                       [np.sin(0.3), np.cos(0.3)]])


def _urdf(tmp_path, body: str):
    path = tmp_path / "r.urdf"
    path.write_text(f'<robot name="r">{body}</robot>')
    return path


def test_a_chain_urdf_gets_unit_gains_and_its_last_link(tmp_path):
    arm = load_arm(_urdf(tmp_path, LINK.format("a") + LINK.format("b") + LINK.format("c")
                         + JOINT.format("j2", "b", "c") + JOINT.format("j1", "a", "b")))
    assert arm.joint_names == ("j1", "j2") and np.array_equal(arm.nominal_gains, [1, 1])
    assert arm.payload_frame == "c"


@pytest.mark.parametrize("body, reason", [
    ("<link", "not a valid URDF"),
    (LINK.format("a") + LINK.format("b") + LINK.format("c") + JOINT.format("j1", "a", "b")
     + JOINT.format("j2", "a", "c"), "does not follow"),
])
def test_bad_urdf_one_line(tmp_path, body, reason):
    with pytest.raises(ConfigError, match=reason) as exc:
        load_arm(_urdf(tmp_path, body))
    assert "\n" not in str(exc.value)


def test_bad_robot_yaml(tmp_path):
    (tmp_path / "r.yaml").write_text("description: ur5.urdf\n")
    with pytest.raises(ConfigError, match="is not a URDF file"):
        load_arm(tmp_path / "r.yaml")
    with pytest.raises(ConfigError, match="own simulator"):
        load_arm("orthoglide")
    with pytest.raises(ConfigError, match="no such file"):
        load_arm("nope")
