"""The live feed hands LiveIdentification exactly the recorded ticks: a recording ends only when
every topic has delivered its last recorded tick here, not when the buffers happen to be empty."""
from __future__ import annotations

import threading

from orthoglide_ident.model.registry import load_robot

ORTHOGLIDE = load_robot("orthoglide")  # the robot these records are of

import rclpy


class _Spy:
    """Stands in for LiveIdentification: records which stamps were fed and when it stopped."""

    def __init__(self) -> None:
        self.stamps: dict[str, list[int]] = {"q": [], "v": []}
        self.stopped = False

    def start_recording(self, *_):
        pass

    def stop_recording(self):
        self.stopped = True
        return []

    def add_joint_states(self, stamps, names, values):
        self.stamps["q"] += [int(s) for s in stamps]
        return []

    def add_current_reference(self, stamps, names, values):
        self.stamps["v"] += [int(s) for s in stamps]
        return []

    def estimate(self):
        return type("E", (), {"line": lambda self: "spy"})()


def _raw(cls, stamp_ns: int) -> bytes:
    from rclpy.serialization import serialize_message

    m = cls(name=["q11", "q12", "q13"])
    if hasattr(m, "position"):
        m.position = [0.0, 0.0, 0.0]
    else:
        m.current = [0.0, 0.0, 0.0]
    m.header.stamp.sec, m.header.stamp.nanosec = divmod(stamp_ns, 1_000_000_000)
    return serialize_message(m)


def test_recording_ends_when_every_topic_delivered_its_last_tick():
    from sensor_msgs.msg import JointState

    from orthoglide_ident.nodes.live_feed import LiveFeed
    from orthoglide_msgs.msg import CurrentReference, RecorderStatus

    rclpy.init()
    node = rclpy.create_node("test_live_feed")
    try:
        spy = _Spy()
        feed = LiveFeed(node, spy, threading.Lock(), robot=ORTHOGLIDE, worker=False)
        t0 = 10**12
        status = RecorderStatus(recording=True, condition="unloaded", bag_path="/bags/x")
        status.first_tick.sec, status.first_tick.nanosec = divmod(t0, 10**9)
        feed.on_status(status)
        for k in range(100):  # ticks 0..99 arrive; the recorder wrote 0..119
            feed.buffers["q"].append(_raw(JointState, t0 + k * 10**6))
            feed.buffers["v"].append(_raw(CurrentReference, t0 + k * 10**6))
        status = RecorderStatus(recording=False, condition="unloaded", bag_path="/bags/x",
                                first_tick=status.first_tick)  # a new message, as DDS delivers
        status.last_tick.sec, status.last_tick.nanosec = divmod(t0 + 119 * 10**6, 10**9)
        feed.on_status(status)
        feed.turn()
        assert not spy.stopped, "finished before ticks 100..119 arrived"
        assert spy.stamps["q"][-1] == t0 + 99 * 10**6
        for k in range(100, 125):  # the rest arrives, with ticks after the recording
            feed.buffers["q"].append(_raw(JointState, t0 + k * 10**6))
            feed.buffers["v"].append(_raw(CurrentReference, t0 + k * 10**6))
        feed.turn()
        assert spy.stopped
        want = [t0 + k * 10**6 for k in range(120)]
        assert spy.stamps["q"] == want and spy.stamps["v"] == want
        feed.close()
    finally:
        node.destroy_node()
        rclpy.shutdown()


def test_a_recorder_killed_and_restarted_ends_the_recording_it_left():
    """The recorder killed mid-recording never says "stopped"; the one that replaces it says "idle":
    the live recording ends at the last tick received, with a warning, instead of staying open."""
    from sensor_msgs.msg import JointState

    from orthoglide_ident.nodes.live_feed import LiveFeed
    from orthoglide_msgs.msg import CurrentReference, RecorderStatus

    rclpy.init()
    node = rclpy.create_node("test_live_feed_restart")
    try:
        spy = _Spy()
        feed = LiveFeed(node, spy, threading.Lock(), robot=ORTHOGLIDE, worker=False)
        t0 = 10**12
        status = RecorderStatus(recording=True, condition="unloaded", bag_path="/bags/killed")
        status.first_tick.sec, status.first_tick.nanosec = divmod(t0, 10**9)
        feed.on_status(status)
        for k in range(50):
            feed.buffers["q"].append(_raw(JointState, t0 + k * 10**6))
            feed.buffers["v"].append(_raw(CurrentReference, t0 + k * 10**6))
        feed.turn()
        # the new recorder
        feed.on_status(RecorderStatus(recording=False, bag_path="", message="idle"))
        feed.turn()
        assert spy.stopped and feed.bag is None
        want = [t0 + k * 10**6 for k in range(50)]
        assert spy.stamps["q"] == want and spy.stamps["v"] == want
        assert any("restarted without stopping it" in w for w in feed.warnings)
        feed.close()
    finally:
        node.destroy_node()
        rclpy.shutdown()


def test_a_stop_and_the_next_start_between_two_feeds_lose_nothing():
    """The recorder stops a recording and starts the next within one feed period (the stop's
    status and the start's handled back to back): the first recording still gets every tick it
    holds, the newest 0.25 s the feed held back while recording included, and the second starts
    at its own first tick."""
    from sensor_msgs.msg import JointState

    from orthoglide_ident.nodes.live_feed import LiveFeed
    from orthoglide_msgs.msg import CurrentReference, RecorderStatus

    rclpy.init()
    node = rclpy.create_node("test_live_feed_back_to_back")
    try:
        spy = _Spy()
        feed = LiveFeed(node, spy, threading.Lock(), robot=ORTHOGLIDE, worker=False)
        t0, ms = 10**12, 10**6
        first = RecorderStatus(recording=True, condition="unloaded", bag_path="/bags/a")
        first.first_tick.sec, first.first_tick.nanosec = divmod(t0, 10**9)
        feed.on_status(first)
        for k in range(1000):
            feed.buffers["q"].append(_raw(JointState, t0 + k * ms))
            feed.buffers["v"].append(_raw(CurrentReference, t0 + k * ms))
        feed.turn()
        assert spy.stamps["q"][-1] == t0 + 749 * ms  # the newest 0.25 s held back
        stop = RecorderStatus(recording=False, condition="unloaded", bag_path="/bags/a",
                              first_tick=first.first_tick)  # a new message, as DDS delivers
        stop.last_tick.sec, stop.last_tick.nanosec = divmod(t0 + 999 * ms, 10**9)
        feed.on_status(stop)
        second = RecorderStatus(
            recording=True, condition="loaded", payload_mass=1.0, bag_path="/bags/b"
        )
        second.first_tick.sec, second.first_tick.nanosec = divmod(t0 + 1020 * ms, 10**9)
        for k in range(1000, 1400):  # between the recordings, then the second's
            feed.buffers["q"].append(_raw(JointState, t0 + k * ms))
            feed.buffers["v"].append(_raw(CurrentReference, t0 + k * ms))
        feed.on_status(second)
        feed.turn()  # the stop and the start applied back to back, then one feed
        assert spy.stopped and not feed.warnings, feed.warnings
        want = [t0 + k * ms for k in range(1000)]
        assert spy.stamps["q"][:1000] == want and spy.stamps["v"][:1000] == want
        assert spy.stamps["q"][1000] == t0 + 1020 * ms  # the second recording's first tick
        feed.close()
    finally:
        node.destroy_node()
        rclpy.shutdown()


def test_the_first_message_of_each_topic_is_said_once():
    """'live identification: receiving <topic>' when a topic's first batch comes in (its
    publishers matched: what they publish from then on reaches live identification), once."""
    from sensor_msgs.msg import JointState

    from orthoglide_ident.nodes.live_feed import LiveFeed

    rclpy.init()
    node = rclpy.create_node("test_live_feed_receiving")
    said: list[str] = []
    try:
        feed = LiveFeed(node, _Spy(), threading.Lock(), robot=ORTHOGLIDE, worker=False)
        logger = type("L", (), {"info": lambda self, m: said.append(m)})()
        feed.node = type(
            "N",
            (),
            {
                "get_logger": lambda self: logger,
                "resolve_topic_name": lambda self, t: node.resolve_topic_name(t),
            },
        )()
        take = feed._intake("q", None).on_batch
        for k in range(3):
            take([(_raw(JointState, 10**12 + k), 0, 0)])
        assert said == ["live identification: receiving /orthoglide/joint_states"]
        assert len(feed.buffers["q"]) == 3
        feed.close()
    finally:
        node.destroy_node()
        rclpy.shutdown()
