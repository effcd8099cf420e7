"""Where live identification takes a recording's current from, in the offline order: a
DynamicJointState interface, the JointState effort, the CurrentReference; one-line reasons."""
from __future__ import annotations

import numpy as np
import pytest

from orthoglide_ident.bags.encoding import encode_dynamic_joint_states, encode_joint_states
from orthoglide_ident.errors import DataError
from orthoglide_ident.nodes.live_sources import (
    DYNAMIC,
    EFFORT,
    REFERENCE,
    SOURCE_WAIT_S,
    LiveTopics,
    choose_current,
)

JOINTS = ("shoulder_pan_joint", "elbow_joint")
HW = ("elbow_joint", "gripper", "shoulder_pan_joint")  # the hardware's order, an extra joint
RESOLVED = {
    "q": "/joint_states",
    "d": "/dynamic_joint_states",
    "v": "/orthoglide/current_reference",
}


def _js(effort: bool = True, names=HW) -> bytes:
    n = len(names)
    e = np.array([[0.1, np.nan, 0.3]])[:, :n] if effort else None
    return encode_joint_states(
        names, np.array([10**9]), np.zeros((1, n)), np.zeros((1, n)), e
    )[0].tobytes()


def _djs(gripper_current: bool = False, arm=("position", "velocity", "current")) -> bytes:
    ifaces = [arm, ("position", "velocity", "current") if gripper_current else ("position",), arm]
    vals = {i: np.ones((1, 3)) for i in ("position", "velocity", "current", "torque")}
    return encode_dynamic_joint_states(HW, ifaces, np.array([10**9]), vals)[0].tobytes()


JOINT_STATES_TOPICS = LiveTopics("joint_states")


def choose(first, publishers=None, waited=0.0, topics=JOINT_STATES_TOPICS):
    return choose_current(JOINTS, topics, first, publishers or {}, waited, RESOLVED)


def test_order_of_preference():
    assert choose({"q": _js(), "d": _djs(), "v": b"x"}) == DYNAMIC
    assert choose({"q": _js(), "d": None, "v": b"x"}) == EFFORT  # no dynamic_joint_states publisher
    assert choose({"q": _js(effort=False), "d": None, "v": b"x"}) == REFERENCE
    # DynamicJointState without a current interface at all: the effort is next, as offline
    assert choose({"q": _js(), "d": _djs(arm=("position", "velocity", "torque"))}) == EFFORT


def test_waits_for_a_preferred_topic_that_has_a_publisher():
    first = {"q": _js(), "d": None}
    assert choose(first, {"d": 1}) is None
    assert choose(first, {"d": 1}, waited=SOURCE_WAIT_S) == EFFORT  # published nothing in time
    assert choose({"q": None}) is None  # no joint state of the recording yet


def test_missing_interface_or_joint_is_a_one_line_reason():
    only_some = _djs(arm=("position", "velocity"))  # elbow and shoulder without current ...
    with pytest.raises(
        DataError,
        match="joint 'shoulder_pan_joint' has no torque in /dynamic_joint_states "
        r"\(it has: position, velocity\)",
    ):
        choose({"q": _js(), "d": only_some}, topics=LiveTopics("joint_states", interface="torque"))
    with pytest.raises(
        DataError, match=r"interface 'torque' asked for \(current_interface\), but nothing"
    ):
        choose({"q": _js(), "d": None}, waited=SOURCE_WAIT_S,
               topics=LiveTopics("joint_states", interface="torque"))
    with pytest.raises(DataError, match="joint 'shoulder_pan_joint' is not in /joint_states"):
        choose({"q": _js(names=("elbow_joint", "gripper")), "d": None})
    with pytest.raises(DataError) as e:
        choose({"q": _js(effort=False), "d": None, "v": None}, waited=SOURCE_WAIT_S)
    assert str(e.value) == (
        "no current for shoulder_pan_joint, elbow_joint: /joint_states carries no effort, "
        "nothing on /dynamic_joint_states with interface 'current', nothing on "
        "/orthoglide/current_reference"
    )
