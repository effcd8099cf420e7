"""Recorder node: tagged rosbag2/MCAP bags of the Orthoglide topics, started/stopped by services.

Subscriptions take serialized messages; a writer thread parses only the header stamp (for the live
count of missing ticks) and hands the bytes to :class:`orthoglide_ident.bags.BagWriter`, which
compresses and writes chunks of ``chunk_duration`` seconds. The executor thread only queues.
"""

from __future__ import annotations

import importlib
import os
import re
import sys
from datetime import datetime
from pathlib import Path
from typing import Any

from orthoglide_ident import bags
from orthoglide_ident.bags.recording import Recording
from orthoglide_ident.errors import OrthoglideError
from orthoglide_ident.nodes._spin import spin

HELP = """usage: ros2 run orthoglide_ident recorder [--ros-args -p NAME:=VALUE ...
                                           | --params-file config/recorder.yaml]

Records tagged rosbag2 bags (metadata.yaml v9 + MCAP) of the Orthoglide topics.

services:
  /orthoglide/recorder/start  orthoglide_msgs/srv/StartRecording  condition (loaded|unloaded),
                              payload_mass [kg, 0 when unloaded], name (bag folder, default
                              <condition>_<date>_<time>) -> success, message, bag_path
  /orthoglide/recorder/stop   std_srvs/srv/Trigger -> success, message (messages written,
                              missing ticks)

parameters (defaults):
  output_dir       bags                      folder for the bag directories
  topics           [/orthoglide/joint_states, /orthoglide/current_reference]
  optional_topics  [/orthoglide/setpoints, /orthoglide/current_command]  recorded when published
  expected_rate    1000.0     Hz, for counting missing ticks from the header stamps
  chunk_duration   0.5        s per MCAP chunk (what a SIGKILL can lose)
  split_duration   0.0        s per .mcap file (0: no split)
  split_size       0          bytes per .mcap file (0: no split)
  compression      zstd       zstd | lz4 | none
  queue_depth      1000       subscription depth (reliable, keep last)
"""

DEFAULTS: dict[str, Any] = {
    "output_dir": "bags",
    "topics": [bags.JOINT_STATES_TOPIC, bags.CURRENT_REFERENCE_TOPIC],
    "optional_topics": ["/orthoglide/setpoints", "/orthoglide/current_command"],
    "expected_rate": 1000.0,
    "chunk_duration": 0.5,
    "split_duration": 0.0,
    "split_size": 0,
    "compression": "zstd",
    "queue_depth": 1000,
}
_NAME = re.compile(r"^[A-Za-z0-9_.+-]+$")


def _qos_dict(qos: Any) -> dict[str, Any]:
    def dur(d: Any) -> dict[str, int]:
        ns = int(getattr(d, "nanoseconds", 0))
        return {"sec": ns // 1_000_000_000, "nsec": ns % 1_000_000_000}

    return bags.qos_profile(
        qos.reliability.name.lower(),
        qos.durability.name.lower(),
        qos.history.name.lower(),
        qos.depth,
        dur(qos.deadline),
        dur(qos.lifespan),
        qos.liveliness.name.lower(),
        dur(qos.liveliness_lease_duration),
    )


def _import_type(msgtype: str) -> Any:
    pkg, kind, name = msgtype.split("/")
    return getattr(importlib.import_module(f"{pkg}.{kind}"), name)


def make_node() -> Any:
    from rclpy.event_handler import SubscriptionEventCallbacks
    from rclpy.node import Node
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
    from std_srvs.srv import Trigger

    from orthoglide_msgs.srv import StartRecording

    class RecorderNode(Node):
        def __init__(self) -> None:
            super().__init__("recorder")
            for name, value in DEFAULTS.items():
                self.declare_parameter(name, value)
            p = {n: self.get_parameter(n).value for n in DEFAULTS}
            self.p = p
            self.qos = QoSProfile(
                history=HistoryPolicy.KEEP_LAST,
                depth=int(p["queue_depth"]),
                reliability=ReliabilityPolicy.RELIABLE,
            )
            self.rec: Recording | None = None
            self.subs: dict[str, tuple[Any, str]] = {}
            known = {
                bags.JOINT_STATES_TOPIC: bags.JOINT_STATE_TYPE,
                bags.CURRENT_REFERENCE_TOPIC: bags.CURRENT_REFERENCE_TYPE,
            }
            for topic in p["topics"]:
                msgtype = known.get(topic) or self._graph_type(topic)
                if msgtype is None:
                    self.get_logger().warning(
                        f"{topic}: type unknown until it is published; will retry"
                    )
                    p["optional_topics"] = list(p["optional_topics"]) + [topic]
                    continue
                self._subscribe(topic, msgtype)
            self.create_service(StartRecording, "/orthoglide/recorder/start", self.on_start)
            self.create_service(Trigger, "/orthoglide/recorder/stop", self.on_stop)
            self.create_timer(1.0, self.discover)
            self.get_logger().info(f"recorder ready; bags go to {Path(p['output_dir']).resolve()}")

        def _graph_type(self, topic: str) -> str | None:
            types = dict(self.get_topic_names_and_types()).get(topic)
            return types[0] if types else None

        def _subscribe(self, topic: str, msgtype: str) -> None:
            try:
                cls = _import_type(msgtype)
            except (ImportError, AttributeError, ValueError):
                self.get_logger().warning(f"{topic}: cannot import {msgtype}; not recorded")
                return

            def callback(data: bytes, info: dict[str, int]) -> None:
                rec = self.rec
                if rec is not None and rec.alive:
                    if (
                        topic not in rec.registered
                    ):  # first message: its publishers' QoS are known now
                        self._register(rec, topic)
                    rec.queue.append(
                        (topic, data, info["received_timestamp"], info["source_timestamp"])
                    )

            def incompatible(event: Any) -> None:
                self.get_logger().warning(
                    f"{topic}: a publisher's QoS is incompatible with this reliable "
                    f"subscription (best effort?); its messages are not recorded"
                )

            events = SubscriptionEventCallbacks(incompatible_qos=incompatible)
            sub = self.create_subscription(
                cls, topic, callback, self.qos, raw=True, event_callbacks=events
            )
            self.subs[topic] = (sub, msgtype)

        def _register(self, rec: Recording, topic: str) -> None:
            """Add a topic to the bag with its publishers' offered QoS, as rosbag2 records them."""
            infos = self.get_publishers_info_by_topic(topic)
            rec.registered.add(topic)
            rec.add_topic(
                topic,
                self.subs[topic][1],
                [_qos_dict(i.qos_profile) for i in infos] or bags.default_qos(),
            )

        def discover(self) -> None:
            for topic in self.p["optional_topics"]:
                if topic not in self.subs and (msgtype := self._graph_type(topic)):
                    self._subscribe(topic, msgtype)

        def on_start(self, req: Any, res: Any) -> Any:
            res.success = False
            if self.rec is not None and self.rec.error:  # ended by a write error: finish it first
                self.rec.stop()
                self.rec = None
            if self.rec is not None:
                res.message = f"already recording to {self.rec.writer.path}; call stop first"
                return res
            try:
                tags = bags.BagTags.checked(req.condition, req.payload_mass)
            except OrthoglideError as exc:
                res.message = str(exc)
                return res
            p = {
                n: self.get_parameter(n).value for n in DEFAULTS
            }  # changes apply at the next start
            name = req.name or f"{tags.condition}_{datetime.now():%Y%m%d_%H%M%S}"
            if not _NAME.match(name) or name in (".", ".."):
                res.message = f"bad bag name {name!r}: use letters, digits, '_', '-', '.', '+'"
                return res
            out = Path(p["output_dir"]).expanduser()
            try:
                out.mkdir(parents=True, exist_ok=True)
            except OSError as exc:
                res.message = (
                    f"output folder {out} is not writable: cannot create it ({exc.strerror or exc})"
                )
                return res
            if not os.access(out, os.W_OK | os.X_OK):
                res.message = f"output folder {out} is not writable"
                return res
            comp = "" if p["compression"] in ("none", "") else p["compression"]
            writer = bags.BagWriter(
                out / name,
                tags,
                compression=comp,
                chunk_duration_s=float(p["chunk_duration"]),
                split_duration_s=float(p["split_duration"]) or None,
                split_size_bytes=int(p["split_size"]) or None,
            )
            try:
                writer.open()
            except (OrthoglideError, OSError) as exc:
                res.message = str(exc)
                return res
            stamped = {
                t
                for t, (_, m) in self.subs.items()
                if m in (bags.JOINT_STATE_TYPE, bags.CURRENT_REFERENCE_TYPE)
            }
            rec = Recording(writer, stamped, float(p["expected_rate"]), self.get_logger())
            for topic in self.subs:  # topics already published; the others at their first message
                if self.count_publishers(topic):
                    self._register(rec, topic)
            self.rec = rec
            res.success, res.bag_path = True, str(writer.path)
            res.message = f"recording {tags.condition} ({tags.payload_mass:g} kg) to {writer.path}"
            self.get_logger().info(res.message)
            return res

        def on_stop(self, req: Any, res: Any) -> Any:
            rec, self.rec = self.rec, None
            if rec is None:
                res.success, res.message = False, "not recording"
                return res
            res.message = rec.stop()
            res.success = not rec.error
            (self.get_logger().error if rec.error else self.get_logger().info)(res.message)
            return res

        def close(self) -> None:
            """Close the bag properly (called on SIGINT/SIGTERM and at exit)."""
            rec, self.rec = self.rec, None
            if rec is not None:
                msg = rec.stop()
                print(f"[recorder] {msg}", file=sys.stderr)

    return RecorderNode()


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if "-h" in argv or "--help" in argv:
        print(HELP)
        return 0

    return spin(make_node, ["recorder", *argv], "recorder")


if __name__ == "__main__":
    sys.exit(main())
