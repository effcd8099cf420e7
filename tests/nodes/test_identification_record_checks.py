"""The identification node's live answer runs offline's record checks (issues 43 and 47): a UR5's
/joint_states (position, and the current as effort) fed in degrees is refused by the service with
the one-line reason `identify` gives for such a bag (success false, the node answers on), then a
good feed of the same runs is answered (success true). Stamps given, the node's own handler, the
feed turned by the test (no wall clock)."""
from __future__ import annotations

import dataclasses
import math
import time

import pytest

rclpy = pytest.importorskip("rclpy")
from ros2_control_records import ROBOT, standin_records  # noqa: E402

PARAMS = {"robot": ROBOT, "joint_states_topic": "joint_states", "current_reference_topic": "''",
          "dynamic_joint_states_topic": "''", "check_excitation": "false",
          "partial_answers": "false"}
BOUND_S = 60.0  # a bound on a hang, not a figure


@pytest.fixture(scope="module")
def records():
    return standin_records(seconds=8.0, drop_rate=0.0)


@pytest.fixture
def node():
    from orthoglide_ident.nodes.identification import IdentificationNode

    args = ["--ros-args"] + [a for k, v in PARAMS.items() for a in ("-p", f"{k}:={v}")]
    rclpy.init(args=args)
    n = IdentificationNode()
    yield n
    n.close()
    n.destroy_node()
    rclpy.shutdown()


def _in_degrees(rec):
    """The run as a logger writing degrees in the position field (and the fingers too)."""
    from rclpy.serialization import deserialize_message, serialize_message
    from sensor_msgs.msg import JointState

    out = []
    for stamp, js, _ in rec.messages:
        m = deserialize_message(js, JointState)
        m.position = [math.degrees(x) for x in m.position]
        out.append((stamp, serialize_message(m), None))
    return dataclasses.replace(rec, messages=out)


def _status(bag: str, rec, recording: bool):
    from orthoglide_msgs.msg import RecorderStatus

    m = RecorderStatus(recording=recording, condition=rec.condition,
                       payload_mass=rec.payload_mass, bag_path=bag)
    for field, ns in (("first_tick", rec.messages[0][0]), ("last_tick", rec.messages[-1][0])):
        getattr(m, field).sec, getattr(m, field).nanosec = divmod(ns, 10**9)
    return m


def _record(feed, name: str, rec) -> None:
    """One recording through the node's live feed, as the recorder and the topic deliver it;
    returns when the feed has ended it (its stop checks run)."""
    feed.on_status(_status(name, rec, True))
    feed.turn()
    for k in range(0, len(rec.messages), 250):
        feed.buffers["q"].extend(js for _, js, _ in rec.messages[k:k + 250])
        feed.turn()
    feed.on_status(_status(name, rec, False))
    t_end = time.monotonic() + BOUND_S
    while feed.bag is not None or not feed._jobs.empty():  # the stop applied and fed
        assert time.monotonic() < t_end, f"{name}: the recording did not end"
        feed.turn()


def _call(node):
    from orthoglide_msgs.srv import Identify

    return node.on_identify(Identify.Request(), Identify.Response())


def test_degrees_refused_then_a_good_feed_answered(node, records):
    from orthoglide_ident.errors import DataError
    from orthoglide_ident.identify import Record
    from orthoglide_ident.identify.records.robot_checks import check_positions

    for name, rec in records.items():
        _record(node.feed, f"deg_{name}", _in_degrees(rec))
    res = _call(node)
    assert not res.success and "\n" not in res.message
    assert "deg_loaded" in res.message and "look like degrees" in res.message, res.message
    # the reason offline's check gives for the same positions (independent of the live path)
    rec = records["loaded"]
    from rclpy.serialization import deserialize_message
    from sensor_msgs.msg import JointState

    msgs = [deserialize_message(js, JointState) for _, js, _ in _in_degrees(rec).messages]
    names = list(msgs[0].name)
    arm = list(node.robot.joint_names)  # the model's order, as live keeps them
    q = [[m.position[names.index(n)] for n in arm] for m in msgs]
    stamps = [s for s, _, _ in rec.messages]
    import numpy as np

    bag = Record("deg_loaded", np.array(stamps), arm, np.array(q), np.array(stamps), arm,
                 np.zeros((len(stamps), len(arm))), "loaded", rec.payload_mass)
    with pytest.raises(DataError) as exc:
        check_positions(bag, node.robot)
    assert str(exc.value).split(": ", 1)[1].split(" goes over")[0] in res.message
    assert node.live.estimate().status.startswith("refused: ")

    for name, rec in records.items():  # the node answers on: the same runs, in radians
        _record(node.feed, name, rec)
    res = _call(node)
    assert res.success, res.message
    assert "refused: left out of the live data" in res.message  # said, not counted
    assert "from the live data (" in res.message, res.message
