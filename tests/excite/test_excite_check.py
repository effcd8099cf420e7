"""``excite check``: each constraint violated on purpose is caught on the 1 ms grid."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from excite_robots import static_runs

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.excite.check import check_trajectory
from orthoglide_ident.excite.collision import CollisionModel
from orthoglide_ident.excite.constraints import Margins
from orthoglide_ident.excite.design import DesignOptions, design
from orthoglide_ident.excite.limits import read_limits
from orthoglide_ident.model.registry import load_robot
from orthoglide_ident.model.robot import Payload

HOME = [0.0, -2.0, 1.2, -1.5708, -1.5708, 0.0]


@pytest.fixture(scope="module")
def ur5():
    robot = load_robot("ur5")
    return robot, read_limits(robot), CollisionModel(robot, "mesh")


@pytest.fixture(scope="module")
def designed(ur5):
    """A short design (2 random shapes, 10 steps): feasible, not optimal."""
    robot, limits, col = ur5
    opt = DesignOptions(Payload(2.0), np.full(6, 0.02), restarts=2, steps=10)
    return design(robot, limits, col, opt, progress=lambda _: None)


def failed(report) -> set[str]:
    return {s.kind for s in report.failures()}


def test_a_design_passes_its_own_check(ur5, designed):
    robot, limits, col = ur5
    assert designed.check.ok
    again = check_trajectory(designed.trajectory, robot, limits, col, Margins())
    assert again.ok and set(again.by_kind()) == {"at_rest", "position", "velocity",
                                                 "acceleration", "effort", "collision"}
    assert designed.trajectory.start_pose("loaded") == pytest.approx(HOME)


@pytest.mark.parametrize("kind,change", [
    ("velocity", {"velocity": 0.5}), ("acceleration", {"acceleration": 0.5}),
    ("effort", {"effort": 0.3}), ("position", {"lower": 0.0, "upper": 0.0})])
def test_each_joint_limit_tightened_is_caught(ur5, designed, kind, change):
    robot, limits, col = ur5
    if kind == "position":  # the range shrunk to 0.1 rad around the start pose
        tight = dataclasses.replace(limits, lower=np.array(HOME) - 0.1, upper=np.array(HOME) + 0.1)
    else:
        tight = dataclasses.replace(
            limits, **{k: getattr(limits, k) * f for k, f in change.items()}
        )
    report = check_trajectory(designed.trajectory, robot, tight, col, Margins())
    assert failed(report) == {kind}, report.to_text()


def test_a_run_not_at_rest_is_caught(ur5):
    robot, limits, col = ur5
    a = np.zeros((6, 2))
    a[0] = [0.2, 0.0]  # q̇(0) = 0.2 rad/s
    report = check_trajectory(static_runs("ur5", robot.joint_names, HOME, a), robot, limits, col,
                              Margins())
    assert "at_rest" in failed(report)


def test_a_trajectory_folding_the_arm_onto_itself_collides(ur5):
    """The elbow swings from 2.2 to about 2.9 rad with the upper arm upright: the wrist comes
    down onto the shoulder."""
    robot, limits, col = ur5
    w = 2 * np.pi / 5.0
    a = np.zeros((6, 2))
    a[2] = [0.68, -0.68]  # Σ a = 0 and b = 0: at rest at t = 0
    pose = [0.0, -1.57, 2.2, 0.0, 0.0, 0.0]
    traj = static_runs("ur5", robot.joint_names, pose, a)
    report = check_trajectory(traj, robot, limits, col, Margins())
    col_slack = report.by_kind()["collision"]
    assert failed(report) == {"collision"} and col_slack.value < 0, report.to_text()
    assert "wrist" in col_slack.where
    assert traj.evaluate("unloaded", np.linspace(0, 5, 501))[0][:, 2].max() > 2.8 - 1e-9 * w


def test_the_floor_is_an_obstacle(ur5):
    robot, limits, col = ur5
    report = check_trajectory(static_runs("ur5", robot.joint_names, [0, 0.6, 0, 0, 0, 0]), robot,
                              limits, col, Margins())
    assert "floor" in report.by_kind()["collision"].where and "collision" in failed(report)


def test_five_bar_leaving_its_working_mode_is_caught():
    robot = load_robot("five_bar")
    limits, col = read_limits(robot), CollisionModel(robot, "mesh")
    ok = check_trajectory(static_runs("five_bar", robot.joint_names, [2.1, 1.04]), robot, limits,
                          col, Margins())
    assert ok.ok, ok.to_text()
    flipped = check_trajectory(static_runs("five_bar", robot.joint_names, [1.3, 1.85]), robot,
                               limits, col, Margins())
    mode = flipped.by_kind()["working_mode"]  # the elbows turned inwards, past their limits
    assert not mode.ok and mode.value < 0 and "joint_" in mode.where, flipped.to_text()


def test_a_trajectory_for_another_robot_is_refused(ur5):
    robot, limits, col = ur5
    five = static_runs("five_bar", ("joint_1", "joint_2"), [2.1, 1.04])
    with pytest.raises(ConfigError, match="t.yaml is a trajectory for robot five_bar"):
        check_trajectory(five, robot, limits, col, Margins(), where="t.yaml")
