"""What ros2_control's joint_state_broadcaster (Jazzy) publishes for a simulated arm (no ROS here).

Per controller-manager update, from the same state interfaces and with one ``header.stamp``:

- ``joint_states`` (sensor_msgs/JointState): position, velocity and effort of every joint in the
  hardware's order; with ``map_interface_to_joint_state: {effort: current}`` the effort field
  holds the ``current`` interface, and a joint without one (a gripper) gets NaN, as the
  broadcaster fills what it cannot read;
- ``dynamic_joint_states`` (control_msgs/DynamicJointState): every state interface of every joint
  (the arm's: position, velocity, current; an extra joint's: position, velocity).

:class:`BroadcasterLayout` holds that order and those interfaces and turns one :class:`ArmTick`
into the two messages' CDR bytes (``orthoglide_ident.bags`` encoders: the bytes rclpy would
serialise), ready for a raw publish. :class:`TickDropper` decides, per topic and seeded, which
ticks the broadcaster's realtime publisher drops (``try_publish`` returns false while its thread
is still sending the previous message), and counts them.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from orthoglide_ident import bags
from orthoglide_ident.errors import ConfigError
from orthoglide_sim.common.tick_clock import TICK_NS

ARM_INTERFACES = ("position", "velocity", "current")
EXTRA_INTERFACES = ("position", "velocity")
TOPICS = ("joint_states", "dynamic_joint_states")  # relative: the controller manager's namespace


class Tick(Protocol):
    """What the drives report at tick k (arm_or_chain.session.ArmTick), (n,) each."""

    k: int
    position: np.ndarray  # rad (m): the encoder reading at t_k
    velocity: np.ndarray  # rad/s (m/s): the controller's velocity estimate
    current: np.ndarray  # A: the current reference over [t_k, t_k+1)


class Ticking(Protocol):
    """A session ticked one update at a time (arm_or_chain.session.ArmSession)."""

    def tick(self) -> Tick | None: ...


class BroadcasterLayout:
    """The hardware's joint order: ``names`` (arm joints and extra joints), ``arm_column[i]`` the
    arm's column of slot i (-1 for an extra joint), ``interfaces[i]`` the state interfaces of
    slot i; :meth:`encode` writes one update's two messages."""

    def __init__(self, names: Sequence[str], arm_column: np.ndarray) -> None:
        self.names = tuple(names)
        self.arm_column = np.asarray(arm_column)
        self.interfaces = tuple(
            ARM_INTERFACES if c >= 0 else EXTRA_INTERFACES for c in self.arm_column
        )
        self._js = bags.encoding.MessageTemplate.joint_state(self.names)
        self._djs = bags.encoding.MessageTemplate.dynamic_joint_state(self.names, self.interfaces)
        self._js_from = self._sources(self._js.columns)
        self._djs_from = self._sources(self._djs.columns)

    @classmethod
    def of(
        cls,
        arm_joints: Sequence[str],
        extra_joints: Sequence[str] = (),
        order: str = "shuffled",
        seed: int = 0,
    ) -> BroadcasterLayout:
        """``order``: "shuffled" (the arm's joints permuted by ``seed``, the extra joints in the
        middle: a hardware order no URDF gives), "urdf" (the arm's order, extras last), or the
        joint names comma-separated (every arm and extra joint once). ConfigError otherwise."""
        arm, extra = list(arm_joints), list(extra_joints)
        if set(arm) & set(extra) or len(set(extra)) != len(extra):
            raise ConfigError(
                f"extra_joints {extra} must be new, distinct joint names (the arm has "
                f"{', '.join(arm)})"
            )
        if order == "shuffled":
            names = [arm[i] for i in np.random.default_rng(seed).permutation(len(arm))]
            names[len(names) // 2:len(names) // 2] = extra
        elif order == "urdf":
            names = arm + extra
        else:
            names = [n.strip() for n in order.split(",") if n.strip()]
            if sorted(names) != sorted(arm + extra):
                raise ConfigError(
                    f"joint_order {order!r}: name each of {', '.join(arm + extra)} once, "
                    "or say shuffled or urdf"
                )
        return cls(names, np.array([arm.index(n) if n in arm else -1 for n in names]))

    def _sources(self, columns) -> tuple[np.ndarray, np.ndarray]:
        """For each value of a message: which of (position, velocity, current) and which arm
        column it comes from (-1: an extra joint: 0 at rest, NaN for a current)."""
        field = {"position": 0, "velocity": 1, "effort": 2, "current": 2}
        slot = {n: i for i, n in enumerate(self.names)}
        return (np.array([field[f] for _, f in columns]),
                np.array([self.arm_column[slot[j]] for j, _ in columns]))

    @staticmethod
    def _values(sources: tuple[np.ndarray, np.ndarray], state: np.ndarray) -> np.ndarray:
        which, column = sources
        out = state[which, np.maximum(column, 0)]
        extra = column < 0
        out[extra] = np.where(which[extra] == 2, np.nan, 0.0)
        return out

    def encode(self, stamp_ns: int, tick: Tick) -> tuple[bytes, bytes]:
        """CDR bytes of (JointState, DynamicJointState) for ``tick`` stamped ``stamp_ns``: one
        update, one stamp; extra joints at rest at 0 (m or rad), their effort NaN."""
        state = np.stack([tick.position, tick.velocity, tick.current])
        return (self._js.encode(stamp_ns, self._values(self._js_from, state)),
                self._djs.encode(stamp_ns, self._values(self._djs_from, state)))


@dataclass
class TickDropper:
    """Seeded drops: each topic loses a tick with probability ``rate``, independently (each
    realtime publisher has its own thread); ``dropped`` counts them per topic."""

    rate: float
    seed: int = 0
    dropped: dict[str, int] = field(default_factory=lambda: dict.fromkeys(TOPICS, 0))

    def __post_init__(self) -> None:
        if not 0.0 <= self.rate < 1.0:
            raise ConfigError(f"drop_rate must be in [0, 1), got {self.rate}")
        self._rng = np.random.default_rng([self.seed, 25])

    def keep(self) -> tuple[bool, ...]:
        """Per topic of TOPICS: True if this tick is published."""
        drop = self._rng.random(len(TOPICS)) < self.rate
        for topic, d in zip(TOPICS, drop):
            self.dropped[topic] += bool(d)
        return tuple(not d for d in drop)


def broadcast(session: Ticking, n_ticks: int, layout: BroadcasterLayout, dropper: TickDropper,
              start_ns: int) -> list[tuple[int, bytes | None, bytes | None]]:
    """What the stand-in publishes over ``n_ticks`` updates, without ROS (tests, benches): per
    update (stamp, joint_states bytes, dynamic_joint_states bytes), None where a topic dropped
    it."""
    out = []
    for _ in range(n_ticks):
        tick = session.tick()
        if tick is None:
            break
        stamp = start_ns + tick.k * TICK_NS
        raw = layout.encode(stamp, tick)
        out.append((stamp, *(r if keep else None for r, keep in zip(raw, dropper.keep()))))
    return out
