"""The identification node's live side: the recorded topics into LiveIdentification, ~1 Hz estimate.

The recorder says what it records on orthoglide/recorder/status (condition, payload mass, bag,
first and last tick written). The joint states and currents come in raw (serialized), taken in
batches (ros.batch), and wait in a short buffer; every FEED_PERIOD_S they are decoded in bulk
and handed to ``LiveIdentification`` from the recording's first tick to its last, so that the
live data are the ticks the bag holds, and the live result equals ``orthoglide-ident identify``
on that bag. The topics are the Orthoglide's (orthoglide/joint_states + current_reference) or a
ros2_control robot's (joint_states + dynamic_joint_states, or the JointState effort alone):
``live_sources`` says which, per recording. About once a second the estimate goes out on
orthoglide/identification/live with the warnings of the last second; the same warnings go to the
log as they happen.

Real time: the identification itself (a live update can take seconds: a big model, a slow
machine) runs on a worker thread of its own (``<node>-live``), never on the node's executor.
The executor's callbacks only hand over: the recorder's status goes to the worker's queue and is
applied there in order, so the node's services (orthoglide/identify, the parameter services)
and timers answer at once whatever the worker is doing; the 1 kHz topics are taken by the batch
intake's own thread (ros.batch) into buffers that keep every message of a recording however long
an update takes (up to BACKLOG_S of data), so that a slow update delays the estimate, never loses
a tick.
"""
from __future__ import annotations

import collections
import queue
import struct
import threading
import time
from typing import Any

from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState

from orthoglide_ident.bags.reader import decode_messages
from orthoglide_ident.bags.sources import CURRENT_SOURCES
from orthoglide_ident.bags.topics import (
    CURRENT_REFERENCE_TYPE,
    DYNAMIC_JOINT_STATE_TYPE,
    JOINT_STATE_TYPE,
)
from orthoglide_ident.errors import OrthoglideError
from orthoglide_ident.identify.live.session import LiveIdentification
from orthoglide_ident.identify.records.record import effort_channels, torque_as_current
from orthoglide_ident.model.robot import Payload, RobotModel
from orthoglide_ident.nodes.live_sources import (
    DYNAMIC,
    EFFORT,
    REFERENCE,
    LiveTopics,
    choose_current,
)
from orthoglide_ident.ros.batch import BatchTaker, BatchTopic
from orthoglide_ident.ros.guard import FailureLog
from orthoglide_msgs.msg import CurrentReference, RecorderStatus
from orthoglide_msgs.msg import LiveIdentification as LiveMsg

FEED_PERIOD_S = 0.1
ESTIMATE_PERIOD_S = 1.0
IDLE_BUFFER = 5000  # messages kept per topic while nothing records: the recorder may start first
BACKLOG_S = 300.0  # s of a recording's messages kept per topic while the worker is busy (at 1 kHz)
# after the recorder stopped, wait this long at most for its last ticks here (a bound for a last
# tick the source dropped on one topic; the ticks an intake still behind has not taken arrive
# well within it: 1 s ended a recording beside a CPU hog without them, silently)
STOP_WAIT_S = 10.0
# messages DDS holds for this node while it is stalled (5 s at 1 kHz), as the recorder
STREAM_DEPTH = 5000
QOS_CHECK_PERIOD_S = 1.0  # how often the publishers' offered reliability is looked at
HOLDBACK_NS = 250_000_000  # the newest 0.25 s wait: the recorder's stop may end the recording there
STATUS_DEPTH = 10  # recorder statuses queued here (a stop and the next start may come together)
_STAMP = struct.Struct("<iI")
LABELS = {s.key: s.label for s in CURRENT_SOURCES}  # "the effort of" /joint_states, in the log


def _stamp_ns(raw: bytes) -> int:
    sec, nsec = _STAMP.unpack_from(raw, 4)
    return sec * 1_000_000_000 + nsec


def _tick(t: Any) -> int | None:
    ns = t.sec * 1_000_000_000 + t.nanosec
    return ns or None


def _topics(t: LiveTopics) -> dict[str, tuple[str, Any, str]]:
    """Buffer key -> (topic, message class, type name) of the topics read ("" = not read)."""
    out = {"q": (t.joint_states, JointState, JOINT_STATE_TYPE)}
    if t.current_reference:
        out[REFERENCE] = (t.current_reference, CurrentReference, CURRENT_REFERENCE_TYPE)
    if t.dynamic_joint_states:
        from control_msgs.msg import DynamicJointState  # built by make setup, or a ROS install's

        out[DYNAMIC] = (t.dynamic_joint_states, DynamicJointState, DYNAMIC_JOINT_STATE_TYPE)
    return out



def status_payload(msg: RecorderStatus) -> Payload | None:
    """The payload the recorder tags a loaded recording with (RecorderStatus): its mass, frame,
    centre of mass and inertia, and what is known of them (payload_known; paper Sect. 4.3)."""
    if msg.condition != "loaded":
        return None
    com, inertia = list(msg.payload_com), list(msg.payload_inertia)
    known = getattr(msg, "payload_known", "") or ("all" if com and inertia else
                                                  "com" if com else "mass")
    return Payload(float(msg.payload_mass), msg.payload_frame, tuple(com or (0.0,) * 3),
                   tuple(inertia or (0.0,) * 6), known)

class LiveFeed:
    """Subscriptions, buffers and timers of live identification, on ``node`` (under ``lock``);
    ``robot`` the model's joints and nominal gains (the node's ``robot`` parameter); ``effort_unit``
    "torque": a JointState effort or DynamicJointState interface in N·m or N, turned into a current
    with the nominal gains, as offline. ``worker`` False: no worker thread, the caller calls
    :meth:`turn` (tests: each step when they say)."""

    def __init__(self, node: Node, live: LiveIdentification, lock: threading.Lock,
                 topics: LiveTopics | None = None, *, robot: RobotModel,
                 effort_unit: str = "A", worker: bool = True) -> None:
        self.node, self.live, self.lock = node, live, lock
        self.topics, self.effort_unit = topics or LiveTopics(), effort_unit
        self.robot = robot
        self.TOPICS = _topics(self.topics)
        # what the intake thread has taken and the worker not yet fed (deque: thread-safe appends)
        self.buffers = {k: collections.deque(maxlen=int(BACKLOG_S * 1000)) for k in self.TOPICS}
        self.source: str | None = None  # where the recording's current comes from (live_sources)
        # recordings live identification gave up (the reason was said)
        self.left_out: set[str] = set()
        self.waiting_since: float | None = None  # first joint state of the recording seen here
        self.bag: str | None = None  # the recording being fed
        self.first: int | None = None
        self.last: int | None = None  # set when the recorder has stopped
        self.stopped_at = 0.0
        self.seen: dict[str, int] = {}  # newest stamp received per topic during the recording
        self.started: dict[int, bool] = {}  # per buffer: its first tick of the recording checked
        self.warnings: list[str] = []
        self.dirty = False  # something to say on orthoglide/identification/live
        stream = QoSProfile(depth=STREAM_DEPTH, reliability=ReliabilityPolicy.RELIABLE)
        self.reliability = dict.fromkeys(self.TOPICS, ReliabilityPolicy.RELIABLE)  # subscribed with
        self.receiving: set[str] = set()  # topics whose first message arrived (said once each)
        self.taker = BatchTaker(
            node, [self._intake(key, stream) for key in self.TOPICS], period_s=0.01
        )
        # deeper than the recorder's latched 1: a stop followed at once by the next start must not
        # be coalesced into the start (the stop carries the recording's last tick)
        statuses = QoSProfile(depth=STATUS_DEPTH, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                              reliability=ReliabilityPolicy.RELIABLE)
        node.create_subscription(
            RecorderStatus, "orthoglide/recorder/status", self.on_status, statuses
        )
        self.pub = node.create_publisher(LiveMsg, "orthoglide/identification/live", 10)
        node.create_timer(QOS_CHECK_PERIOD_S, self.follow_publishers)
        self._jobs: queue.SimpleQueue = queue.SimpleQueue()  # from the executor, run by the worker
        self._stop = threading.Event()
        self._failures = FailureLog(node.get_logger())
        self._next_estimate = time.monotonic() + ESTIMATE_PERIOD_S
        self._worker = threading.Thread(
            target=self._work, name=f"{node.get_name()}-live", daemon=True
        )
        if worker:
            self._worker.start()

    def _intake(self, key: str, qos: QoSProfile) -> BatchTopic:
        topic, cls, _ = self.TOPICS[key]
        buf = self.buffers[key]

        def on_batch(batch) -> None:
            buf.extend(m[0] for m in batch)
            # matched with its publishers: from now on, nothing missed
            if key not in self.receiving:
                self.receiving.add(key)
                self.node.get_logger().info("live identification: receiving "
                                            f"{self.node.resolve_topic_name(topic)}")
        return BatchTopic(cls, topic, qos, on_batch)

    def follow_publishers(self) -> None:
        """Subscribe best effort while a publisher offers best effort (a reliable subscription
        never matches it), reliable again when none does: the recorder's rule."""
        for key, (topic, _, _) in self.TOPICS.items():
            offered = [i.qos_profile.reliability for i in self.node.get_publishers_info_by_topic(
                self.node.resolve_topic_name(topic))]
            want = (ReliabilityPolicy.BEST_EFFORT if ReliabilityPolicy.BEST_EFFORT in offered
                    else ReliabilityPolicy.RELIABLE)
            if offered and want != self.reliability[key]:
                self.reliability[key] = want
                self.taker.add(self._intake(key, QoSProfile(depth=STREAM_DEPTH, reliability=want)))
                self.node.get_logger().info(
                    f"live identification: {topic} taken {want.name.lower()}, as its "
                    "publishers offer"
                )

    # ---- the worker ----------------------------------------------------------------------------
    def submit(self, job) -> None:
        """Run ``job()`` on the worker, under the lock, in the order submitted (from any thread)."""
        self._jobs.put(job)

    def _work(self) -> None:
        """A turn every FEED_PERIOD_S; a failure is logged and the worker goes on (the next turn
        retries)."""
        while not self._stop.wait(FEED_PERIOD_S):
            try:
                self.turn()
            except Exception as exc:  # noqa: BLE001 - the live side must not die silently
                self._failures.failed("live identification", exc, "the worker goes on")

    def turn(self) -> None:
        """The jobs submitted, in order; the buffered ticks fed; about once a second the
        estimate."""
        while True:
            try:
                job = self._jobs.get_nowait()
            except queue.Empty:
                break
            with self.lock:
                job()
        self.feed()
        if time.monotonic() >= self._next_estimate:
            self._next_estimate = time.monotonic() + ESTIMATE_PERIOD_S
            self.publish_estimate()

    # ---- the recorder's state ----------------------------------------------------------------
    def on_status(self, msg: RecorderStatus) -> None:
        """(executor) The recorder's status, applied by the worker in order: never waits."""
        self.submit(lambda: self._apply_status(msg))

    def _apply_status(self, msg: RecorderStatus) -> None:
        """(worker, under the lock) A new recording, its first tick, its end."""
        if msg.recording and msg.bag_path != self.bag and msg.bag_path not in self.left_out:
            self._end_previous()
            self.bag, self.first, self.last, self.seen, self.started = (
                msg.bag_path,
                None,
                None,
                {},
                {},
            )
            self.source, self.waiting_since = None, None
            try:
                self.live.start_recording(msg.bag_path, msg.condition, msg.payload_mass,
                                          status_payload(msg))
            except OrthoglideError as e:
                self._say([f"live identification ignores {msg.bag_path}: {e}"])
                self.bag = None
                return
            self.node.get_logger().info(
                f"live identification: {msg.condition} recording {msg.bag_path}"
            )
        if self.bag is not None and msg.bag_path == self.bag:
            self.first = self.first or _tick(msg.first_tick)
            if not msg.recording:
                self.last = _tick(msg.last_tick) or 0
                self.stopped_at = time.monotonic()
        elif self.bag is not None and not msg.recording and self.last is None:
            self._recorder_restarted()

    def _recorder_restarted(self) -> None:
        """An idle recorder that is not the one recording ``self.bag``: that one was killed (and
        restarted). Its recording ends here at the last tick every topic delivered."""
        # the topics this recording reads
        used = self._used() if self.source is not None else ("q",)
        newest = [
            _stamp_ns(self.buffers[k][-1]) if self.buffers[k] else self.seen.get(k, 0) for k in used
        ]
        self.last, self.stopped_at = min(newest), time.monotonic()
        self._say(
            [
                f"the recorder of {self.bag} restarted without stopping it (killed?): its live "
                "data "
                ""
                ""
                ""
                "end at "
                "the last tick received here"
            ]
        )

    def _end_previous(self) -> None:
        """A new recording starts: the one under way first gets its ticks already here (the
        recorder's stop and next start may come within one feed period), then ends."""
        if self.bag is not None and self.last is not None:
            self._feed()
        if self.bag is not None and self.last is not None and self.source is not None:
            late = [self.TOPICS[k][0] for k in self._used() if self.seen.get(k, 0) < self.last]
            if late:
                self._say(
                    [
                        f"{self.bag} ended with the next recording's start before its last ticks "
                        f"on {', '.join(late)} reached live identification: its live data end "
                        "earlier than its bag (identify the bag for the exact result)"
                    ]
                )
        self._finish()

    # ---- data --------------------------------------------------------------------------------
    def feed(self) -> None:
        """Hand the buffered ticks of the recording to LiveIdentification (bulk-decoded)."""
        with self.lock:
            self._feed()

    def _feed(self) -> None:
        """:meth:`feed` under the lock."""
        if self.bag is None:
            for buf in self.buffers.values():  # nothing records: the newest IDLE_BUFFER wait
                while len(buf) > IDLE_BUFFER:
                    buf.popleft()
        if self.bag is None or self.first is None:
            return
        for key, buf in self.buffers.items():
            while buf and _stamp_ns(buf[0]) < self.first:
                buf.popleft()  # before the recording
            if buf:
                self.seen[key] = max(self.seen.get(key, 0), _stamp_ns(buf[-1]))
        if self.source is None and not self._choose():
            if self.last is not None and time.monotonic() - self.stopped_at > STOP_WAIT_S:
                self._finish()
            return
        used = self._used()
        for key in used:
            raw = self._take(self.buffers[key])
            if raw:
                self._add(key, raw)
                self.dirty = True
        # done when every topic used has delivered the last recorded tick here (an empty
        # buffer only means its last messages may still be on their way)
        done = all(self.seen.get(key, 0) >= (self.last or 0) for key in used)
        if self.last is not None and (done or time.monotonic() - self.stopped_at > STOP_WAIT_S):
            if not done:
                self._short(used)
            self._finish()

    def _short(self, used: tuple[str, ...]) -> None:
        """Say which topics' last ticks had not come STOP_WAIT_S after the recorder stopped."""
        late = [f"{self.TOPICS[k][0]} (" + (f"{(self.last - self.seen[k]) * 1e-6:.0f} ms)"
                                             if k in self.seen else "all)")
                for k in used if self.seen.get(k, 0) < self.last]
        self._say([f"{self.bag}: its last ticks on {', '.join(late)} had not reached live "
                   f"identification {STOP_WAIT_S:g} s after the recorder stopped: the live data "
                   "end earlier than its bag (identify the bag for the exact result)"])

    def _used(self) -> tuple[str, ...]:
        return ("q",) if self.source == EFFORT else ("q", self.source)

    def _choose(self) -> bool:
        """Pick the recording's current source (live_sources); False while waiting for it. A
        recording without a usable current is left out with the reason."""
        if self.waiting_since is None and self.buffers["q"]:
            self.waiting_since = time.monotonic()
        waited = 0.0 if self.waiting_since is None else time.monotonic() - self.waiting_since
        first = {k: (b[0] if b else None) for k, b in self.buffers.items()}
        publishers = {k: self.node.count_publishers(t) for k, (t, _, _) in self.TOPICS.items()}
        resolved = {k: self.node.resolve_topic_name(t) for k, (t, _, _) in self.TOPICS.items()}
        try:
            self.source = choose_current(
                self._joints(), self.topics, first, publishers, waited, resolved
            )
        except OrthoglideError as e:
            self._say([f"live identification leaves {self.bag} out: {e}"])
            self.left_out.add(str(self.bag))
            self._finish()
            return False
        if self.source is not None:
            what = (f"interface {self.topics.iface!r} of" if self.source == DYNAMIC
                    else LABELS[self.source])
            key = "q" if self.source == EFFORT else self.source
            self.node.get_logger().info(f"live identification: {self.bag}: current from {what} "
                                        f"{resolved[key]}, q from {resolved['q']}")
        return self.source is not None

    def _joints(self) -> tuple[str, ...]:
        """The current's channels (a transmission's joints or motors: its effort_side)."""
        return effort_channels(self.robot)

    def _take(self, buf: collections.deque) -> list[bytes]:
        """Messages of the recording's ticks, oldest first; earlier ones dropped, later ones
        kept."""
        while buf and _stamp_ns(buf[0]) < self.first:
            buf.popleft()
        if buf and not self.started.get(id(buf)):
            self.started[id(buf)] = True
            late_ns = _stamp_ns(buf[0]) - self.first
            if late_ns > 0:  # subscribed after the recording began (DDS matching takes a moment)
                self._say(
                    [
                        f"the first {round(late_ns / 1e6)} ms of {self.bag} never reached live "
                        "identification (subscribed after the recording began): the live estimate "
                        "leaves them out; identify the bag for the exact result"
                    ]
                )
        limit = (
            self.last if self.last is not None else (_stamp_ns(buf[-1]) - HOLDBACK_NS if buf else 0)
        )
        out = []
        while buf and _stamp_ns(buf[0]) <= limit:
            out.append(buf.popleft())
        return out

    def _add(self, key: str, raw: list[bytes]) -> None:
        topic, _, msgtype = self.TOPICS[key]
        try:
            stamps, names, values = decode_messages(
                raw, msgtype, self.topics.iface if key == DYNAMIC else None
            )
            if key == "q":
                self._say(self.live.add_joint_states(stamps, list(names), values))
                if self.source != EFFORT:
                    return
                stamps, names, values = decode_messages(raw, msgtype, "effort")
        except OrthoglideError as e:
            self._say([f"{topic}: {e}; {len(raw)} messages not used"])
            return
        if self.effort_unit == "torque":  # N·m or N -> A with the nominal gains, as offline
            values = torque_as_current(self.robot, names, values)
        self._say(self.live.add_current_reference(stamps, list(names), values))

    def replace(self, live: LiveIdentification, robot: RobotModel) -> None:
        """Another robot model (a new robot_description): the recording under way, if any, is
        left out with a warning; the next ones are identified with ``live`` (under the lock)."""
        if self.bag is not None:
            self._say(
                [
                    f"the robot model changed to {robot.name} during {self.bag}: live "
                    "identification "
                    "leaves it out and starts again from the next recording (identify its bag)"
                ]
            )
            self.left_out.add(self.bag)
            self.bag = self.first = self.last = None
        self.live, self.robot = live, robot
        self.dirty = True

    def _finish(self) -> None:
        if self.bag is not None:
            self._say(self.live.stop_recording())
            self.node.get_logger().info(
                f"live identification: {self.bag} done; {self.live.estimate().line()}"
            )
            self.dirty = True
        self.bag, self.first, self.last, self.source = None, None, None, None

    def _say(self, warnings: list[str]) -> None:
        for w in warnings:
            self.node.get_logger().warning(f"live: {w}")
        self.warnings.extend(warnings)

    # ---- the estimate ------------------------------------------------------------------------
    def publish_estimate(self) -> None:
        with self.lock:
            if not (self.dirty or self.warnings or self.bag is not None):
                return  # nothing new since the last recording ended
            est = self.live.estimate()
            warnings, self.warnings, self.dirty = self.warnings, [], False
        msg = LiveMsg(**est.message_fields(warnings))
        msg.header.stamp = self.node.get_clock().now().to_msg()
        self.pub.publish(msg)

    def close(self) -> None:
        self._stop.set()
        if self._worker.is_alive():
            self._worker.join(timeout=10.0)
        self.taker.close()
