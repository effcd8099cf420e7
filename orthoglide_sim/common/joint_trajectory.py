"""A FollowJointTrajectory goal as joint_trajectory_controller (Jazzy) executes it, without ROS.

:class:`JointTrajectory` interpolates a goal's points as the JTC does when they carry positions,
velocities and accelerations: a quintic per joint between two points (missing velocities or
accelerations count as 0 here, where the JTC would use a cubic or a straight line); before the
first point (when its time is after the goal's start) from the state the goal starts from; after
the last point it holds that point's position at rest. A goal's ``effort`` (N·m or N, per point)
is interpolated linearly and added to the PID's output as feed-forward, as the JTC does with the
``effort`` command interface (the hardware divides it by the nominal torque constant).
:class:`GoalTracker` follows one goal tick by tick: the path tolerance
on every tick (position error, per joint), the goal tolerance from the last point's time on
(position and velocity errors; a velocity tolerance of 0 means "stopped": ``STOPPED_VELOCITY``),
``goal_time`` after it the goal aborts; ``cancel()`` ends it. Tolerances: 0 takes the default,
-1 (any negative) erases it, as in control_msgs/JointTolerance. Errors are reference - measured.

Units: s, rad (m) per joint, arrays (n,) in the arm's joint order; times of points are from the
goal's start.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from orthoglide_ident.errors import ConfigError

STOPPED_VELOCITY = 0.01  # rad/s: JTC's default stopped_velocity_tolerance

# result codes of control_msgs/action/FollowJointTrajectory
SUCCESSFUL, INVALID_GOAL, INVALID_JOINTS = 0, -1, -2
PATH_TOLERANCE_VIOLATED, GOAL_TOLERANCE_VIOLATED = -4, -5


def _quintic(p0, v0, a0, p1, v1, a1, T):
    """Coefficients c0..c5 (6, n) of the quintic through both ends' position, velocity and
    acceleration over T s (the JTC's segment with all three given)."""
    T2, T3, T4, T5 = T**2, T**3, T**4, T**5
    c3 = (20 * (p1 - p0) - (8 * v1 + 12 * v0) * T - (3 * a0 - a1) * T2) / (2 * T3)
    c4 = (30 * (p0 - p1) + (14 * v1 + 16 * v0) * T + (3 * a0 - 2 * a1) * T2) / (2 * T4)
    c5 = (12 * (p1 - p0) - 6 * (v1 + v0) * T - (a0 - a1) * T2) / (2 * T5)
    return np.stack([p0, v0, a0 / 2, c3, c4, c5])


class JointTrajectory:
    """The reference of one goal (see the module docstring): ``evaluate(t)`` -> q, qd, qdd (m,
    n)."""

    def __init__(
        self,
        times: np.ndarray,
        q: np.ndarray,
        qd: np.ndarray | None,
        qdd: np.ndarray | None,
        start: tuple[np.ndarray, np.ndarray, np.ndarray],
        effort: np.ndarray | None = None,
    ) -> None:
        times, q = np.asarray(times, float), np.atleast_2d(np.asarray(q, float))
        if len(times) != len(q) or not len(times) or np.any(np.diff(times) <= 0) or times[0] < 0:
            raise ConfigError("a trajectory needs points at strictly increasing times from 0 on")
        n = q.shape[1]
        qd = np.zeros_like(q) if qd is None else np.asarray(qd, float)
        qdd = np.zeros_like(q) if qdd is None else np.asarray(qdd, float)
        if effort is not None:
            effort = np.asarray(effort, float)
        if times[0] > 0:  # the JTC interpolates from the state it starts from to the first point
            times = np.concatenate([[0.0], times])
            q, qd, qdd = (
                np.vstack([np.reshape(s, (1, n)), x]) for s, x in zip(start, (q, qd, qdd))
            )
            if effort is not None:
                effort = np.vstack([effort[:1], effort])
        self.effort = effort  # (N, n) or None
        self.times, self.end_pos = times, q[-1].copy()
        self.end_time = float(times[-1])
        T = np.diff(times)[:, None]
        self.coef = (np.stack([_quintic(q[i], qd[i], qdd[i], q[i + 1], qd[i + 1], qdd[i + 1], T[i])
                               for i in range(len(T))]) if len(T) else np.zeros((0, 6, n)))
        self.first = q[0].copy()

    def evaluate(self, t: np.ndarray | float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """q, qd, qdd at ``t`` (s from the goal's start), each (m, n)."""
        t = np.atleast_1d(np.asarray(t, float))
        n = len(self.end_pos)
        q, qd, qdd = (
            np.tile(self.end_pos, (len(t), 1)),
            np.zeros((len(t), n)),
            np.zeros((len(t), n)),
        )
        q[t < 0] = self.first
        inside = (t >= 0) & (t < self.end_time)
        if inside.any():
            seg = np.clip(
                np.searchsorted(self.times, t[inside], "right") - 1, 0, len(self.coef) - 1
            )
            tau = (t[inside] - self.times[seg])[:, None]
            c = self.coef[seg]  # (m, 6, n)
            powers = tau[:, None, :] ** np.arange(6)[None, :, None]  # (m, 6, 1)
            q[inside] = np.sum(c * powers, axis=1)
            qd[inside] = np.sum(c[:, 1:] * np.arange(1, 6)[None, :, None] * powers[:, :-1], axis=1)
            qdd[inside] = np.sum(c[:, 2:] * (np.arange(2, 6) * np.arange(1, 5))[None, :, None]
                                 * powers[:, :-2], axis=1)
        return q, qd, qdd


    def effort_at(self, t: float) -> np.ndarray | None:
        """The feed-forward effort at ``t`` (linear between points; none after the last one)."""
        if self.effort is None or not 0.0 <= t <= self.end_time:
            return None
        return np.array(
            [np.interp(t, self.times, self.effort[:, j]) for j in range(self.effort.shape[1])]
        )


class Hold:
    """At rest at ``q`` forever: the reference after a cancelled or aborted goal."""

    def __init__(self, q: np.ndarray) -> None:
        self.q = np.asarray(q, float).copy()

    def evaluate(self, t: np.ndarray | float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        m = len(np.atleast_1d(t))
        return np.tile(self.q, (m, 1)), np.zeros((m, len(self.q))), np.zeros((m, len(self.q)))


@dataclass
class Tolerances:
    """Per joint (n,): path position tolerance, goal position and velocity tolerances (0: not
    checked), and the time after the last point the goal may take to settle (s, 0: no limit)."""

    path: np.ndarray
    goal_position: np.ndarray
    goal_velocity: np.ndarray
    goal_time: float = 0.0

    @staticmethod
    def merged(given: np.ndarray, default: np.ndarray) -> np.ndarray:
        """control_msgs/JointTolerance's rule: 0 -> the default, < 0 -> erased (0 = unchecked)."""
        given = np.asarray(given, float)
        return np.where(given == 0, default, np.where(given < 0, 0.0, given))


@dataclass
class GoalTracker:
    """One goal tick by tick (see the module docstring). ``status``: active, succeeded, aborted,
    canceled; ``code`` and ``reason`` say how it ended."""

    trajectory: JointTrajectory
    tolerances: Tolerances
    joint_names: tuple[str, ...]
    status: str = "active"
    code: int = SUCCESSFUL
    reason: str = ""
    t: float = 0.0
    desired: tuple = field(default_factory=tuple)  # (q, qd, qdd) at t
    actual: tuple = field(default_factory=tuple)  # (q, qd) at t

    def update(self, t: float, q_meas: np.ndarray, qd_meas: np.ndarray,
               desired: tuple[np.ndarray, np.ndarray, np.ndarray]) -> None:
        """The measured state at ``t`` s from the goal's start against the reference ``desired``."""
        if self.status != "active":
            return
        self.t, self.desired, self.actual = t, desired, (q_meas, qd_meas)
        e = desired[0] - q_meas
        tol = self.tolerances
        over = (tol.path > 0) & (np.abs(e) > tol.path)
        if over.any():
            return self._abort(PATH_TOLERANCE_VIOLATED, "path", over, e, tol.path, t)
        if t < self.trajectory.end_time:
            return
        e_v = desired[1] - qd_meas
        v_tol = np.where(tol.goal_velocity > 0, tol.goal_velocity, STOPPED_VELOCITY)
        bad_p = (tol.goal_position > 0) & (np.abs(e) > tol.goal_position)
        bad_v = np.abs(e_v) > v_tol
        if not (bad_p.any() or bad_v.any()):
            self.status, self.reason = (
                "succeeded",
                f"reached the last point {t - self.trajectory.end_time:.3f} s after its time",
            )
        elif tol.goal_time > 0 and t > self.trajectory.end_time + tol.goal_time:
            if bad_p.any():
                self._abort(
                    GOAL_TOLERANCE_VIOLATED, "goal position", bad_p, e, tol.goal_position, t
                )
            else:
                self._abort(GOAL_TOLERANCE_VIOLATED, "goal velocity", bad_v, e_v, v_tol, t)

    def _abort(
        self, code: int, what: str, over: np.ndarray, e: np.ndarray, tol: np.ndarray, t: float
    ) -> None:
        j = int(np.argmax(over))
        self.status, self.code = "aborted", code
        self.reason = (
            f"{self.joint_names[j]} violated its {what} tolerance at t = {t:.3f} s: error "
            f"{e[j]:+.4f}, tolerance {tol[j]:.4f}"
        )

    def cancel(self) -> None:
        if self.status == "active":
            self.status, self.reason = "canceled", f"canceled at t = {self.t:.3f} s"
