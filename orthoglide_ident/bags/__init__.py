"""rosbag2/MCAP bags: tagged writing, fast reading, info, recovery (docs/design/interfaces.md).

No rclpy here. Files are written by the official MCAP library as rosbag2's MCAP storage plugin
writes them (``_mcapfile``, ``_metadata``) and read by a fast crash-tolerant scanner (``_mcap``);
message definitions and type hashes come from rosbags' typestore (reading: from the bag's own
schemas); q and the current are decoded in bulk with numpy (``_cdr``, ``_decode``) from the
Orthoglide's topics or a ros2_control robot's, as :mod:`.sources` chooses.

- :func:`write_bag` — a whole record at once (the simulator's sample bags).
- :class:`BagWriter` — streaming, chunked, split-capable writer (the recorder).
- :func:`read_bag` → :class:`BagData`; :func:`bag_info` → :class:`BagInfo`.
- :func:`reindex` → :class:`ReindexResult` — close cut-short files, rebuild metadata.yaml.
"""

from __future__ import annotations

from ._encode import (
    CdrTemplate,
    MessageTemplate,
    encode_dynamic_joint_states,
    encode_joint_states,
    encode_messages,
)
from ._tags import (
    COM_KEY,
    CONDITION_KEY,
    CONDITIONS,
    CURRENT_SOURCE_KEY,
    EFFORT_SIDE_KEY,
    EFFORT_UNIT_KEY,
    FRAME_KEY,
    INCOMPLETE_KEY,
    INERTIA_KEY,
    MASS_KEY,
    METADATA_NAME,
    POSITION_SIDE_KEY,
    POSITION_SOURCE_KEY,
    SIDES,
    BagTags,
)
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
from .info import BagInfo, Gaps, TickCounter, TopicInfo, bag_info, find_gaps
from .reader import (
    BagData,
    CurrentReferences,
    FileStatus,
    JointStates,
    bag_files,
    decode_messages,
    read_bag,
)
from .recording import Recording
from .reindex import FileReport, ReindexResult, left_open, reindex
from .sources import BagSources, Source
from .writer import LAYOUTS, BagWriter, write_bag

__all__ = [
    "COM_KEY",
    "CONDITIONS",
    "CONDITION_KEY",
    "CURRENT_REFERENCE_TOPIC",
    "CURRENT_REFERENCE_TYPE",
    "CURRENT_SOURCE_KEY",
    "DYNAMIC_JOINT_STATES_TOPIC",
    "DYNAMIC_JOINT_STATE_TYPE",
    "EFFORT_SIDE_KEY",
    "EFFORT_UNIT_KEY",
    "FRAME_KEY",
    "INCOMPLETE_KEY",
    "INERTIA_KEY",
    "JOINT_STATES_TOPIC",
    "JOINT_STATE_TYPE",
    "JTC_STATE_TYPE",
    "LAYOUTS",
    "MASS_KEY",
    "CdrTemplate",
    "MessageTemplate",
    "METADATA_NAME",
    "POSITION_SIDE_KEY",
    "POSITION_SOURCE_KEY",
    "SIDES",
    "ROS2_CONTROL_JOINT_STATES_TOPIC",
    "TickCounter",
    "BagData",
    "BagInfo",
    "BagSources",
    "BagTags",
    "BagWriter",
    "Recording",
    "ReindexResult",
    "Source",
    "CurrentReferences",
    "FileReport",
    "FileStatus",
    "Gaps",
    "JointStates",
    "left_open",
    "TopicInfo",
    "bag_files",
    "bag_info",
    "decode_messages",
    "default_qos",
    "encode_dynamic_joint_states",
    "encode_joint_states",
    "encode_messages",
    "find_gaps",
    "msgdef_and_hash",
    "qos_profile",
    "read_bag",
    "reindex",
    "write_bag",
]
