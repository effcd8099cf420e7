"""A URDF mimic joint keeps its own limits in ``excite design`` and ``excite check`` (issue 43:
j3 = 3 j2 reached 4.98 rad/s against its 3 rad/s with "every constraint keeps its margin")."""
from __future__ import annotations

import numpy as np
import pytest
from excite_robots import mimic_arm_urdf, static_runs

from orthoglide_ident.excite.check import CHECK_STEP_S, check_trajectory
from orthoglide_ident.excite.constraints import Margins
from orthoglide_ident.excite.design import DesignOptions, design
from orthoglide_ident.excite.limits import read_limits
from orthoglide_ident.model.registry import load_robot
from orthoglide_ident.model.robot import Payload


@pytest.fixture(scope="module")
def arm(tmp_path_factory):
    robot = load_robot(str(mimic_arm_urdf(tmp_path_factory.mktemp("mimic"))))
    return robot, read_limits(robot)


def test_the_mimic_joints_own_limits_are_read(arm):
    robot, limits = arm
    assert robot.joint_names == ("j1", "j2")
    (m,) = limits.mimics
    assert (m.joint, m.leader, m.multiplier) == ("j3", 1, 3.0)
    assert (m.lower, m.upper, m.velocity) == (-2.0, 2.0, 3.0)


def test_check_catches_a_mimic_joint_beyond_its_velocity(arm):
    robot, limits = arm
    # j2 swings at 1.66 rad/s peak (55 % of its 3 rad/s): j3 = 3 j2 reaches 4.98 rad/s
    traj = static_runs("mimic_arm", robot.joint_names, [0.0, 0.0],
                       a=[[0.0, 0.0], [1.66, 0.0]], b=np.zeros((2, 2)))
    t = np.arange(0.0, 5.0, CHECK_STEP_S)
    _, qd, _ = traj.evaluate("unloaded", t)
    assert 3.0 * np.abs(qd[:, 1]).max() == pytest.approx(4.98, rel=1e-3)
    report = check_trajectory(traj, robot, limits, None, Margins())
    v = report.by_kind()["velocity"]
    assert not v.ok and v.where.startswith("j3")
    assert v.value == pytest.approx(1.0 - 4.98 / 3.0, rel=1e-3)


def test_design_keeps_the_mimic_joint_within_its_limits(arm):
    robot, limits = arm
    opt = DesignOptions(Payload(0.5), np.full(2, 0.02), restarts=2, steps=5, periods=2)
    d = design(robot, limits, None, opt, progress=lambda _: None)
    assert d.check.ok, d.check.to_text()
    t = np.arange(0.0, d.trajectory.period_s, CHECK_STEP_S)
    for run in ("unloaded", "loaded"):
        q, qd, qdd = d.trajectory.evaluate(run, t)
        # j3's own motion from the URDF's <mimic>, apart from the code: 3 × j2
        assert np.abs(3 * qd[:, 1]).max() <= 3.0 * 0.9 + 1e-9
        assert np.abs(3 * q[:, 1]).max() <= 2.0 - 0.05 + 1e-9


def test_a_mimic_joint_moves_its_body_in_the_collision_check(arm):
    """The tree configurations the distances are computed at hold j3 = 3 j2 (it stayed at 0)."""
    from orthoglide_ident.excite.constraints import TreeStates

    robot, _ = arm
    Q, _ = TreeStates(robot).configurations(np.array([[0.1, 0.2]]))
    j3 = next(j for j in robot.tree_joints if j.name == "j3")
    assert Q[0, j3.iq] == pytest.approx(0.6)
