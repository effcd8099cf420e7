"""Which topic and field of a bag carry q and the current (docs/design/architecture.md §3).

A bag of the Orthoglide holds ``/orthoglide/joint_states`` (q) and ``/orthoglide/current_reference``
(v_tau); a bag of a ros2_control robot holds ``/joint_states`` alone (``effort`` = the current, in
A, as ``map_interface_to_joint_state: {effort: current}`` publishes it) or with
``/dynamic_joint_states`` (every state interface, ``current`` among them). Topics are recognised by
type and by their last name (``joint_states``, ``dynamic_joint_states``, ``current_reference``)
under any namespace. q is the ``position`` of the JointState; the current comes, in this order of
preference when present (``CURRENT_SOURCES``, the one table of inputs the recorder, the live
identification and the viewer read too):

1. a DynamicJointState interface (``interface``, default ``current``);
2. the JointState ``effort`` field (when it holds a finite value);
3. the product's CurrentReference ``current``.

A bag's tag may name the sources (``orthoglide.position_source``, ``orthoglide.current_source``,
"TOPIC FIELD"): then those are used, and a bag whose tag names a source it lacks is refused. Joints
are matched by name: any order, extra joints (a gripper) kept unless ``joints`` asks for some.
Every refusal is a BagError with a one-line reason.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from orthoglide_ident.errors import BagError

from ._decode import TopicSeries
from ._tags import BagTags
from ._types import CURRENT_REFERENCE_TYPE, DYNAMIC_JOINT_STATE_TYPE, JOINT_STATE_TYPE

DEFAULT_INTERFACE = "current"  # the DynamicJointState interface of the current, unless told


@dataclass(frozen=True)
class InputSource:
    """One kind of input the product reads q or the current from, offline (bags) and live (the
    identification node, the viewer): the message type, the topic's last name (recognised under
    any namespace), the field (a DynamicJointState's: the ``current_interface`` option), the
    unit, the node parameter that names the topic and its default, and the key live buffers and
    logs use."""

    key: str
    msgtype: str
    basename: str
    field: str  # "" for a DynamicJointState: the interface option (default DEFAULT_INTERFACE)
    quantity: str  # "position" | "current"
    unit: str
    topic_parameter: str  # of the identification and viewer nodes
    default_topic: str
    label: str  # "the effort of" /joint_states, in logs

    def field_for(self, interface: str | None) -> str:
        return self.field or interface or DEFAULT_INTERFACE


# The one table of inputs: q, then the current's sources in the order of preference.
POSITION = InputSource("q", JOINT_STATE_TYPE, "joint_states", "position", "position", "m or rad",
                       "joint_states_topic", "orthoglide/joint_states", "the position of")
CURRENT_SOURCES = (
    InputSource("d", DYNAMIC_JOINT_STATE_TYPE, "dynamic_joint_states", "", "current", "A",
                "dynamic_joint_states_topic", "dynamic_joint_states", "the interface of"),
    InputSource("effort", JOINT_STATE_TYPE, "joint_states", "effort", "current",
                "A (N or N·m with effort_unit: torque)", "joint_states_topic",
                "orthoglide/joint_states", "the effort of"),
    InputSource("v", CURRENT_REFERENCE_TYPE, "current_reference", "current", "current", "A",
                "current_reference_topic", "orthoglide/current_reference", "the current of"),
)
INPUT_SOURCES = (POSITION,) + CURRENT_SOURCES
BASENAMES = {s.msgtype: s.basename for s in INPUT_SOURCES}
_CURRENT_TYPES = tuple(dict.fromkeys(s.msgtype for s in CURRENT_SOURCES))


@dataclass(frozen=True)
class Source:
    """One topic's field: ``position``/``effort`` of a JointState, ``current`` of a
    CurrentReference, or an interface name of a DynamicJointState."""

    topic: str
    msgtype: str
    field: str

    def __str__(self) -> str:
        """As written in the tag: ``TOPIC FIELD``."""
        return f"{self.topic} {self.field}"

    def describe(self) -> str:
        """In words, for results and ``info``."""
        if self.msgtype == DYNAMIC_JOINT_STATE_TYPE:
            return f"{self.topic} interface '{self.field}' (DynamicJointState)"
        kind = "JointState" if self.msgtype == JOINT_STATE_TYPE else "CurrentReference"
        return f"{self.topic} {self.field} ({kind})"


@dataclass(frozen=True)
class BagSources:
    """Where q (m or rad) and the current (A) of a bag were read from."""

    position: Source
    current: Source

    def describe(self) -> str:
        return f"q from {self.position.describe()}; current from {self.current.describe()}"

    def tag_fields(self) -> dict[str, str]:
        """The two source entries of :class:`BagTags` (``BagTags.checked(..., **these)``)."""
        return {"position_source": str(self.position), "current_source": str(self.current)}


def _found(topics: Mapping[str, TopicSeries]) -> str:
    return ", ".join(sorted(topics)) or "no topics"


def find_topic(topics: Mapping[str, TopicSeries], msgtype: str, path: Path) -> TopicSeries | None:
    """The one decoded topic of ``msgtype`` named ``.../<basename>``; BagError if several (two
    robots' namespaces in one bag)."""
    base = BASENAMES[msgtype]
    hits = [s for s in topics.values()
            if s.msgtype == msgtype and s.decoded and s.topic.rsplit("/", 1)[-1] == base]
    if len(hits) > 1:
        names = ", ".join(sorted(s.topic for s in hits))
        raise BagError(f"{path}: {len(hits)} robots' {base} in one bag ({names}); record one "
                       "namespace per bag")
    return hits[0] if hits else None


def _tagged(topics: Mapping[str, TopicSeries], text: str, key: str, types: Sequence[str],
            path: Path) -> Source:
    topic, field = text.split(" ", 1)
    s = topics.get(topic)
    if s is None or not s.decoded or s.msgtype not in types or not len(s.stamps_ns):
        raise BagError(f"{path}: the tag's {key} {text!r} names a topic this bag does not hold "
                       f"with messages of a joint-state type (found: {_found(topics)})")
    if not s.take(field)[0]:
        raise BagError(f"{path}: the tag's {key} {text!r} names a field {topic} does not carry")
    return Source(topic, s.msgtype, field)


def _position(topics: Mapping[str, TopicSeries], tags: BagTags | None, path: Path) -> Source:
    if tags is not None and tags.position_source:
        return _tagged(topics, tags.position_source, "position_source", (JOINT_STATE_TYPE,), path)
    js = find_topic(topics, JOINT_STATE_TYPE, path)
    if js is None or not len(js.stamps_ns):
        raise BagError(f"{path}: no joint_states topic (sensor_msgs/msg/JointState, e.g. "
                       f"/joint_states or /orthoglide/joint_states) in the bag (found: "
                       f"{_found(topics)})")
    if not js.take("position")[0]:
        raise BagError(f"{path}: {js.topic} carries no position")
    return Source(js.topic, JOINT_STATE_TYPE, "position")


def _carries(s: TopicSeries, src: InputSource, field: str,
             joints: Sequence[str] | None) -> bool:
    """Whether ``s`` holds the current as ``src`` reads it: a DynamicJointState with the
    interface, a JointState with a finite effort, a CurrentReference with messages."""
    if src.msgtype == JOINT_STATE_TYPE:
        return bool(np.isfinite(s.take(field, joints)[1]).any())
    if not len(s.stamps_ns):
        return False
    return src.msgtype != DYNAMIC_JOINT_STATE_TYPE or bool(s.take(field, joints)[0])


def _current(topics: Mapping[str, TopicSeries], position: Source, interface: str | None,
             joints: Sequence[str] | None, path: Path) -> Source:
    """The first of CURRENT_SOURCES the bag holds; ``interface`` given: that DynamicJointState
    interface only."""
    iface = interface or DEFAULT_INTERFACE
    for src in CURRENT_SOURCES:
        s = (topics[position.topic] if src.msgtype == JOINT_STATE_TYPE
             else find_topic(topics, src.msgtype, path))
        field = src.field_for(interface)
        if s is not None and _carries(s, src, field, joints):
            return Source(s.topic, src.msgtype, field)
        if interface is not None:  # asked for explicitly: no other source will do
            where = s.topic if s is not None else "no dynamic_joint_states topic"
            raise BagError(f"{path}: interface {interface!r} is not in {where} "
                           f"(found: {_found(topics)})")
    cr_name = position.topic.rsplit("/", 1)[0] + "/current_reference"
    raise BagError(f"{path}: no current: {cr_name} is missing, {position.topic} carries no effort "
                   f"and no dynamic_joint_states topic has interface '{iface}' (found: "
                   f"{_found(topics)})")


def choose_sources(topics: Mapping[str, TopicSeries], path: Path, *, tags: BagTags | None = None,
                   interface: str | None = None, joints: Sequence[str] | None = None) -> BagSources:
    """The sources of q and the current by the tag, else by the order of preference (module
    docstring); an explicit ``interface`` overrides the tag's current source."""
    position = _position(topics, tags, path)
    if interface is None and tags is not None and tags.current_source:
        current = _tagged(topics, tags.current_source, "current_source", _CURRENT_TYPES, path)
    else:
        current = _current(topics, position, interface, joints, path)
    return BagSources(position, current)


def missing_joint_text(missing: str, topic: str, names: Sequence[str],
                       joints: Sequence[str]) -> str:
    """Why ``missing`` (one of the robot's ``joints``) is not in ``topic``, which carries
    ``names``; when the topic carries the robot's other joints, the likely cause: a joint of the
    description the controller does not drive (a gripper's, a tool changer's)."""
    text = f"joint {missing!r} is not in {topic} (it has: {', '.join(names) or 'no joints'})"
    if any(j in names for j in joints):
        text += ("; a gripper's or a tool's joint the logs do not carry? lock it in a robot file "
                 "(locked_joints: docs/guide/locked_joints.md)")
    return text


def take_joints(s: TopicSeries, src: Source, joints: Sequence[str] | None,
                path: Path) -> tuple[tuple[str, ...], np.ndarray]:
    """(joint names, values (N, k)) of ``src``: every joint that has the field, or ``joints`` in
    that order (BagError naming the first one missing)."""
    have, values = s.take(src.field, joints)
    if joints is not None and len(have) != len(joints):
        missing = next(j for j in joints if j not in have)
        if missing not in (s.names or ()):
            raise BagError(f"{path}: "
                           + missing_joint_text(missing, src.topic, s.names or (), joints))
        has = [f for j, f in s.columns if j == missing]
        raise BagError(f"{path}: joint {missing!r} has no {src.field} in {src.topic} (it has: "
                       f"{', '.join(has) or 'nothing'})")
    return have, values
