"""The stand-in's joint_trajectory_controller: a ``<controller>/follow_joint_trajectory`` action
server (control_msgs/action/FollowJointTrajectory) that runs each goal on the simulated arm.

As the JTC (Jazzy) does: a goal naming other joints than the arm's, with no points, with
non-finite values or times that do not increase is rejected (the reason in the log), and so is a
goal while another runs (the JTC would replace it; refusing keeps a recording's run whole). An
accepted goal is executed by the session's update loop (``ArmSession.start_goal``: interpolation,
the plant's PID on that reference, path and goal tolerances, ``joint_trajectory``); this server
adds the points' ``effort`` as feed-forward (the JTC with an effort command interface); sends
feedback (desired, actual, error) every FEEDBACK_PERIOD_S, and ends the goal as the loop
ended it: succeeded, aborted with PATH_/GOAL_TOLERANCE_VIOLATED and the reason in
``error_string``, or canceled on request (the arm then holds where it is).
"""
from __future__ import annotations

import threading
import time
from typing import Any

import numpy as np
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.callback_groups import ReentrantCallbackGroup
from trajectory_msgs.msg import JointTrajectoryPoint

from control_msgs.action import FollowJointTrajectory
from orthoglide_ident.errors import ConfigError
from orthoglide_sim.arm_or_chain.session import ArmSession
from orthoglide_sim.common.joint_trajectory import Tolerances

FEEDBACK_PERIOD_S = 0.05


def _seconds(d: Any) -> float:
    return d.sec + 1e-9 * d.nanosec


def goal_arrays(goal: Any, arm_joints: tuple[str, ...]) -> tuple[np.ndarray, ...]:
    """times (N,), q, qd, qdd, effort (N, n) in the arm's order (None when the points lack them);
    ConfigError with the reason for a goal the JTC would reject."""
    traj = goal.trajectory
    names = list(traj.joint_names)
    if sorted(names) != sorted(arm_joints):
        raise ConfigError(f"goal joints {names} are not the controller's {list(arm_joints)}")
    pts = traj.points
    if not pts:
        raise ConfigError("goal has no points")
    order = [names.index(j) for j in arm_joints]
    times = np.array([_seconds(p.time_from_start) for p in pts])

    def column(field: str) -> np.ndarray | None:
        rows = [list(getattr(p, field)) for p in pts]
        if all(len(r) == 0 for r in rows):
            return None
        if any(len(r) != len(names) for r in rows):
            raise ConfigError(f"every point needs {len(names)} {field} (or none)")
        return np.array(rows, float)[:, order]

    q, qd, qdd, effort = (column(f) for f in ("positions", "velocities", "accelerations", "effort"))
    if q is None:
        raise ConfigError("goal points have no positions")
    if not all(np.isfinite(x).all() for x in (times, q, qd, qdd, effort) if x is not None):
        raise ConfigError("goal holds a non-finite value")
    if np.any(np.diff(times) <= 0) or times[0] < 0:
        raise ConfigError("goal point times must increase from 0 on")
    return times, q, qd, qdd, effort


def goal_tolerances(goal: Any, arm_joints: tuple[str, ...], defaults: Tolerances) -> Tolerances:
    """The goal's tolerances over the defaults (JointTolerance: 0 default, -1 erased)."""
    def per_joint(items: Any, field: str) -> np.ndarray:
        given = {t.name: getattr(t, field) for t in items}
        return np.array([given.get(j, 0.0) for j in arm_joints], float)

    goal_time = _seconds(goal.goal_time_tolerance) or defaults.goal_time
    return Tolerances(
        Tolerances.merged(per_joint(goal.path_tolerance, "position"), defaults.path),
        Tolerances.merged(per_joint(goal.goal_tolerance, "position"), defaults.goal_position),
        Tolerances.merged(per_joint(goal.goal_tolerance, "velocity"), defaults.goal_velocity),
        goal_time,
    )


class TrajectoryActionServer:
    """FollowJointTrajectory on ``node`` for ``session`` (shared with the update loop under
    ``lock``)."""

    def __init__(self, node: Any, session: ArmSession, lock: threading.Lock, controller: str,
                 defaults: Tolerances) -> None:
        self.node, self.session, self.lock, self.defaults = node, session, lock, defaults
        self.joints = tuple(session.joint_names)
        self.busy = False
        self.name = f"{controller}/follow_joint_trajectory"
        self.server = ActionServer(
            node,
            FollowJointTrajectory,
            self.name,
            self._execute,
            goal_callback=self._on_goal,
            cancel_callback=lambda _: CancelResponse.ACCEPT,
            callback_group=ReentrantCallbackGroup(),
        )

    def _on_goal(self, goal: Any) -> GoalResponse:
        try:
            if self.busy:
                raise ConfigError("a goal is already running")
            goal_arrays(goal, self.joints)
        except ConfigError as exc:
            self.node.get_logger().warning(f"{self.name}: goal rejected: {exc}")
            return GoalResponse.REJECT
        self.busy = True  # until this goal ends (the next one is refused meanwhile)
        return GoalResponse.ACCEPT

    def _execute(self, handle: Any) -> Any:
        result = FollowJointTrajectory.Result()
        try:
            times, q, qd, qdd, effort = goal_arrays(handle.request, self.joints)
            with self.lock:
                tracker = self.session.start_goal(
                    times,
                    q,
                    qd,
                    qdd,
                    goal_tolerances(handle.request, self.joints, self.defaults),
                    effort,
                )
            self.node.get_logger().info(
                f"{self.name}: goal of {len(times)} points, {times[-1]:.2f} s"
            )
            while tracker.status == "active":
                if handle.is_cancel_requested:
                    with self.lock:
                        self.session.cancel_goal()
                    break
                self._feedback(handle, tracker)
                time.sleep(FEEDBACK_PERIOD_S)
            result.error_code, result.error_string = tracker.code, tracker.reason
            {"succeeded": handle.succeed, "canceled": handle.canceled}.get(
                tracker.status, handle.abort
            )()
            self.node.get_logger().info(f"{self.name}: goal {tracker.status}: {tracker.reason}")
        except ConfigError as exc:
            result.error_code, result.error_string = (
                FollowJointTrajectory.Result.INVALID_GOAL,
                str(exc),
            )
            handle.abort()
        finally:
            self.busy = False
        return result

    def _feedback(self, handle: Any, tracker: Any) -> None:
        with self.lock:
            desired, actual, t = tracker.desired, tracker.actual, tracker.t
        if not desired:
            return
        fb = FollowJointTrajectory.Feedback(joint_names=list(self.joints))
        fb.header.stamp = self.node.get_clock().now().to_msg()
        stamp = {"sec": int(t), "nanosec": int((t % 1) * 1e9)}
        fb.desired = JointTrajectoryPoint(
            positions=desired[0].tolist(),
            velocities=desired[1].tolist(),
            accelerations=desired[2].tolist(),
        )
        fb.actual = JointTrajectoryPoint(
            positions=actual[0].tolist(), velocities=actual[1].tolist()
        )
        fb.error = JointTrajectoryPoint(positions=(desired[0] - actual[0]).tolist(),
                                        velocities=(desired[1] - actual[1]).tolist())
        for p in (fb.desired, fb.actual, fb.error):
            p.time_from_start.sec, p.time_from_start.nanosec = stamp["sec"], stamp["nanosec"]
        handle.publish_feedback(fb)
