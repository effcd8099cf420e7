"""The topics and message types of the bags (docs/design/interfaces.md), the rosbag2 records of
their definitions (type hash) and QoS: ``bags.topics.JOINT_STATES_TOPIC``, ...; ``typestore()``
is rosbags' Jazzy typestore with the product's own types (orthoglide_msgs, control_msgs) added,
for writing or decoding these messages with rosbags."""
from __future__ import annotations

from ._types import (
    CURRENT_REFERENCE_TOPIC,
    CURRENT_REFERENCE_TYPE,
    DYNAMIC_JOINT_STATE_TYPE,
    DYNAMIC_JOINT_STATES_TOPIC,
    INTERFACE_VALUE_TYPE,
    JOINT_STATE_TYPE,
    JOINT_STATES_TOPIC,
    JTC_STATE_TYPE,
    ROS2_CONTROL_JOINT_STATES_TOPIC,
    default_qos,
    msgdef_and_hash,
    qos_profile,
    typestore,
)

__all__ = [
    "CURRENT_REFERENCE_TOPIC",
    "CURRENT_REFERENCE_TYPE",
    "DYNAMIC_JOINT_STATES_TOPIC",
    "DYNAMIC_JOINT_STATE_TYPE",
    "INTERFACE_VALUE_TYPE",
    "JOINT_STATES_TOPIC",
    "JOINT_STATE_TYPE",
    "JTC_STATE_TYPE",
    "ROS2_CONTROL_JOINT_STATES_TOPIC",
    "default_qos",
    "msgdef_and_hash",
    "qos_profile",
    "typestore",
]
