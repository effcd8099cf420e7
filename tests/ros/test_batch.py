"""Batch intake (ros/batch.py): a callback that raises loses its batch, says why, and the
thread goes on taking the topic (it used to die silently: a node up but deaf)."""
from __future__ import annotations

import time

import pytest

rclpy = pytest.importorskip("rclpy")


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
