"""The one CDR template patcher (bags.CdrTemplate): what the bags' encoders, the broadcasters and
the simulated driver write equals rosbags' own serialisation of the message."""
from __future__ import annotations

import numpy as np

from orthoglide_ident import bags

NAMES = ("q11", "q12", "q13")


def _rosbags_joint_state(sec: int, nanosec: int, position, velocity) -> bytes:
    store = bags.topics.typestore()
    T, H = store.types["builtin_interfaces/msg/Time"], store.types["std_msgs/msg/Header"]
    msg = store.types[bags.topics.JOINT_STATE_TYPE](
        header=H(stamp=T(sec=sec, nanosec=nanosec), frame_id=""), name=list(NAMES),
        position=np.asarray(position, float), velocity=np.asarray(velocity, float),
        effort=np.zeros(0))
    return bytes(store.serialize_cdr(msg, bags.topics.JOINT_STATE_TYPE))


def test_one_message_and_many_equal_rosbags_serialisation():
    rng = np.random.default_rng(3)
    tpl = bags.encoding.MessageTemplate.joint_state(NAMES, ("position", "velocity"))
    stamps = rng.integers(0, 2 * 10**18, 5)  # sec within int32
    values = rng.normal(size=(5, 6))
    many = bags.encoding.encode_joint_states(NAMES, stamps, values[:, :3], values[:, 3:])
    for k, ns in enumerate(stamps.tolist()):
        expected = _rosbags_joint_state(*divmod(ns, 10**9), values[k, :3], values[k, 3:])
        assert tpl.encode(ns, values[k]) == expected
        assert many[k].tobytes() == expected


def test_the_simulated_driver_patches_with_the_same_template_class():
    from sensor_msgs.msg import JointState

    from orthoglide_sim.common.packed_messages import PackedMessage

    packed = PackedMessage(JointState, NAMES, ["position", "velocity"])
    assert isinstance(packed._cdr, bags.encoding.CdrTemplate)
    q, qd = [0.1, -0.2, 0.3], [1.0, 2.0, -3.0]
    raw = packed.pack(12, 345, q, qd)
    # rclpy leaves the CDR padding uninitialised: equal to rosbags' bytes as a message
    assert len(raw) == len(_rosbags_joint_state(12, 345, q, qd))
    msg = bags.topics.typestore().deserialize_cdr(raw, bags.topics.JOINT_STATE_TYPE)
    assert (msg.header.stamp.sec, msg.header.stamp.nanosec) == (12, 345) and msg.name == list(NAMES)
    assert msg.position.tolist() == q and msg.velocity.tolist() == qd and len(msg.effort) == 0
