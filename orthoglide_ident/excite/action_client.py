"""The ROS side of ``excite run``: a FollowJointTrajectory goal to a joint_trajectory_controller,
followed to its end, cancelled on Ctrl-C (rclpy; the plan is ``excite.plan``).

``send_goal`` returns a :class:`GoalOutcome` (succeeded, aborted with the controller's error code
and string, rejected, canceled, or interrupted by Ctrl-C after the cancel went out); progress
from the action's feedback goes to a callback (``excite run`` prints it on stderr).
"""
from __future__ import annotations

import time
import weakref
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from orthoglide_ident.excite.plan import Points

ACCEPT_TIMEOUT_S = 10.0  # the controller answers a goal within this
END_MARGIN_S = 30.0  # after the last point's time, waiting for the result gives up after this
CANCEL_TIMEOUT_S = 5.0
ERROR_NAMES = {
    0: "SUCCESSFUL",
    -1: "INVALID_GOAL",
    -2: "INVALID_JOINTS",
    -3: "OLD_HEADER_TIMESTAMP",
    -4: "PATH_TOLERANCE_VIOLATED",
    -5: "GOAL_TOLERANCE_VIOLATED",
}


@dataclass(frozen=True)
class GoalOutcome:
    """How a goal ended: ``status`` succeeded | aborted | rejected | canceled | interrupted |
    timeout, and why (the controller's error code name and string)."""

    status: str
    reason: str = ""

    @property
    def ok(self) -> bool:
        return self.status == "succeeded"


def goal_message(points: Points, path_tolerance: float = 0.0, goal_tolerance: float = 0.0,
                 goal_time: float = 0.0, effort: np.ndarray | None = None) -> Any:
    """control_msgs/action/FollowJointTrajectory.Goal of ``points``; tolerances per joint (rad
    or m; 0 leaves the controller's default), ``goal_time`` s; ``effort`` (N, n), when given,
    the points' feed-forward (N·m or N: a JTC with the effort command interface adds it)."""
    from builtin_interfaces.msg import Duration
    from trajectory_msgs.msg import JointTrajectoryPoint

    from control_msgs.action import FollowJointTrajectory
    from control_msgs.msg import JointTolerance

    goal = FollowJointTrajectory.Goal()
    goal.trajectory.joint_names = list(points.joint_names)
    sec = np.floor(points.times).astype(int)
    nsec = np.round((points.times - sec) * 1e9).astype(int)
    goal.trajectory.points = [
        JointTrajectoryPoint(
            positions=points.q[k].tolist(),
            velocities=points.qd[k].tolist(),
            accelerations=points.qdd[k].tolist(),
            effort=[] if effort is None else np.asarray(effort[k], float).tolist(),
            time_from_start=Duration(sec=int(sec[k]), nanosec=int(min(nsec[k], 999_999_999))),
        )
        for k in range(len(points.times))
    ]
    if path_tolerance:
        goal.path_tolerance = [
            JointTolerance(name=j, position=path_tolerance) for j in points.joint_names
        ]
    if goal_tolerance:
        goal.goal_tolerance = [
            JointTolerance(name=j, position=goal_tolerance) for j in points.joint_names
        ]
    goal.goal_time_tolerance = Duration(sec=int(goal_time), nanosec=int((goal_time % 1) * 1e9))
    return goal


class _CancelRequested(Exception):
    pass


# node -> clients
_CLIENTS: weakref.WeakKeyDictionary[Any, dict[str, Any]] = weakref.WeakKeyDictionary()


def send_goal(
    node: Any,
    action_name: str,
    goal: Any,
    duration: float,
    on_feedback: Callable[[Any], None] | None = None,
    spin: Callable[[float], None] | None = None,
    on_interrupt: Callable[[], None] | None = None,
    should_cancel: Callable[[], bool] | None = None,
) -> GoalOutcome:
    """Send ``goal`` to ``action_name`` and follow it until it ends; Ctrl-C, or
    ``should_cancel()`` turning true, cancels it (outcome ``interrupted``). ``spin(timeout)`` runs
    the node's callbacks (feedback, other subscriptions)."""
    import rclpy
    from rclpy.action import ActionClient

    from control_msgs.action import FollowJointTrajectory

    spin = spin or (lambda t: rclpy.spin_once(node, timeout_sec=t))
    clients = _CLIENTS.setdefault(node, {})
    if action_name not in clients:  # kept: destroying one while an executor waits on it races
        clients[action_name] = ActionClient(node, FollowJointTrajectory, action_name)
    return _follow(
        clients[action_name],
        action_name,
        goal,
        duration,
        on_feedback,
        spin,
        on_interrupt,
        should_cancel,
    )


def _follow(client: Any, action_name: str, goal: Any, duration: float, on_feedback: Any, spin: Any,
            on_interrupt: Any, should_cancel: Any) -> GoalOutcome:
    from action_msgs.msg import GoalStatus

    def spin_or_cancel(t: float) -> None:
        spin(t)
        if should_cancel is not None and should_cancel():
            raise _CancelRequested

    if not client.wait_for_server(timeout_sec=ACCEPT_TIMEOUT_S):
        return GoalOutcome(
            "rejected", f"no action server {action_name}: is the controller running?"
        )
    future = client.send_goal_async(goal, feedback_callback=(lambda m: on_feedback(m.feedback))
                                    if on_feedback else None)
    try:
        handle = wait_for(future, spin_or_cancel, ACCEPT_TIMEOUT_S)
    except (KeyboardInterrupt, _CancelRequested) as exc:  # before the answer: cancel once accepted
        handle = wait_for(future, spin, ACCEPT_TIMEOUT_S)
        return _cancelled(
            handle if handle is not None and handle.accepted else None, spin, exc, on_interrupt
        )
    if handle is None:  # no answer in time: a goal accepted later must not run unattended
        future.add_done_callback(_cancel_if_accepted)
        return GoalOutcome("rejected", f"{action_name} did not answer the goal within "
                                       f"{ACCEPT_TIMEOUT_S:g} s (cancelled if it accepts it later)")
    if not handle.accepted:
        return GoalOutcome(
            "rejected",
            f"{action_name} rejected the goal (see the controller's log: "
            "other joints, or a goal already running)",
        )
    result_future = handle.get_result_async()
    try:
        res = wait_for(result_future, spin_or_cancel, duration + END_MARGIN_S)
    except (KeyboardInterrupt, _CancelRequested) as exc:
        return _cancelled(handle, spin, exc, on_interrupt)
    if res is None:
        wait_for(handle.cancel_goal_async(), spin, CANCEL_TIMEOUT_S)
        return GoalOutcome(
            "timeout", f"no result {END_MARGIN_S:g} s after the trajectory's end: cancelled"
        )
    code, text = res.result.error_code, res.result.error_string
    status = {GoalStatus.STATUS_SUCCEEDED: "succeeded", GoalStatus.STATUS_CANCELED: "canceled"}.get(
        res.status, "aborted")
    reason = (
        text
        if status == "succeeded"
        else f"{ERROR_NAMES.get(code, code)}: {text or 'no reason given'}"
    )
    return GoalOutcome(status, reason)


def _cancel_if_accepted(future: Any) -> None:
    handle = future.result()
    if handle is not None and handle.accepted:
        handle.cancel_goal_async()


def _cancelled(handle: Any, spin: Any, exc: BaseException, on_interrupt: Any) -> GoalOutcome:
    """Ctrl-C or a cancel request: cancel the goal (when it was accepted)."""
    if on_interrupt:
        on_interrupt()
    if handle is not None:
        wait_for(handle.cancel_goal_async(), spin, CANCEL_TIMEOUT_S)
    why = "interrupted (Ctrl-C)" if isinstance(exc, KeyboardInterrupt) else "cancel requested"
    return GoalOutcome("interrupted", f"{why}: the goal was cancelled")


def wait_for(future: Any, spin: Callable[[float], None], timeout: float) -> Any:
    """The future's result once done (``spin`` runs meanwhile), None after ``timeout`` s."""
    t_end = time.monotonic() + timeout
    while not future.done() and time.monotonic() < t_end:
        spin(0.05)
    return future.result() if future.done() else None
