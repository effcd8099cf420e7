"""Batch intake (ros/batch.py): a callback that raises loses its batch, says why, and the
thread goes on taking the topic (it used to die silently: a node up but deaf)."""
from __future__ import annotations

import time

import rclpy


def test_a_failing_callback_is_logged_and_later_batches_still_arrive():
    from rclpy.qos import QoSProfile
    from std_msgs.msg import String

    from orthoglide_ident.ros.batch import BatchTaker, BatchTopic

    rclpy.init()
    node = rclpy.create_node("test_batch_owner")
    pub_node = rclpy.create_node("test_batch_pub")
    got: list[int] = []

    def on_batch(batch):
        if not got:
            got.append(-1)
            raise AttributeError("'Owner' object has no attribute 'monitor'")
        got.extend(len(raw) for raw, _, _ in batch)

    taker = BatchTaker(node, [BatchTopic(String, "batch_test", QoSProfile(depth=100), on_batch)])
    pub = pub_node.create_publisher(String, "batch_test", 100)
    try:
        deadline = time.monotonic() + 20.0
        while len(got) < 5 and time.monotonic() < deadline:
            pub.publish(String(data="x"))
            time.sleep(0.02)
        assert len(got) >= 5, "the taker stopped after its callback raised"
        assert taker.failures == 1
        assert taker._thread.is_alive()
    finally:
        taker.close()
        pub_node.destroy_node()
        node.destroy_node()
        rclpy.shutdown()


def test_the_intake_node_is_hidden_beside_its_owner():
    """`ros2 node list` leaves out nodes whose name starts with "_" (ros2node's hidden nodes):
    a user sees the node started, not its intake helper; `-a` shows both."""
    from rclpy.qos import QoSProfile
    from std_msgs.msg import String

    from orthoglide_ident.ros.batch import BatchTaker, BatchTopic

    rclpy.init()
    node = rclpy.create_node("test_hidden_owner", namespace="/robot2")
    taker = BatchTaker(node, [BatchTopic(String, "hidden_test", QoSProfile(depth=10),
                                         lambda batch: None)])
    try:
        deadline = time.monotonic() + 20.0
        names: list[tuple[str, str]] = []
        while time.monotonic() < deadline:
            names = node.get_node_names_and_namespaces()
            if ("_test_hidden_owner_rx", "/robot2") in names:
                break
            time.sleep(0.05)
        assert ("_test_hidden_owner_rx", "/robot2") in names  # in the owner's namespace
        visible = [n for n, ns in names if ns == "/robot2" and not n.startswith("_")]
        assert visible == ["test_hidden_owner"]
    finally:
        taker.close()
        node.destroy_node()
        rclpy.shutdown()


def _fifo_allowed() -> bool:
    import os
    import threading

    ok = []

    def probe():
        try:
            os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(1))
            ok.append(True)
        except OSError:
            ok.append(False)

    t = threading.Thread(target=probe)
    t.start()
    t.join()
    return ok[0]


def test_a_real_time_intake_thread_runs_sched_fifo_or_says_why_not():
    """The ctc's intake (rt_priority) runs SCHED_FIFO so that a busy machine does not starve it;
    the rest of the process keeps its ordinary scheduling."""
    import os

    from rclpy.qos import QoSProfile
    from std_msgs.msg import String

    from orthoglide_ident.ros.batch import BatchTaker, BatchTopic

    rclpy.init()
    node = rclpy.create_node("test_rt_owner")
    said: list[str] = []
    logger = node.get_logger()
    node.get_logger = lambda: type("L", (), {  # noqa: E731 - capture what the taker says
        "info": lambda self, m, **k: said.append(m), "warning": lambda self, m, **k: said.append(m),
        "error": lambda self, m, **k: logger.error(m)})()
    taker = BatchTaker(node, [BatchTopic(String, "rt_test", QoSProfile(depth=10), lambda b: None)],
                       rt_priority=5)
    try:
        deadline = time.monotonic() + 10.0
        while not said and time.monotonic() < deadline:
            time.sleep(0.02)
        policy = os.sched_getscheduler(taker._thread.native_id)
        if _fifo_allowed():
            assert policy == os.SCHED_FIFO and "real-time priority 5" in said[0], said
        else:
            assert policy != os.SCHED_FIFO and "no real-time priority" in said[0], said
        assert os.sched_getscheduler(0) != os.SCHED_FIFO  # this (main) thread: unchanged
    finally:
        taker.close()
        node.destroy_node()
        rclpy.shutdown()
