"""The ctc node's outlet to ros2_control's joint_trajectory_controller (Jazzy).

A JTC that claims the ``effort`` command interface alone adds each trajectory point's ``effort``,
interpolated linearly between points, to its PID output (joint_trajectory_controller.cpp:
``tmp_command_ = ff_velocity_scale * v + command_next_.effort + pid(error)``), where
``command_next_`` is the trajectory sampled one update period ahead. So the model's feed-forward
of tick k goes in the point of tick k + 1, whose time is when the JTC applies it.

The effort is in the controller's units, ``effort`` parameter:

- ``nominal`` (default): v_ff x the nominal (manufacturer's) gain, N·m or N. The hardware turns
  an effort command into a current with the torque constant it is configured with, the nominal
  one; so this is the command that makes the drive carry the model's current v_ff, whose torque is
  g_tau v_ff with the drive's true gain: what the identified model asks for. (The model's torque
  itself would come out scaled by g_true / g_nominal: the few % the identification found.)
- ``torque``: v_ff x the identified gain = the model's torque W chi + W_kl m_7, N·m or N, for a
  joint that applies its effort command as a torque (a torque-sensed joint loop).
- ``current``: v_ff, A, for hardware whose effort command interface is a current.

Each message (trajectory_msgs/JointTrajectory, header.stamp = its first point's time) repeats the
last ``overlap`` points already sent before the new ones, so that it starts before the JTC's
``now`` when it arrives (the setpoints come ``setpoint_lead`` ticks ahead): the JTC "forgets the
old trajectory" on a new message, and a first point still in the future would have it interpolate
from its measured state to that point. Messages are written as CDR bytes directly (~0.1 ms for 60
points; building them with rclpy takes ~2 ms).
"""
from __future__ import annotations

import struct
from collections import deque
from collections.abc import Callable, Sequence

import numpy as np

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.ticks import TICK_NS

EFFORTS = ("nominal", "torque", "current")


def _string(name: str) -> bytes:
    data = name.encode() + b"\0"
    return struct.pack("<I", len(data)) + data


def encode_joint_trajectory(
    stamp_ns: int,
    joint_names: Sequence[str],
    times_ns: np.ndarray,
    positions: np.ndarray,
    velocities: np.ndarray,
    accelerations: np.ndarray,
    effort: np.ndarray,
) -> bytes:
    """CDR bytes (little endian, as rclpy serialises) of a JointTrajectory with an empty frame id:
    points at ``times_ns`` (N,) from ``stamp_ns``, arrays (N, n) in ``joint_names`` order."""
    out = bytearray(b"\x00\x01\x00\x00")  # encapsulation: CDR little endian

    def align(a: int) -> None:  # CDR alignment counts from the end of the encapsulation
        out.extend(b"\0" * ((-(len(out) - 4)) % a))

    sec, nsec = divmod(int(stamp_ns), 1_000_000_000)
    out += struct.pack("<iI", sec, nsec) + _string("")
    align(4)
    out += struct.pack("<I", len(joint_names))
    for name in joint_names:
        align(4)
        out += _string(name)
    align(4)
    out += struct.pack("<I", len(times_ns))
    n = len(joint_names)
    for k, t in enumerate(np.asarray(times_ns, np.int64)):
        for arr in (positions, velocities, accelerations, effort):
            align(4)
            out += struct.pack("<I", n)
            align(8)
            out += np.ascontiguousarray(arr[k], "<f8").tobytes()
        align(4)
        out += struct.pack("<iI", *divmod(int(t), 1_000_000_000))
    return bytes(out)


class TrajectoryOutlet:
    """Setpoints + feed-forward -> JointTrajectory messages (see the module docstring)."""

    def __init__(self, joint_names: Sequence[str], effort: str, nominal_gains: np.ndarray,
                 overlap: int = 100,
                 to_joint_effort: Callable[[np.ndarray], np.ndarray] | None = None) -> None:
        """``to_joint_effort``: a transmission's τ_j = Nᵀ τ_m (model/transmission.py) when the
        feed-forward is per motor and the points per joint; None: motors are joints."""
        if effort not in EFFORTS:
            raise ConfigError(f"parameter trajectory_effort: {' | '.join(EFFORTS)}, got {effort!r}")
        if overlap < 1:
            raise ConfigError(f"parameter trajectory_overlap: at least 1 tick, got {overlap}")
        self.joint_names, self.effort = tuple(joint_names), effort
        self.nominal_gains = np.asarray(nominal_gains, float)
        self.to_joint_effort = to_joint_effort
        self.history: deque = deque(maxlen=overlap)  # (stamp, q_d, qd_d, qdd_d, effort) sent
        self.v_prev: tuple[int, np.ndarray] | None = None  # the last tick's feed-forward (A)

    def efforts(self, v_ff: np.ndarray, gains: np.ndarray) -> np.ndarray:
        """(N, n) the effort of each tick's feed-forward ``v_ff`` (A), identified ``gains``; with
        a transmission the motors' efforts mapped to the joints (Nᵀ), which the hardware's
        transmission maps back to each motor."""
        scale = {"nominal": self.nominal_gains, "torque": np.asarray(gains, float),
                 "current": np.ones_like(self.nominal_gains)}[self.effort]
        e = np.asarray(v_ff, float) * scale
        return e if self.to_joint_effort is None else self.to_joint_effort(e)

    def message(self, stamps_ns: np.ndarray, ref: np.ndarray, v_ff: np.ndarray,
                gains: np.ndarray) -> bytes | None:
        """The next message for consecutive ticks ``stamps_ns`` (N,), reference ``ref`` (N, 3, n)
        (q_d, qd_d, qdd_d) and feed-forward ``v_ff`` (N, n) A; None until there are two points.
        Point k carries the feed-forward of tick k - 1 (applied from the JTC's update at
        t_(k-1))."""
        e = self.efforts(v_ff, gains)
        if self.history and int(stamps_ns[0]) != self.history[-1][0] + TICK_NS:
            self.history.clear()  # a gap: what was sent before does not lead into these ticks
            self.v_prev = None
        prev = [self.v_prev[1]] if self.v_prev is not None else [e[0]]
        shifted = np.concatenate([prev, e[:-1]])
        self.v_prev = (int(stamps_ns[-1]), e[-1])
        for k, stamp in enumerate(stamps_ns):
            self.history.append((int(stamp), ref[k, 0], ref[k, 1], ref[k, 2], shifted[k]))
        if len(self.history) < 2:
            return None
        points = list(self.history)
        t0 = points[0][0]
        cols = [np.array([p[i] for p in points]) for i in range(1, 5)]
        return encode_joint_trajectory(
            t0, self.joint_names, np.array([p[0] - t0 for p in points]), *cols
        )
