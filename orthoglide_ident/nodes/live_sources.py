"""Which topics live identification reads, and where each recording's current comes from.

Positions come from a JointState topic (``joint_states_topic``); the current, as offline
(docs/design/bags.md), from the first of these that the recording has (bags.sources.CURRENT_SOURCES,
the one table of inputs):

1. a DynamicJointState interface (``current_interface``, default ``current``) on
   ``dynamic_joint_states_topic``, as ros2_control's joint_state_broadcaster publishes every state
   interface; given explicitly, it must be there;
2. the JointState ``effort`` (the broadcaster with ``map_interface_to_joint_state: {effort:
   current}``), when it holds a finite value for every joint of the robot;
3. the product's CurrentReference on ``current_reference_topic`` (the Orthoglide).

The choice is made once per recording, from its first messages; while a topic that would be
preferred has a publisher but no message yet, it waits (at most SOURCE_WAIT_S). A recording with
no usable current gets a one-line reason (DataError) and is left out of live identification.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from orthoglide_ident.bags.reader import decode_messages
from orthoglide_ident.bags.sources import (
    CURRENT_SOURCES,
    DEFAULT_INTERFACE,
    POSITION,
    missing_joint_text,
)
from orthoglide_ident.bags.topics import DYNAMIC_JOINT_STATE_TYPE, JOINT_STATE_TYPE
from orthoglide_ident.errors import DataError

SOURCE_WAIT_S = 1.0  # s after the recording's first joint state, waiting for a preferred topic
# the three sources in their order of preference (buffer keys of LiveFeed): bags.sources' table
DYNAMIC, EFFORT, REFERENCE = (s.key for s in CURRENT_SOURCES)
_DEFAULT_TOPIC = {s.key: s.default_topic for s in CURRENT_SOURCES}


@dataclass(frozen=True)
class LiveTopics:
    """The topics (relative names resolve in the node's namespace; "" = not read) and the
    DynamicJointState interface ("" = ``current``, used when present)."""

    joint_states: str = POSITION.default_topic
    current_reference: str = _DEFAULT_TOPIC[REFERENCE]
    dynamic_joint_states: str = _DEFAULT_TOPIC[DYNAMIC]
    interface: str = ""

    @property
    def iface(self) -> str:
        return self.interface or DEFAULT_INTERFACE


def _interfaces_of(raw: bytes, joint: str) -> list[str]:
    """The interfaces ``joint`` has in one serialized DynamicJointState (for the reason)."""
    from rclpy.serialization import deserialize_message

    from control_msgs.msg import DynamicJointState

    msg = deserialize_message(raw, DynamicJointState)
    for name, iv in zip(msg.joint_names, msg.interface_values):
        if name == joint:
            return list(iv.interface_names)
    return []


def _dynamic(raw: bytes, joints: Sequence[str], topics: LiveTopics, topic: str) -> bool:
    """True if the interface is there for every joint; DataError if for some only, or if it was
    asked for explicitly; False: fall back to the effort."""
    names = decode_messages([raw], DYNAMIC_JOINT_STATE_TYPE, topics.iface)[1]
    missing = [j for j in joints if j not in names]
    if not missing:
        return True
    if len(missing) < len(joints) or topics.interface:
        has = _interfaces_of(raw, missing[0])
        raise DataError(f"joint {missing[0]!r} has no {topics.iface} in {topic} (it has: "
                        f"{', '.join(has) or 'nothing: not in the message'})")
    return False


def _effort(raw: bytes, joints: Sequence[str], topic: str) -> bool:
    """True if the JointState carries a finite effort for every joint (DataError: a joint
    missing)."""
    names, values = decode_messages([raw], JOINT_STATE_TYPE, "effort")[1:]
    all_names = decode_messages([raw], JOINT_STATE_TYPE)[1]
    missing = [j for j in joints if j not in all_names]
    if missing:
        raise DataError(missing_joint_text(missing[0], topic, all_names, joints))
    if not all(j in names for j in joints):
        return False
    return bool(np.isfinite(values[0, [names.index(j) for j in joints]]).all())


def choose_current(joints: Sequence[str], topics: LiveTopics, first: Mapping[str, bytes | None],
                   publishers: Mapping[str, int], waited_s: float,
                   resolved: Mapping[str, str]) -> str | None:
    """The recording's current source: DYNAMIC, EFFORT or REFERENCE; None to wait for more.

    ``first``: the recording's first serialized message per buffer key ("q" joint states, "d",
    "v"), None when none came yet; ``publishers``: publisher counts per key; ``waited_s``: since
    the first joint state; ``resolved``: full topic names per key, for the reasons."""
    late = waited_s >= SOURCE_WAIT_S
    d = first.get(DYNAMIC)
    if d is not None:
        if _dynamic(d, joints, topics, resolved[DYNAMIC]):
            return DYNAMIC
    elif topics.interface or (publishers.get(DYNAMIC) and topics.dynamic_joint_states):
        if not late:
            return None  # its first message may be on its way
        if topics.interface:
            raise DataError(
                f"interface {topics.interface!r} asked for (current_interface), but nothing "
                f"arrived on {resolved.get(DYNAMIC) or 'dynamic_joint_states_topic (empty)'}"
            )
    q = first.get("q")
    if q is None:
        return None
    if _effort(q, joints, resolved["q"]):
        return EFFORT
    if first.get(REFERENCE) is not None:
        return REFERENCE
    if not late:
        return None
    where = [f"{resolved['q']} carries no effort"]
    if topics.dynamic_joint_states:
        where.append(f"nothing on {resolved[DYNAMIC]} with interface {topics.iface!r}")
    if topics.current_reference:
        where.append(f"nothing on {resolved[REFERENCE]}")
    raise DataError(f"no current for {', '.join(joints)}: " + ", ".join(where))
