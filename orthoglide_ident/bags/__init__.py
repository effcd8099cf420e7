"""rosbag2/MCAP bags of the Orthoglide: tagged writing, fast reading, info, recovery (DESIGN §4).

No rclpy here. Files are written by the official MCAP library as rosbag2's MCAP storage plugin
writes them (``_mcapfile``, ``_metadata``) and read by a fast crash-tolerant scanner (``_mcap``);
message definitions and type hashes come from rosbags' typestore, q and v_tau are decoded in bulk
with numpy (``_cdr``).

- :func:`write_bag` — a whole record at once (the simulator's sample bags).
- :class:`BagWriter` — streaming, chunked, split-capable writer (the recorder).
- :func:`read_bag` → :class:`BagData`; :func:`bag_info` → :class:`BagInfo`.
- :func:`reindex` → :class:`ReindexResult` — close cut-short files, rebuild metadata.yaml.
"""

from __future__ import annotations

from ._tags import CONDITION_KEY, CONDITIONS, MASS_KEY, METADATA_NAME, BagTags
from ._types import (
    CURRENT_REFERENCE_TOPIC,
    CURRENT_REFERENCE_TYPE,
    JOINT_STATE_TYPE,
    JOINT_STATES_TOPIC,
    default_qos,
    msgdef_and_hash,
    qos_profile,
)
from .info import BagInfo, Gaps, TickCounter, TopicInfo, bag_info, find_gaps
from .recording import Recording
from .reader import (
    BagData,
    CurrentReferences,
    FileStatus,
    JointStates,
    bag_files,
    decode_messages,
    read_bag,
)
from .reindex import FileReport, ReindexResult, left_open, reindex
from .writer import BagWriter, encode_messages, write_bag

__all__ = [
    "CONDITIONS",
    "CONDITION_KEY",
    "CURRENT_REFERENCE_TOPIC",
    "CURRENT_REFERENCE_TYPE",
    "JOINT_STATES_TOPIC",
    "JOINT_STATE_TYPE",
    "MASS_KEY",
    "METADATA_NAME",
    "TickCounter",
    "BagData",
    "BagInfo",
    "BagTags",
    "BagWriter",
    "Recording",
    "ReindexResult",
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
    "encode_messages",
    "find_gaps",
    "msgdef_and_hash",
    "qos_profile",
    "read_bag",
    "reindex",
    "write_bag",
]
