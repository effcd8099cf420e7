"""Live identification from a ros2_control robot's topics equals the offline identification of
its bag, whether the current comes from /dynamic_joint_states or the JointState effort.

The stand-in's bytes (joint_states + dynamic_joint_states from one update, hardware order, a
gripper joint, dropped ticks) go through the identification node's live side (LiveFeed: bulk
decoding, source choice, LiveIdentification) as they would arrive, and into bags as the recorder
writes them; the same equations live and offline (lag_model: off) must give the same numbers.
"""
from __future__ import annotations

import dataclasses
import threading
import time

import numpy as np
import pytest
import rclpy
from ros2_control_records import ROBOT, standin_records, write_record_bag  # noqa: E402

from orthoglide_ident.identify import IdentifyOptions, LiveIdentification, identify
from orthoglide_ident.model.registry import load_robot

FEED_TICKS = 250  # messages handed to the feed between two feed() calls (a BatchTaker wake-up)


@pytest.fixture(scope="module")
def node():
    rclpy.init()
    n = rclpy.create_node("test_live_ros2_control")
    yield n
    n.destroy_node()
    rclpy.shutdown()


@pytest.fixture(scope="module")
def records():
    return standin_records(seconds=20.0, drop_rate=2e-4)


def _status(bag: str, rec, recording: bool):
    from orthoglide_msgs.msg import RecorderStatus

    m = RecorderStatus(
        recording=recording, condition=rec.condition, payload_mass=rec.payload_mass, bag_path=bag
    )
    for field, ns in (("first_tick", rec.messages[0][0]), ("last_tick", rec.messages[-1][0])):
        getattr(m, field).sec, getattr(m, field).nanosec = divmod(ns, 10**9)
    return m


def run_live(node, records, topics, opts):
    """Feed both records to a LiveFeed as the topics deliver them; the live result and warnings."""
    from orthoglide_ident.nodes.live_feed import LiveFeed

    model = load_robot(ROBOT)
    live = LiveIdentification(opts, model=model)
    feed = LiveFeed(node, live, threading.Lock(), topics, robot=model, worker=False)
    try:
        for name, rec in records.items():
            feed.on_status(_status(name, rec, True))
            feed.turn()  # the worker applies it (here: when the test says)
            for k in range(0, len(rec.messages), FEED_TICKS):
                for _, js, djs in rec.messages[k:k + FEED_TICKS]:
                    if js is not None:
                        feed.buffers["q"].append(js)
                    if djs is not None and "d" in feed.buffers:
                        feed.buffers["d"].append(djs)
                feed.turn()
            feed.on_status(_status(name, rec, False))
            feed.turn()  # the worker applies it (here: when the test says)
            feed.turn()
            assert feed.bag is None, f"{name}: the recording did not end"
        return live.result(), feed.warnings
    finally:
        feed.close()


def _gains(res) -> np.ndarray:
    return np.array([g.value for g in res.drive_gains])


def _rel(a, b) -> float:
    return float(np.max(np.abs(np.asarray(a) - np.asarray(b)) / np.abs(np.asarray(b))))


@pytest.mark.slow
def test_live_equals_offline_from_both_current_sources(node, records, tmp_path):
    from orthoglide_ident.nodes.live_sources import LiveTopics

    opts = IdentifyOptions.of(lag_model="off")  # the same equations live and offline (test_live.py)
    # (A): the same ticks as (B) pairs, the current from the JointState effort alone
    only_js = {
        n: dataclasses.replace(
            r, messages=[(t, a if b is not None else None, None) for t, a, b in r.messages]
        )
        for n, r in records.items()
    }
    bags_b = [str(write_record_bag(tmp_path / f"{n}_b", r)) for n, r in records.items()]
    bags_a = [
        str(write_record_bag(tmp_path / f"{n}_a", r, dynamic=False)) for n, r in only_js.items()
    ]
    offline_b = identify(bags_b, model=load_robot(ROBOT), options=opts)
    offline_a = identify(bags_a, model=load_robot(ROBOT), options=opts)
    live_b, warn_b = run_live(node, records, LiveTopics("joint_states"), opts)
    live_a, warn_a = run_live(
        node, only_js, LiveTopics("joint_states", dynamic_joint_states=""), opts
    )

    # (A) JointState.effort and (B) DynamicJointState carry the same numbers: identical results
    np.testing.assert_array_equal(_gains(offline_a), _gains(offline_b))
    np.testing.assert_array_equal(_gains(live_a), _gains(live_b))
    sources = [{b.sources or None for b in r.record_reports} for r in (offline_a, offline_b)]
    assert sources[0] == {
        "q from /joint_states position (JointState); current from /joint_states effort (JointState)"
    }, sources
    assert sources[1] == {
        "q from /joint_states position (JointState); current from /dynamic_joint_states "
        "interface 'current' (DynamicJointState)"
    }, sources
    # live = offline (the 1e-6), every base parameter too
    assert _rel(_gains(live_b), _gains(offline_b)) < 1e-6
    off = {p.name: p.value for p in offline_b.parameters}
    big = [
        p for p in live_b.parameters if abs(off[p.name]) > 1e-3 * max(abs(v) for v in off.values())
    ]
    assert _rel([p.value for p in big], [off[p.name] for p in big]) < 1e-6
    # and right: the plant's gains, through the hardware order and the gripper joint
    g_true = records["loaded"].g_tau
    assert _rel(_gains(live_b), g_true) < 0.005
    # the dropped ticks were seen as gaps, live and offline
    dropped = sum(r.dropped["joint_states"] for r in records.values())
    assert dropped > 0
    assert any("tick(s) lost" in w for w in warn_b), warn_b


class _Spy:
    """Stands in for LiveIdentification: which recordings started, which stamps came."""

    def __init__(self) -> None:
        self.started: list[str] = []
        self.q: list[int] = []
        self.v: list[int] = []

    def start_recording(self, source, *_):
        self.started.append(source)

    def stop_recording(self):
        return []

    def add_joint_states(self, stamps, names, values):
        self.q += [int(s) for s in stamps]
        return []

    def add_current_reference(self, stamps, names, values):
        self.v += [int(s) for s in stamps]
        return []

    def estimate(self):
        return type("E", (), {"line": lambda self: "spy"})()


def _spy_feed(node, records, topics=None):
    from orthoglide_ident.nodes.live_feed import LiveFeed
    from orthoglide_ident.nodes.live_sources import LiveTopics

    spy = _Spy()
    feed = LiveFeed(node, spy, threading.Lock(), topics or LiveTopics("joint_states"),
                    robot=load_robot(ROBOT), worker=False)
    return spy, feed


@pytest.fixture(scope="module")
def short_records():
    return standin_records(seconds=1.0, drop_rate=0.0)


def test_a_new_robot_model_during_a_recording_leaves_it_out(node, short_records):
    rec = short_records["unloaded"]
    spy, feed = _spy_feed(node, short_records)
    try:
        feed.on_status(_status("run-1", rec, True))
        feed.turn()  # the worker applies it (here: when the test says)
        for _, js, djs in rec.messages[:500]:
            feed.buffers["q"].append(js)
            feed.buffers["d"].append(djs)
        feed.turn()
        assert spy.started == ["run-1"] and spy.q and spy.v  # DJS chosen, fed
        spy2 = _Spy()
        feed.replace(spy2, load_robot(ROBOT))
        assert any("the robot model changed to ur5 during run-1" in w for w in feed.warnings), (
            feed.warnings
        )
        feed.on_status(_status("run-1", rec, True))  # the recorder's next status of the same run
        feed.turn()  # the worker applies it (here: when the test says)
        assert spy2.started == []  # left out: not restarted half-way through
        feed.on_status(_status("run-2", rec, True))
        feed.turn()  # the worker applies it (here: when the test says)
        assert spy2.started == ["run-2"]
    finally:
        feed.close()


def test_a_recording_without_a_current_is_left_out_with_the_reason(node, short_records):
    from orthoglide_ident import bags
    from orthoglide_ident.nodes.live_sources import LiveTopics

    rec = short_records["unloaded"]
    spy, feed = _spy_feed(node, short_records, LiveTopics("joint_states", "", ""))
    try:
        feed.on_status(_status("run-1", rec, True))
        feed.turn()  # the worker applies it (here: when the test says)
        names = rec.layout.names
        for stamp, _, _ in rec.messages[:300]:  # positions only: no effort, no other topic
            msg = bags.encoding.encode_joint_states(names, np.array([stamp]),
                                                    np.zeros((1, len(names))))[0]
            feed.buffers["q"].append(msg.tobytes())
        feed.turn()
        assert feed.bag == "run-1" and not feed.warnings  # waiting for a current a moment
        feed.waiting_since = time.monotonic() - 2.0
        feed.turn()
        assert feed.bag is None and spy.v == []
        assert feed.warnings == [
            "live identification leaves run-1 out: no current for shoulder_pan_joint, "
            "shoulder_lift_joint, elbow_joint, wrist_1_joint, wrist_2_joint, "
            "wrist_3_joint: /joint_states carries no effort"
        ]
        feed.on_status(_status("run-1", rec, True))  # not tried again every second
        feed.turn()  # the worker applies it (here: when the test says)
        assert spy.started == ["run-1"]
    finally:
        feed.close()


def test_a_best_effort_publisher_is_followed(node):
    """A reliable subscription never matches a best-effort publisher: the feed follows what the
    publishers offer, as the recorder does."""
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState

    spy, feed = _spy_feed(node, None)
    pub_node = rclpy.create_node("best_effort_publisher")
    try:
        pub = pub_node.create_publisher(
            JointState,
            "/joint_states",
            QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT),
        )
        t_end = time.monotonic() + 20
        while feed.reliability["q"] != ReliabilityPolicy.BEST_EFFORT:
            assert time.monotonic() < t_end, "the publisher was never seen"
            feed.follow_publishers()
            time.sleep(0.1)
        while not feed.buffers["q"]:
            assert time.monotonic() < t_end, "nothing taken from the best-effort publisher"
            pub.publish(JointState(name=["a"], position=[0.0]))
            time.sleep(0.05)
    finally:
        feed.close()
        pub_node.destroy_node()
