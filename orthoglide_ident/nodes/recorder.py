"""Recorder node: tagged rosbag2/MCAP bags of the Orthoglide topics, started/stopped by services.

Subscriptions take serialized messages; a writer thread parses only the header stamp (for the live
count of missing ticks) and hands the bytes to :class:`orthoglide_ident.bags.BagWriter`, which
compresses and writes chunks of ``chunk_duration`` seconds. The executor thread only queues.

Nothing that arrived is lost at the end: stop (and SIGINT/SIGTERM) first has the batch intake
hand over every message its subscriptions hold (bounded by STOP_DRAIN_S), then the writer writes
its whole queue and closes the bag. A recording ended by a write error (disk full, file-size limit)
is finished at the next status tick with the reason; bags a killed recorder left open in
``output_dir`` are reindexed when the recorder starts.
"""

from __future__ import annotations

import importlib
import sys
import time
from pathlib import Path
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from std_srvs.srv import Trigger

from orthoglide_ident import bags
from orthoglide_ident.bags.recording import Recording, open_bag
from orthoglide_ident.bags.reindex import left_open
from orthoglide_ident.bags.sources import INPUT_SOURCES
from orthoglide_ident.errors import BagError, ConfigError, OrthoglideError
from orthoglide_ident.ros.batch import BatchTaker, BatchTopic
from orthoglide_ident.ros.params import Param, declare, on_set, usage
from orthoglide_ident.ros.spin import spin
from orthoglide_msgs.msg import RecorderStatus
from orthoglide_msgs.srv import StartRecording, StopRecording

DOC = """\
Records tagged rosbag2 bags (metadata.yaml v9 + MCAP) of the Orthoglide's topics, or of a
ros2_control
robot's (topics: [joint_states, dynamic_joint_states], as joint_state_broadcaster publishes them;
each channel's offered QoS is recorded, its subscription follows it).

Services (relative names: /orthoglide/... in the root namespace, -r __ns:=/robot2 moves them):
  orthoglide/recorder/start  orthoglide_msgs/srv/StartRecording  condition (loaded|unloaded),
                             payload_mass [kg, 0 when unloaded], name (bag folder, default
                             <condition>_<date>_<time>) -> success, message, bag_path
  orthoglide/recorder/stop   std_srvs/srv/Trigger -> success (false when nothing was written),
                             message (messages written, missing ticks)
  orthoglide/recorder/stop_incomplete  orthoglide_msgs/srv/StopRecording  incomplete_reason ->
                             as stop, and the bag (kept) is tagged orthoglide.incomplete: the
                             reason (a cancelled or aborted excitation run: excite run)
Topic:
  orthoglide/recorder/status orthoglide_msgs/msg/RecorderStatus (transient local): recording?,
                             condition, payload mass, bag, ticks written and samples missing
                             (judged against the source's own step distribution, as `info`
                             does; ticks of expected_rate where the source keeps that rate),
                             the step in its message; on start, on stop and every second
                             while recording
  /diagnostics               diagnostic_msgs/DiagnosticArray, the same counts (WARN when
                             samples are missing), with the status
A topic of `topics` that never has a publisher (dynamic_joint_states of a driver that publishes
only joint_states) is said once, at the first start, and is not a fault."""

PAYLOAD_KEYS = ("payload_frame", "payload_com", "payload_inertia")
PARAMETERS = (
    Param(
        "payload_frame",
        "",
        "the link a loaded recording's payload is fixed to (\"\": the robot's "
        "payload frame); with payload_com and payload_inertia in the bag's tag "
        "(orthoglide.payload_*). "
        "The payload_* parameters are used by the next start only, then back to their launch "
        "values",
        dynamic=True,
    ),
    Param(
        "payload_com",
        [0.0, 0.0, 0.0],
        "m, the payload's centre of mass in payload_frame (zeros: at its "
        "origin); used by the next loaded start",
        dynamic=True,
    ),
    Param(
        "payload_inertia",
        [0.0] * 6,
        "kg·m², Ixx Ixy Ixz Iyy Iyz Izz about the payload's centre of mass "
        "(zeros: a point mass); used by the next loaded start",
        dynamic=True,
    ),
    Param(
        "robot",
        "",
        "the robot (a URDF, robot YAML or bundled name, as the identification node's): a "
        'loaded start\'s payload_frame must be one of its frames ("": not checked)',
    ),
    Param(
        "payload_known",
        "",
        "what is known of a loaded recording's payload, tagged "
        "orthoglide.payload_known (paper Sect. 4.3): mass (weighed only: its CoM and inertia are "
        'identified), com, all, point (a point mass at payload_frame / payload_com); "": what '
        "payload_com and payload_inertia give (none: mass only)",
        dynamic=True,
    ),
    Param(
        "output_dir",
        "bags",
        "folder for the bag directories (this and the next ones: from the next start "
        "on when changed)",
        dynamic=True,
    ),
    Param(
        "topics",
        ["orthoglide/joint_states", "orthoglide/current_reference"],
        "always recorded (subscribed at start-up; relative names resolve in the node's namespace): "
        "the "
        "Orthoglide's, or a ros2_control robot's [joint_states, dynamic_joint_states]; the first "
        "JointState topic is the one the status counts ticks on",
    ),
    Param(
        "optional_topics",
        ["orthoglide/setpoints", "orthoglide/current_command"],
        "recorded when a publisher exists (checked every second)",
    ),
    Param(
        "expected_rate",
        1000.0,
        "Hz of the controller ticks: a source whose local step is this "
        "period is counted in these ticks; any other source against its own step distribution",
        dynamic=True,
    ),
    Param("chunk_duration", 0.5, "s per MCAP chunk: what a SIGKILL can lose at most", dynamic=True),
    Param("split_duration", 0.0, "s per .mcap file (0: no split)", dynamic=True),
    Param("split_size", 0, "bytes per .mcap file (0: no split)", dynamic=True),
    Param("compression", "zstd", "zstd | lz4 | none", dynamic=True),
    Param(
        "queue_depth",
        5000,
        "subscription history depth (reliable, keep last): what DDS holds for the "
        "recorder while it is stalled; 5 s at 1 kHz",
    ),
)
STATUS_PERIOD_S = 1.0
STOP_DRAIN_S = 2.0  # at stop, the intake has this long to hand over what it holds
SILENT_S = 0.5  # a required topic silent this long while recording: the status says so
# topics a controller publishes every tick, subscribed before they have a publisher: the
# Orthoglide's, and ros2_control's joint_state_broadcaster's (relative: the node's namespace)
TICK_TOPICS = (("orthoglide/joint_states", bags.topics.JOINT_STATE_TYPE),
               ("orthoglide/current_reference", bags.topics.CURRENT_REFERENCE_TYPE),
               ("joint_states", bags.topics.JOINT_STATE_TYPE),
               ("dynamic_joint_states", bags.topics.DYNAMIC_JOINT_STATE_TYPE))
STAMPED_TYPES = tuple(dict.fromkeys(s.msgtype for s in INPUT_SOURCES))  # bags.sources' table


def _qos_dict(qos: Any) -> dict[str, Any]:
    def dur(d: Any) -> dict[str, int]:
        ns = int(getattr(d, "nanoseconds", 0))
        return {"sec": ns // 1_000_000_000, "nsec": ns % 1_000_000_000}

    return bags.topics.qos_profile(
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


def check_frame(robot: str, frame: str) -> None:
    """ConfigError unless ``robot`` (a robot file; "" or the Orthoglide's: not checked beyond its
    own rule) has the frame ``frame`` (the model is loaded once, at the first loaded start)."""
    if not robot:
        return
    from orthoglide_ident.model.registry import load_robot
    from orthoglide_ident.model.robot import Payload

    load_robot(robot).with_payload(Payload(1.0, frame))


def robot_sides(robot: str) -> dict[str, str]:
    """The tag's orthoglide.position_side / effort_side: the ``robot`` file's transmission's
    (what its hardware publishes); none without a transmission (docs/design/bags.md)."""
    from orthoglide_ident.model.registry import load_robot

    t = load_robot(robot).transmission if robot else None
    return {} if t is None else {"position_side": t.position_side, "effort_side": t.effort_side}


class RecorderNode(Node):
    """Start/stop services around a :class:`Recording`; the recorder's state on a latched topic."""

    def __init__(self) -> None:
        super().__init__("orthoglide_recorder")
        p = declare(self, PARAMETERS)
        _check(p)
        self.p = p
        self.payload_defaults = {k: p[k] for k in PAYLOAD_KEYS}  # what each start falls back to
        on_set(self, PARAMETERS, self._changed)
        self.rec: Recording | None = None
        self.last = {"condition": "", "payload_mass": 0.0, "bag_path": "", "message": "idle"}
        self.last_ticks: tuple = (0, 0, None, None)  # written, missing, first and last stamp
        self.last_against = ""  # how the last recording's missing samples were judged
        # why the last recording ended by itself (write error), until the next start
        self.ended = ""
        self.heard: dict[str, float] = {}  # topic -> monotonic time of its last message
        self.silent: set[str] = set()  # required topics the status says are silent
        self.said_absent: set[str] = set()  # required topics said once to have no publisher
        self.started_at = 0.0
        self.subs: dict[str, tuple[Any, str]] = {}  # topic -> (QoS subscribed with, type)
        self.checked_dirs: set[Path] = set()
        self.recover_left_open(p["output_dir"])
        self.taker = BatchTaker(self, [], period_s=0.005)
        self.known = {self.resolve_topic_name(t): m for t, m in TICK_TOPICS}
        self.required = [self.resolve_topic_name(t) for t in p["topics"]]
        self.optional = [self.resolve_topic_name(t) for t in p["optional_topics"]]
        self.discover()
        latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                             reliability=ReliabilityPolicy.RELIABLE)
        self.status_pub = self.create_publisher(
            RecorderStatus, "orthoglide/recorder/status", latched
        )
        self.diag_pub = self.create_publisher(DiagnosticArray, "/diagnostics", 10)
        self.create_service(StartRecording, "orthoglide/recorder/start", self.on_start)
        self.create_service(Trigger, "orthoglide/recorder/stop", self.on_stop)
        self.create_service(
            StopRecording, "orthoglide/recorder/stop_incomplete", self.on_stop_incomplete
        )
        self.create_timer(1.0, self.discover)
        self.create_timer(STATUS_PERIOD_S, self.status_tick)
        self.publish_status()
        self.get_logger().info(f"recorder ready; bags go to {Path(p['output_dir']).resolve()}")

    def _changed(self, changes: dict[str, Any]) -> None:
        """Run-time parameter changes: checked now, used from the next start on."""
        p = {**self.p, **changes}
        _check(p)
        self.p = p

    def _graph_type(self, topic: str) -> str | None:
        types = dict(self.get_topic_names_and_types()).get(topic)
        return types[0] if types else None

    def _subscribe(self, topic: str, msgtype: str) -> None:
        """Record ``topic`` from now on, with the reliability and durability its publishers offer
        (as rosbag2 does: a reliable subscription never matches a best-effort publisher)."""
        try:
            cls = _import_type(msgtype)
        except (ImportError, AttributeError, ValueError):
            self.get_logger().warning(f"{topic}: cannot import {msgtype}; not recorded")
            return
        qos = self._adapted_qos(topic)

        def on_batch(batch: list) -> None:
            self.heard[topic] = time.monotonic()
            rec = self.rec
            if rec is not None and rec.alive:
                if topic not in rec.registered:  # first message: its publishers' QoS are known now
                    self._register(rec, topic)
                rec.queue.extend(
                    (topic, data, received, published) for data, received, published in batch
                )

        self.taker.add(BatchTopic(cls, topic, qos, on_batch))
        self.subs[topic] = (qos, msgtype)

    def _adapted_qos(self, topic: str, quiet: bool = False) -> QoSProfile:
        offered = [i.qos_profile for i in self.get_publishers_info_by_topic(topic)]
        qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=self.p["queue_depth"],
                         reliability=ReliabilityPolicy.RELIABLE)
        if offered and any(o.reliability == ReliabilityPolicy.BEST_EFFORT for o in offered):
            qos.reliability = ReliabilityPolicy.BEST_EFFORT
            if not quiet:
                self.get_logger().warning(
                    f"{topic}: a publisher offers best effort: recorded best effort (ticks "
                    "may be lost on the way, the missing count will say)"
                )
        if offered and all(o.durability == DurabilityPolicy.TRANSIENT_LOCAL for o in offered):
            qos.durability = DurabilityPolicy.TRANSIENT_LOCAL
        return qos

    def _register(self, rec: Recording, topic: str) -> None:
        """Add a topic to the bag with its publishers' offered QoS, as rosbag2 records them."""
        infos = self.get_publishers_info_by_topic(topic)
        rec.registered.add(topic)
        rec.add_topic(
            topic,
            self.subs[topic][1],
            [_qos_dict(i.qos_profile) for i in infos] or bags.topics.default_qos(),
        )

    def discover(self) -> None:
        """Subscribe to the wanted topics: the required ones from the start (reliable), the optional
        ones once published; and follow the QoS their publishers offer (best effort, latched)."""
        for topic in self.required + self.optional:
            published = self.count_publishers(topic) > 0
            if topic not in self.subs:
                msgtype = self.known.get(topic) or (self._graph_type(topic) if published else None)
                if msgtype and (published or topic in self.required):
                    self._subscribe(topic, msgtype)
            elif published and self._adapted_qos(topic, quiet=True) != self.subs[topic][0]:
                self._subscribe(topic, self.subs[topic][1])  # a publisher with another QoS appeared

    def publish_status(self) -> None:
        """orthoglide/recorder/status: what is being (or was last) recorded, and how it goes."""
        msg = RecorderStatus(
            recording=self.rec is not None, **{**self.last, "message": self._status_text()}
        )
        msg.header.stamp = self.get_clock().now().to_msg()
        if self.rec is not None:
            self.last_ticks = self._ticks(self.rec)
        msg.ticks_written, msg.ticks_missing, first, last = self.last_ticks
        for field, ns in (("first_tick", first), ("last_tick", last)):
            getattr(msg, field).sec, getattr(msg, field).nanosec = divmod(ns or 0, 1_000_000_000)
        self.status_pub.publish(msg)
        self.publish_diagnostics(msg)

    def publish_diagnostics(self, status: Any) -> None:
        """The status's counts on /diagnostics: WARN when samples are missing."""
        counter = self.rec.counters.get(self._ticks_topic()) if self.rec is not None else None
        against = counter.describe() if counter is not None else self.last_against
        level = DiagnosticStatus.WARN if status.ticks_missing else DiagnosticStatus.OK
        values = {"recording": status.recording, "condition": status.condition,
                  "bag": status.bag_path, "topic": self._ticks_topic(),
                  "samples written": status.ticks_written,
                  "samples missing": status.ticks_missing, "judged": against}
        self.diag_pub.publish(DiagnosticArray(header=status.header, status=[DiagnosticStatus(
            level=level, name=f"{self.get_fully_qualified_name()}: recording",
            hardware_id="orthoglide_ident", message=status.message,
            values=[KeyValue(key=k, value=str(v)) for k, v in values.items()])]))

    def status_tick(self) -> None:
        """Every STATUS_PERIOD_S while recording: finish a recording a write error ended, say
        when a required topic falls silent or comes back, publish the status."""
        rec = self.rec
        if rec is None:
            return
        if rec.error:
            self._end()
            return
        for topic in (t for t in self.required if t in self.heard):  # never heard: not silence
            age = self._silent_for(topic)
            if age >= SILENT_S and topic not in self.silent:
                self.silent.add(topic)
                self.get_logger().warning(
                    f"no message on {topic} for {age:.1f} s: source stopped or gone? "
                    "What arrived is kept; the recording goes on"
                )
            elif age < SILENT_S and topic in self.silent:
                self.silent.discard(topic)
                self.get_logger().info(f"{topic} is back")
        self.publish_status()

    def _silent_for(self, topic: str) -> float:
        """Seconds the intake has been taking without a message of ``topic`` (since the recording
        started); counted on the intake's clock, so that a recorder that was itself stalled
        (SIGSTOP, starved of CPU) does not take the backlog it has not taken yet for silence."""
        return self.taker.last_take - max(self.heard.get(topic, 0.0), self.started_at)

    def _status_text(self) -> str:
        text = self.last["message"]
        counter = self.rec.counters.get(self._ticks_topic()) if self.rec is not None else None
        if counter is not None and counter.n_steps:
            text += f"; {counter.missing} samples missing ({counter.describe()})"
        if self.rec is not None and self.silent:
            ages = ", ".join(f"{t} for {self._silent_for(t):.1f} s" for t in sorted(self.silent))
            text += f"; no message on {ages} (source stopped or gone?); what arrived is kept"
        return text

    def recover_left_open(self, output_dir: str) -> None:
        """Reindex the bags a killed recorder left open in ``output_dir`` (once per folder), so
        that every tool reads them whole; one log line each."""
        folder = Path(output_dir).expanduser().resolve()
        if folder in self.checked_dirs:
            return
        self.checked_dirs.add(folder)
        for bag in left_open(folder):
            try:
                result = bags.reindex(bag)
            except BagError as exc:
                self.get_logger().warning(
                    f"{bag} was left open (recorder killed?) and could not be reindexed: {exc}"
                )
                continue
            kept = sum(f.messages for f in result.files)
            lost = "; ".join(f"{f.path.name} lost: {f.lost}" for f in result.files if not f.closed)
            self.get_logger().warning(
                f"{bag} was left open (recorder killed?): reindexed: {kept} messages "
                f"kept; {lost}; originals kept as *.mcap.orig"
            )

    def _ticks(self, rec: Recording) -> tuple[int, int, int | None, int | None]:
        """(written, missing, first stamp, last stamp) of the joint states of a recording."""
        js = self._ticks_topic()
        counter = rec.counters.get(js)
        return (
            rec.writer.counts.get(js, 0),
            _missing(rec),
            counter and counter.first,
            counter and counter.last,
        )

    def _ticks_topic(self) -> str:
        """The joint states the status counts ticks on: the first JointState topic of ``topics``."""
        return next(
            (
                t
                for t in self.required
                if t in self.subs and self.subs[t][1] == bags.topics.JOINT_STATE_TYPE
            ),
            self.resolve_topic_name("orthoglide/joint_states"),
        )

    def on_start(self, req: Any, res: Any) -> Any:
        res.success = False
        if self.rec is not None and self.rec.error:  # ended by a write error: finish it first
            self._end()
        if self.rec is not None:
            res.message = f"already recording to {self.rec.writer.path}; call stop first"
            return res
        p = self.p
        self.recover_left_open(p["output_dir"])
        try:
            tags = bags.BagTags.checked(req.condition, req.payload_mass,
                                        **self._payload_shape(req.condition),
                                        **robot_sides(p["robot"]))
            writer = open_bag(
                p["output_dir"],
                req.name,
                tags,
                p["compression"],
                p["chunk_duration"],
                p["split_duration"],
                p["split_size"],
            )
        except OrthoglideError as exc:
            res.message = str(exc)
            return res
        finally:  # this start's payload, accepted or not, is not the next one's
            self._reset_payload()
        self.discover()
        for topic in self.required:  # absent (an optional source): said once, not a fault
            if topic not in self.heard and not self.count_publishers(topic) \
                    and topic not in self.said_absent:
                self.said_absent.add(topic)
                self.get_logger().info(f"{topic} has no publisher: recorded from its first message "
                                       "if one appears (said once)")
        # the topics of every tick (the Orthoglide's two, or the broadcaster's), aligned on their
        # stamps: those published now (a robot without /dynamic_joint_states, say, must not hold
        # its /joint_states back waiting for ticks that never come)
        stamped = {t for t in self.required if t in self.subs and self.subs[t][1] in STAMPED_TYPES}
        stamped = {t for t in stamped if self.count_publishers(t)} or stamped  # none yet: all
        rec = Recording(writer, stamped, float(self.p["expected_rate"]), self.get_logger())
        for topic in self.subs:  # topics already published; the others at their first message
            if self.count_publishers(topic):
                self._register(rec, topic)
        self.rec, self.ended, self.silent, self.started_at = rec, "", set(), time.monotonic()
        res.success, res.bag_path = True, str(writer.path)
        res.message = f"recording {tags.condition} ({tags.payload_mass:g} kg) to {writer.path}"
        self.last = {"condition": tags.condition, "payload_mass": float(tags.payload_mass),
                     "payload_frame": tags.payload_frame or "",
                     "payload_com": list(tags.payload_com or ()),
                     "payload_inertia": list(tags.payload_inertia or ()),
                     "payload_known": tags.knowledge if tags.condition == "loaded" else "",
                     "bag_path": str(writer.path), "message": res.message}
        self.get_logger().info(res.message)
        self.publish_status()
        return res

    def _reset_payload(self) -> None:
        """payload_* back to their launch values: what a start said is not carried over."""
        from rclpy.parameter import Parameter

        changed = [
            Parameter(k, value=v) for k, v in self.payload_defaults.items() if self.p[k] != v
        ]
        if changed:
            self.set_parameters(changed)

    def _payload_shape(self, condition: str) -> dict[str, Any]:
        """The tag's payload frame, centre of mass, inertia and what is known of them
        (parameters) of a loaded start; none (its mass only) or unloaded. ConfigError for a
        frame the ``robot`` lacks."""
        p = self.p
        if condition != "loaded":
            return {}
        out: dict[str, Any] = {}
        if p["payload_frame"]:
            check_frame(p["robot"], p["payload_frame"])
            out["payload_frame"] = p["payload_frame"]
        if len(p["payload_com"]) != 3 or len(p["payload_inertia"]) != 6:
            raise ConfigError(
                "parameters payload_com (3 numbers, m) and payload_inertia (6, kg·m²) "
                f"have {len(p['payload_com'])} and {len(p['payload_inertia'])}"
            )
        known = p["payload_known"] or None
        com, inertia = any(p["payload_com"]), any(p["payload_inertia"])
        if known in ("com", "point"):  # a CoM (when given), no inertia
            if com:
                out["payload_com"] = p["payload_com"]
            if inertia:
                raise ConfigError(f"payload_known {known} takes no payload_inertia; set it to "
                                  "zeros, or payload_known all")
        elif com or inertia:
            out["payload_com"], out["payload_inertia"] = p["payload_com"], p["payload_inertia"]
        if known is not None:
            out["payload_known"] = known
        return out

    def on_stop(self, req: Any, res: Any) -> Any:
        if self.rec is None:
            res.success = False
            res.message = "not recording" + (
                f" (the last recording ended: {self.ended})" if self.ended else ""
            )
            return res
        res.success, res.message = self._end()
        return res

    def on_stop_incomplete(self, req: Any, res: Any) -> Any:
        """Stop, the bag tagged incomplete with the request's reason (kept as it is)."""
        res.bag_path = str(self.rec.writer.path) if self.rec is not None else ""
        if self.rec is None:
            return self.on_stop(req, res)
        res.success, res.message = self._end(req.incomplete_reason.strip())
        return res

    def _end(self, incomplete: str = "") -> tuple[bool, str]:
        """Finish the recording: everything the intake holds is handed over (at most STOP_DRAIN_S),
        the writer writes its queue and closes the bag (tagged incomplete with that reason when
        given). (success, the summary or the reason)."""
        drained = self.taker.drain(STOP_DRAIN_S)
        rec, self.rec = self.rec, None
        assert rec is not None
        message = rec.stop(incomplete)
        js = self._ticks_topic()
        written = rec.writer.counts.get(js, 0)
        success = not rec.error and written > 0
        if not rec.error and not written:
            message = (f"nothing recorded on {js} (no publisher, or one whose QoS does not match); "
                       f"{rec.writer.path} holds no data")
        if not drained:
            message += (
                f"; the intake did not hand over what it held within {STOP_DRAIN_S:g} s: the last "
                "messages received may be missing"
            )
        self.ended = message if rec.error else ""
        self.last_ticks = self._ticks(rec)
        counter = rec.counters.get(js)
        self.last_against = counter.describe() if counter is not None else ""
        self.last["message"] = message
        if success:
            self.get_logger().info(message)
        else:  # one severity per call site: rclpy refuses a call site that changes it (issue 26)
            self.get_logger().error(message)
        self.publish_status()
        return success, message

    def close(self) -> None:
        """Close the bag properly, with what arrived (called on SIGINT/SIGTERM and at exit)."""
        if self.rec is not None:
            self.taker.drain(STOP_DRAIN_S)
        self.taker.close()
        rec, self.rec = self.rec, None
        if rec is not None:
            msg = rec.stop()
            print(f"[recorder] {msg}", file=sys.stderr)


def _missing(rec: Recording) -> int:
    """Ticks missing from the recorded stamps (the worst of the stamped topics)."""
    return max((c.missing for c in rec.counters.values()), default=0)


def _check(p: dict[str, Any]) -> None:
    """One-line reasons for parameter values that cannot work."""
    if p["queue_depth"] < 1:
        raise ConfigError(f"parameter queue_depth: must be >= 1, got {p['queue_depth']}")
    if p["expected_rate"] <= 0 or p["chunk_duration"] <= 0:
        raise ConfigError("parameters expected_rate and chunk_duration must be positive")
    if p["split_duration"] < 0 or p["split_size"] < 0:
        raise ConfigError("parameters split_duration and split_size must be >= 0 (0: no split)")
    if p["compression"] not in ("zstd", "lz4", "none", ""):
        raise ConfigError(f"parameter compression: zstd, lz4 or none, got {p['compression']!r}")


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv if argv is None else argv
    if "-h" in argv or "--help" in argv:
        print(
            usage(
                "usage: ros2 run orthoglide_ident recorder [--ros-args -p NAME:=VALUE ... | "
                "--params-file "
                "config/recorder.yaml]",
                DOC,
                PARAMETERS,
            )
        )
        return 0
    return spin(RecorderNode, argv, "recorder")


if __name__ == "__main__":
    sys.exit(main())
