"""rosbag2 bag metadata (version 9): metadata.yaml and the ``rosbag2`` MCAP metadata record.

rosbag2's MCAP storage plugin (rosbag2_storage_mcap, ``MCAPStorage::update_metadata``) writes an
MCAP metadata record named ``rosbag2`` with one key, ``serialized_metadata``: the YAML of the bag
metadata, i.e. the mapping that metadata.yaml holds under ``rosbag2_bagfile_information``. The
sequential writer calls it when a file is opened (topics and counts still empty, ``custom_data``
already there), before a split closes a file, and at close; ``ros2 bag reindex`` and ``ros2 bag
info`` on a lone file read it back (the last one wins), which is how ``custom_data`` (our tags)
survives a reindex. One structure here feeds both, so they never disagree.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from orthoglide_ident.yaml_files import safe_load

METADATA_VERSION = 9
ROSBAG2_RECORD = "rosbag2"
SERIALIZED_KEY = "serialized_metadata"
ROS_DISTRO = "jazzy"


@dataclass
class TopicStat:
    """One topic of a bag: rosbag2 topic metadata and its message count."""

    name: str
    msgtype: str
    qos: list[dict[str, Any]]
    type_hash: str
    count: int = 0
    serialization_format: str = "cdr"


@dataclass
class FileStat:
    """One .mcap file of a bag: message count and log-time span (ns since the epoch)."""

    path: Path
    count: int = 0
    start: int = 2**63 - 1
    end: int = 0

    def add(self, log_start_ns: int, log_end_ns: int, count: int) -> None:
        """Account for ``count`` messages logged between the two times."""
        self.count += count
        self.start = min(self.start, log_start_ns)
        self.end = max(self.end, log_end_ns)


@dataclass
class BagMetadata:
    """What metadata.yaml and the ``rosbag2`` record say about a bag."""

    topics: list[TopicStat] = field(default_factory=list)
    files: list[FileStat] = field(default_factory=list)
    custom_data: dict[str, str] = field(default_factory=dict)
    ros_distro: str = ROS_DISTRO

    def to_dict(self) -> dict[str, Any]:
        """The ``rosbag2_bagfile_information`` mapping (times in ns, log times)."""
        used = [f for f in self.files if f.count]
        start = min((f.start for f in used), default=0)
        end = max((f.end for f in used), default=0)
        return {
            "version": METADATA_VERSION,
            "storage_identifier": "mcap",
            "duration": {"nanoseconds": max(0, end - start)},
            "starting_time": {"nanoseconds_since_epoch": start},
            "message_count": sum(f.count for f in self.files),
            "topics_with_message_count": [_topic_dict(t) for t in self.topics],
            "compression_format": "",
            "compression_mode": "",
            "relative_file_paths": [f.path.name for f in self.files],
            "files": [_file_dict(f) for f in self.files],
            "custom_data": dict(self.custom_data),
            "ros_distro": self.ros_distro,
        }

    def serialized(self) -> str:
        """The value of the ``serialized_metadata`` key of the ``rosbag2`` record."""
        return yaml.safe_dump(self.to_dict(), sort_keys=False)

    def record(self) -> dict[str, str]:
        """The items of the ``rosbag2`` MCAP metadata record."""
        return {SERIALIZED_KEY: self.serialized()}

    def write_yaml(self, bag_dir: Path) -> None:
        """(Re)write ``bag_dir/metadata.yaml`` atomically (OSError propagates)."""
        text = yaml.safe_dump({"rosbag2_bagfile_information": self.to_dict()}, sort_keys=False)
        tmp = Path(bag_dir) / "metadata.yaml.tmp"
        tmp.write_text(text)
        os.replace(tmp, Path(bag_dir) / "metadata.yaml")


def _topic_dict(t: TopicStat) -> dict[str, Any]:
    return {
        "topic_metadata": {
            "name": t.name,
            "type": t.msgtype,
            "serialization_format": t.serialization_format,
            "offered_qos_profiles": t.qos,
            "type_description_hash": t.type_hash,
        },
        "message_count": t.count,
    }


def _file_dict(f: FileStat) -> dict[str, Any]:
    return {
        "path": f.path.name,
        "starting_time": {"nanoseconds_since_epoch": f.start if f.count else 0},
        "duration": {"nanoseconds": max(0, f.end - f.start) if f.count else 0},
        "message_count": f.count,
    }


def parse_record(items: dict[str, str]) -> dict[str, Any] | None:
    """The bag metadata mapping of a ``rosbag2`` record, or None when it is absent or unreadable."""
    doc = _yaml(items.get(SERIALIZED_KEY))
    return doc if isinstance(doc, dict) else None


def channel_qos(text: str | None) -> list[dict[str, Any]] | None:
    """The offered QoS profiles of a channel's ``offered_qos_profiles`` metadata (a YAML list)."""
    doc = _yaml(text)
    if isinstance(doc, list) and all(isinstance(q, dict) for q in doc):
        return doc
    return None


def _yaml(text: str | None) -> Any:
    """The YAML document in ``text``; None when there is none or it does not parse."""
    if not text:
        return None
    try:
        return safe_load(text)
    except yaml.YAMLError:
        return None
