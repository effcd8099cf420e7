"""bags/_cdr.py: the bulk layout of one CDR message. Its unit test, so it imports the private
module (the public path, read_bag, falls back to decoding one by one without telling)."""
from __future__ import annotations

from orthoglide_ident.bags import _cdr  # the unit test of this private module
from orthoglide_ident.bags.topics import JOINT_STATE_TYPE


def test_rclpy_serialisation_has_a_bulk_layout():
    """rclpy's CDR (garbage padding, trailing bytes) parses into the bulk layout."""
    from rclpy import serialization as rclpy_ser
    from sensor_msgs.msg import JointState

    msg = JointState()
    msg.header.stamp.sec, msg.header.stamp.nanosec = 1_700_000_000, 5
    msg.name = ["q11", "q12", "q13"]
    msg.position = [0.1, -0.2, 0.3]
    lay = _cdr.layout(rclpy_ser.serialize_message(msg), JOINT_STATE_TYPE)
    assert lay is not None and lay.names == ("q11", "q12", "q13")
    assert _cdr.layout(b"\x00\x01\x00\x00" + b"\xff" * 8, JOINT_STATE_TYPE) is None  # malformed
