"""Limits read from the URDF, the robot file and a ros2_control joint_limits YAML."""
from __future__ import annotations

import math

import numpy as np
import pytest
from excite_robots import two_link_urdf

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.excite.limits import home_pose, read_limits
from orthoglide_ident.model.registry import load_robot


def test_ur5_limits_from_its_urdf_and_robot_file():
    lim = read_limits(load_robot("ur5"))
    assert lim.lower[0] == pytest.approx(-2 * math.pi) and lim.upper[2] == pytest.approx(math.pi)
    np.testing.assert_allclose(lim.velocity, [3.15, 3.15, 3.15, 3.2, 3.2, 3.2])
    np.testing.assert_allclose(lim.effort, [150, 150, 150, 28, 28, 28])
    np.testing.assert_allclose(lim.acceleration, [8, 8, 12, 15, 15, 15])  # robot file
    assert lim.sources["velocity"] == "ur5.urdf" and "robot file" in lim.sources["acceleration"]
    assert home_pose(load_robot("ur5"), lim)[1] == pytest.approx(-2.0)


def test_the_mounted_ur5_designs_within_the_ur5s_limits():
    """ur5_mount.yaml carries ur5.yaml's excitation section (write_mounted_robot copies it)."""
    a, b = read_limits(load_robot("ur5_mount")), read_limits(load_robot("ur5"))
    for kind in ("lower", "upper", "velocity", "acceleration", "effort"):
        np.testing.assert_array_equal(getattr(a, kind), getattr(b, kind))
    assert home_pose(load_robot("ur5_mount"), a)[1] == pytest.approx(-2.0)


def test_ros2_control_joint_limits_override(tmp_path):
    f = tmp_path / "joint_limits.yaml"
    f.write_text("joint_limits:\n  elbow_joint:\n    has_velocity_limits: true\n"
                 "    max_velocity: 1.5\n    has_acceleration_limits: true\n"
                 "    max_acceleration: 4.0\n    has_effort_limits: false\n    max_effort: 1.0\n")
    lim = read_limits(load_robot("ur5"), f)
    assert lim.velocity[2] == 1.5 and lim.acceleration[2] == 4.0
    assert lim.effort[2] == 150.0  # has_effort_limits: false leaves the URDF's
    assert lim.sources["acceleration"] == str(f)


def _robot_yaml(tmp_path, urdf, excitation: str = "") -> str:
    y = tmp_path / "arm.yaml"
    y.write_text(f"name: two_link\ndescription: {urdf.name}\nnominal_gains: 2.0\n{excitation}")
    return str(y)


def test_current_limits_go_through_the_nominal_gains(tmp_path):
    urdf = two_link_urdf(tmp_path)
    robot = load_robot(_robot_yaml(tmp_path, urdf, "excitation:\n  acceleration_limits: 10.0\n"
                                                   "  current_limits: [3.0, 4.0]\n"))
    lim = read_limits(robot)
    np.testing.assert_allclose(lim.effort, [6.0, 8.0])  # A × 2 N·m/A, over the URDF's 20
    np.testing.assert_allclose(lim.acceleration, [10.0, 10.0])


def test_a_urdf_without_limits_is_refused_with_a_reason(tmp_path):
    urdf = two_link_urdf(tmp_path, limits=False)
    with pytest.raises(ConfigError, match="joint j1 has no position limit"):
        read_limits(load_robot(str(urdf)))


def test_no_acceleration_limit_says_where_to_give_one(tmp_path):
    urdf = two_link_urdf(tmp_path)
    with pytest.raises(ConfigError, match="no acceleration limit.*--joint-limits"):
        read_limits(load_robot(str(urdf)), derive_acceleration=False)


def test_a_typo_in_the_excitation_section_is_refused(tmp_path):
    urdf = two_link_urdf(tmp_path)
    robot = load_robot(_robot_yaml(tmp_path, urdf, "excitation:\n  acceleration_limit: 10.0\n"))
    with pytest.raises(ConfigError, match=r"unknown keys \['acceleration_limit'\]"):
        read_limits(robot)


def test_the_orthoglide_closed_form_has_no_description_to_design_on():
    with pytest.raises(ConfigError, match="need a robot described by a URDF"):
        read_limits(load_robot("orthoglide"))


def test_a_plain_urdf_gets_acceleration_limits_from_its_efforts_and_inertia(tmp_path):
    """No acceleration limit anywhere: a_j = 0.5 τ_max,j / M_jj at the home pose, M from
    Pinocchio's CRBA on the URDF itself."""
    import pinocchio as pin

    from orthoglide_ident.excite.limits import ACCEL_SAFETY

    urdf = two_link_urdf(tmp_path, effort=20.0)
    robot = load_robot(_robot_yaml(tmp_path, urdf, "excitation:\n  home: [0.3, -0.7]\n"))
    lim = read_limits(robot)
    model = pin.buildModelFromUrdf(str(urdf))
    M = pin.crba(model, model.createData(), np.array([0.3, -0.7]))
    np.testing.assert_allclose(lim.acceleration, ACCEL_SAFETY * 20.0 / np.diag(M), rtol=1e-9)
    assert ACCEL_SAFETY == 0.5 and lim.sources["acceleration"].startswith("derived")
    # and at the middle of the ranges when the robot file gives no home
    plain = read_limits(load_robot(str(urdf)))
    M0 = pin.crba(model, model.createData(), np.zeros(2))
    np.testing.assert_allclose(plain.acceleration, 0.5 * 20.0 / np.diag(M0), rtol=1e-9)
