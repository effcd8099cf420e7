"""The stand-in's joint_trajectory_controller without ROS: a goal's interpolation, and the arm
following it through its PID with path tolerance, cancel and hold (ArmSession.start_goal)."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parents[2] / "excite"))
from trajectories import small_trajectory  # noqa: E402

from orthoglide_ident.errors import ConfigError  # noqa: E402
from orthoglide_ident.excite import plan as plan  # noqa: E402
from orthoglide_sim.arm_or_chain.session import ArmSession  # noqa: E402
from orthoglide_sim.common.joint_trajectory import (  # noqa: E402
    PATH_TOLERANCE_VIOLATED,
    JointTrajectory,
    Tolerances,
)


def test_interpolation_passes_through_the_points_and_matches_the_series_between_them():
    traj = small_trajectory()
    pts = plan.excitation_points(traj, "unloaded", 100.0)
    jt = JointTrajectory(pts.times, pts.q, pts.qd, pts.qdd, (pts.q[0], pts.qd[0], pts.qdd[0]))
    q, qd, qdd = jt.evaluate(pts.times[:-1])
    np.testing.assert_allclose(q, pts.q[:-1], atol=1e-12)
    np.testing.assert_allclose(qd, pts.qd[:-1], atol=1e-9)
    t = np.linspace(0.0, traj.duration - 1e-6, 777)  # between the points: a quintic per 10 ms
    q_s, qd_s, qdd_s = traj.evaluate("unloaded", t)
    q_i, qd_i, qdd_i = jt.evaluate(t)
    assert np.abs(q_i - q_s).max() < 1e-8 and np.abs(qd_i - qd_s).max() < 1e-6
    assert np.abs(qdd_i - qdd_s).max() < 1e-3 * np.abs(qdd_s).max()
    after = jt.evaluate(np.array([traj.duration + 1.0]))  # holds the last point at rest
    np.testing.assert_allclose(after[0][0], pts.q[-1]) and np.testing.assert_array_equal(
        after[1], 0
    )


def test_points_must_increase_in_time():
    with pytest.raises(ConfigError, match="strictly increasing"):
        JointTrajectory(np.array([0.0, 0.0]), np.zeros((2, 2)), None, None, (np.zeros(2),) * 3)


def _tol(n, path=0.0, goal_time=1.0):
    return Tolerances(np.full(n, path), np.zeros(n), np.zeros(n), goal_time)


def _run(session, goal, max_ticks=20_000):
    for _ in range(max_ticks):
        if goal.status != "active":
            break
        session.tick()
    return goal


def test_arm_follows_a_goal_and_holds_its_end():
    s = ArmSession("ur5", None, "hold", seed=0)
    pts = plan.excitation_points(small_trajectory(), "unloaded")
    ap = plan.approach_points(s.plant.q, pts.q[0], np.full(6, 0.3), pts.joint_names)
    goal = _run(s, s.start_goal(ap.times, ap.q, ap.qd, ap.qdd, _tol(6)))
    assert goal.status == "succeeded", goal.reason
    goal = _run(s, s.start_goal(pts.times, pts.q, pts.qd, pts.qdd, _tol(6, path=0.01)))
    assert goal.status == "succeeded", goal.reason
    for _ in range(500):
        s.tick()
    assert np.abs(s.plant.q - pts.q[-1]).max() < 1e-3  # held at the last point


def test_path_tolerance_violation_aborts_and_the_arm_holds_where_it_was():
    s = ArmSession("ur5", None, "hold", seed=0)
    pts = plan.excitation_points(small_trajectory(), "unloaded")
    ap = plan.approach_points(s.plant.q, pts.q[0], np.full(6, 0.3), pts.joint_names)
    goal = _run(s, s.start_goal(ap.times, ap.q, ap.qd, ap.qdd, _tol(6, path=1e-5)))
    assert goal.status == "aborted" and goal.code == PATH_TOLERANCE_VIOLATED
    assert "violated its path tolerance" in goal.reason
    q_abort = s.plant.q.copy()
    for _ in range(1000):
        s.tick()
    assert np.abs(s.plant.q - q_abort).max() < 0.02 and s.fault is None


def test_cancel_ends_the_goal_and_a_second_goal_waits_for_the_first():
    s = ArmSession("ur5", None, "hold", seed=0)
    pts = plan.excitation_points(small_trajectory(), "unloaded")
    ap = plan.approach_points(s.plant.q, pts.q[0], np.full(6, 0.3), pts.joint_names)
    goal = s.start_goal(ap.times, ap.q, ap.qd, ap.qdd, _tol(6))
    with pytest.raises(ConfigError, match="already running"):
        s.start_goal(ap.times, ap.q, ap.qd, ap.qdd, _tol(6))
    with pytest.raises(ConfigError, match="goal is running"):
        s.set_trajectory("exciting1", s.k)
    for _ in range(300):
        s.tick()
    s.cancel_goal()
    assert goal.status == "canceled"
    s.tick()
    assert goal.status == "canceled"
