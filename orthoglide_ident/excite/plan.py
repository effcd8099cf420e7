"""Running an exciting trajectory on the robot: what is sent, checked before anything moves (no
ROS here; the action client is ``excite.action_client``, the command ``excite.run_command``).

A run is two FollowJointTrajectory goals to a joint_trajectory_controller:

1. the **approach**: from where the robot is to the run's start pose, at rest at both ends
   (a quintic), slow: each joint's peak speed at most ``APPROACH_SPEED_FRACTION`` of its limit;
2. the **excitation**: the run sampled at ``rate_hz`` (positions, velocities, accelerations;
   the JTC interpolates between points with quintics), recorded from its first point to its last.

Before either is sent, :func:`check_run` refuses, with a one-line reason naming the file, a
trajectory for another robot or other joints, a non-finite value, a position outside the robot's
limits or a speed above them (on a 1 ms grid).

Units: s, rad (m), rad/s, rad/s²; arrays (N, n) in the trajectory's joint order.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.excite.trajectory import ExcitationTrajectory
from orthoglide_ident.model.robot import RobotModel

SAMPLE_RATE_HZ = 100.0  # points per second sent to the JTC
CHECK_STEP_S = 1e-3  # the grid the limits are checked on
APPROACH_SPEED_FRACTION = 0.1  # of each joint's velocity limit
APPROACH_MIN_S = 2.0  # the shortest move to the start pose
APPROACH_DEFAULT_SPEED = 0.3  # rad/s (m/s / 10 for prismatic joints) where the robot gives no limit
QUINTIC_PEAK = 1.875  # peak speed of a rest-to-rest quintic over T: 1.875 Δ / T


@dataclass(frozen=True)
class Points:
    """A goal's points: ``times`` (N,) s from the goal's start, ``q``, ``qd``, ``qdd`` (N, n) in
    ``joint_names`` order."""

    joint_names: tuple[str, ...]
    times: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray

    @property
    def duration(self) -> float:
        return float(self.times[-1])


def _robot_matches(traj: ExcitationTrajectory, robot: RobotModel) -> bool:
    return traj.robot in (robot.name, Path(robot.name).stem) or Path(traj.robot).stem == robot.name


def check_run(traj: ExcitationTrajectory, run: str, robot: RobotModel, where: str) -> None:
    """ConfigError (one line, naming ``where``) unless run ``run`` of ``traj`` is for ``robot``'s
    actuated joints and stays inside its position and velocity limits on a 1 ms grid."""
    if not _robot_matches(traj, robot):
        raise ConfigError(
            f"{where}: the trajectory is for robot {traj.robot!r}, not {robot.name!r}"
        )
    if tuple(traj.joints) != tuple(robot.joint_names):
        raise ConfigError(f"{where}: the trajectory moves joints {', '.join(traj.joints)}; robot "
                          f"{robot.name} has {', '.join(robot.joint_names)}")
    t = np.arange(0.0, traj.duration + CHECK_STEP_S / 2, CHECK_STEP_S)
    q, qd, _ = traj.evaluate(run, t)
    if not (np.isfinite(q).all() and np.isfinite(qd).all()):
        raise ConfigError(f"{where}: run {run!r} is not finite (NaN or inf in its coefficients)")
    lo = np.array([j.lower for j in robot.joints])
    hi = np.array([j.upper for j in robot.joints])
    vmax = np.array([j.velocity_limit for j in robot.joints])
    checks = (
        ("below its lower limit", lo - q, q, lo, ""),
        ("above its upper limit", q - hi, q, hi, ""),
        ("faster than its velocity limit", np.abs(qd) - vmax, qd, vmax, "/s"),
    )
    for what, over, value, limit, per_s in checks:
        if np.any(over > 0):
            k, j = np.unravel_index(int(np.argmax(over)), over.shape)
            joint = robot.joints[j]
            raise ConfigError(f"{where}: run {run!r} takes {joint.name} {what} at t = {t[k]:.3f} s "
                              f"({value[k, j]:.4f} vs {limit[j]:.4f} {joint.unit}{per_s})")


def excitation_points(
    traj: ExcitationTrajectory, run: str, rate_hz: float = SAMPLE_RATE_HZ
) -> Points:
    """The run sampled at ``rate_hz`` from t = 0 to its end (both included)."""
    if not (math.isfinite(rate_hz) and rate_hz > 0):
        raise ConfigError(f"sample rate {rate_hz!r} Hz must be positive")
    n = int(math.ceil(traj.duration * rate_hz))
    t = np.linspace(0.0, traj.duration, n + 1)
    q, qd, qdd = traj.evaluate(run, t)
    return Points(tuple(traj.joints), t, q, qd, qdd)


def approach_points(q_now: np.ndarray, q_start: np.ndarray, speed: np.ndarray,
                    joint_names: tuple[str, ...], rate_hz: float = SAMPLE_RATE_HZ) -> Points:
    """Rest-to-rest quintic from ``q_now`` to ``q_start`` whose peak speed on each joint is at
    most ``speed`` (n,), taking at least APPROACH_MIN_S; starts at the goal's first point, t = 0
    (the JTC then starts from the robot's state, not an earlier point)."""
    q_now, q_start = np.asarray(q_now, float), np.asarray(q_start, float)
    T = max(APPROACH_MIN_S, float(np.max(QUINTIC_PEAK * np.abs(q_start - q_now) / speed)))
    t = np.linspace(0.0, T, int(math.ceil(T * rate_hz)) + 1)
    s = t / T
    w, wd, wdd = s**3 * (10 - 15 * s + 6 * s**2), 30 * s**2 * (1 - s) ** 2 / T, \
        60 * s * (1 - s) * (1 - 2 * s) / T**2
    d = q_start - q_now
    return Points(joint_names, t, q_now + np.outer(w, d), np.outer(wd, d), np.outer(wdd, d))


def approach_speed(robot: RobotModel) -> np.ndarray:
    """(n,) the approach's speed per joint: a fraction of its limit, or a default without one."""
    default = np.array(
        [APPROACH_DEFAULT_SPEED / (10 if j.kind == "prismatic" else 1) for j in robot.joints]
    )
    vmax = np.array([j.velocity_limit for j in robot.joints])
    return np.where(np.isfinite(vmax), APPROACH_SPEED_FRACTION * vmax, default)


@dataclass(frozen=True)
class PayloadTag:
    """What the recorder tags a run with: condition, mass (kg) and, when known, the payload's
    frame, CoM (m) and inertia (kg·m², Ixx Ixy Ixz Iyy Iyz Izz)."""

    condition: str
    mass: float
    frame: str | None = None
    com: tuple[float, ...] | None = None
    inertia: tuple[float, ...] | None = None


def payload_tag(traj: ExcitationTrajectory, condition: str, mass: float | None = None,
                where: str = "") -> PayloadTag:
    """The tag of run ``condition``: unloaded -> 0 kg; loaded -> ``mass`` when given, else the
    trajectory's loaded payload (its frame, com and inertia with it). ConfigError if unknown."""
    if condition == "unloaded":
        if mass:
            raise ConfigError("--payload-mass is for --condition loaded")
        return PayloadTag("unloaded", 0.0)
    if condition != "loaded":
        raise ConfigError(f"condition {condition!r}: loaded or unloaded")
    p: dict[str, Any] = dict(traj.run("loaded").payload or {})
    m = mass if mass is not None else p.get("mass")
    try:
        m = float(m)
    except (TypeError, ValueError):
        raise ConfigError(
            f"{where}: its loaded run names no payload mass: give --payload-mass KG"
        ) from None
    if not (math.isfinite(m) and m > 0):
        raise ConfigError(f"payload mass {m!r} kg must be positive")

    def numbers(key: str, n: int) -> tuple[float, ...] | None:
        v = p.get(key)
        if v is None:
            return None
        try:
            out = tuple(float(x) for x in v)
        except (TypeError, ValueError):
            out = ()
        if len(out) != n:
            raise ConfigError(f"{where}: payload {key} needs {n} numbers")
        return out

    return PayloadTag("loaded", m, p.get("frame"), numbers("com", 3), numbers("inertia", 6))


def progress_line(
    t: float, duration: float, error: np.ndarray, joint_names: tuple[str, ...]
) -> str:
    """One line of a goal's progress from its feedback: time, and the largest tracking error."""
    j = int(np.argmax(np.abs(error))) if len(error) else 0
    worst = f", largest error {error[j]:+.4f} on {joint_names[j]}" if len(error) else ""
    return f"{t:6.1f} / {duration:.1f} s ({100 * t / max(duration, 1e-9):3.0f} %){worst}"
