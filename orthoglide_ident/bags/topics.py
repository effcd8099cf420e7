"""The topics and message types of the bags (docs/design/interfaces.md), the rosbag2 records of
their definitions (type hash) and QoS: ``bags.topics.JOINT_STATES_TOPIC``, ..."""
from __future__ import annotations

from ._types import (
    CURRENT_REFERENCE_TOPIC,
    CURRENT_REFERENCE_TYPE,
    DYNAMIC_JOINT_STATE_TYPE,
    DYNAMIC_JOINT_STATES_TOPIC,
    JOINT_STATE_TYPE,
    JOINT_STATES_TOPIC,
    JTC_STATE_TYPE,
    ROS2_CONTROL_JOINT_STATES_TOPIC,
    default_qos,
    msgdef_and_hash,
    qos_profile,
)

__all__ = [
    "CURRENT_REFERENCE_TOPIC",
    "CURRENT_REFERENCE_TYPE",
    "DYNAMIC_JOINT_STATES_TOPIC",
    "DYNAMIC_JOINT_STATE_TYPE",
    "JOINT_STATES_TOPIC",
    "JOINT_STATE_TYPE",
    "JTC_STATE_TYPE",
    "ROS2_CONTROL_JOINT_STATES_TOPIC",
    "default_qos",
    "msgdef_and_hash",
    "qos_profile",
]
