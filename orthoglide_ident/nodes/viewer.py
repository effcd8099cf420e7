"""Viewer node: the graph's topics served live to Foxglove (or Lichtblick) over its WebSocket.

    ros2 run orthoglide_ident viewer [--ros-args --params-file config/viewer.yaml]
"""
from __future__ import annotations

import collections
import sys
from typing import Any

from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import JointState

from orthoglide_ident.bags import CURRENT_REFERENCE_TYPE, JOINT_STATE_TYPE, decode_messages
from orthoglide_ident.errors import ConfigError, OrthoglideError
from orthoglide_ident.model.robots import load_robot
from orthoglide_ident.nodes._batch import BatchTaker, BatchTopic
from orthoglide_ident.nodes._params import Param, declare, usage
from orthoglide_ident.nodes._spin import spin
from orthoglide_ident.view import schemas
from orthoglide_ident.view.decimate import StampDecimator, cdr_stamps
from orthoglide_ident.view.residual import ForceResidual
from orthoglide_ident.view.server import ViewServer
from orthoglide_msgs.msg import CurrentReference, IdentifiedParameters, JointSetpoint, LiveIdentification, RecorderStatus

DOC = """\
Serves the graph's topics to Foxglove (or Lichtblick) over the Foxglove WebSocket protocol
(foxglove-sdk, subprotocol foxglove.sdk.v1): in the app, "Open connection" -> Foxglove WebSocket
-> ws://host:port (the node prints the address), then import the layout
share/orthoglide_ident/foxglove/orthoglide_layout.json for a ready view.

JSON channels, named after the topics (resolved: /orthoglide/..., or under the namespace):
  orthoglide/joint_states, orthoglide/current_reference, orthoglide/setpoints   at `rate` Hz (the
      first message of each period of their stamps)
  orthoglide/identification/live    the live estimate: each gain, its sigma and gain +- sigma as
                                    numbers, the status and the warnings as text
  orthoglide/recorder/status        the recorder's state, with a one-line summary
  orthoglide/identified_parameters  the latched IDIM-TLS result (gains +- sigma, base parameters)
  orthoglide/forces                 per joint the measured force g_tau v_tau, the identified
      model's W chi + W_kl m_7 (positions differentiated by the identification's filter, the
      payload the recorder says is on) and their difference, means over 1/rate s, ~0.2 s late
Joint names and counts come from the messages. Browsers that do not keep up lose frames, never the
node: the topics are taken in batches on a thread of their own, and the server drops a slow
client's oldest messages."""

PARAMETERS = (
    Param("host", "127.0.0.1", "address the Foxglove WebSocket server listens on (0.0.0.0: every interface)"),
    Param("port", 8765, "TCP port of the Foxglove WebSocket server (0: any free port, printed at start)"),
    Param("rate", 50.0, "Hz of the high-rate channels sent to clients (joint states, currents, setpoints, forces)"),
    Param("robot", "", "robot model of the model force, as the identification's robot parameter: empty = the "
          "Orthoglide, a bundled name, a URDF or a robot YAML"),
)
PROCESS_PERIOD_S = 0.1  # the batches taken are decoded, decimated and sent this often
QOS_CHECK_PERIOD_S = 2.0
BUFFER = 5000  # serialized messages kept per high-rate topic between two processings (5 s at 1 kHz)
STREAMS = {schemas.JOINT_STATES: JointState, schemas.CURRENT_REFERENCE: CurrentReference,
           schemas.SETPOINTS: JointSetpoint}


def fields(msg: Any) -> dict[str, Any]:
    return {k: getattr(msg, k) for k in msg.get_fields_and_field_types()}


def stamp_ns(msg: Any) -> int:
    return msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec


class ViewerNode(Node):
    """Topics in, Foxglove channels out; the numerics are orthoglide_ident.view's."""

    def __init__(self) -> None:
        super().__init__("orthoglide_viewer")
        p = declare(self, PARAMETERS)
        if not p["rate"] > 0:
            raise ConfigError(f"parameter rate: must be > 0 Hz, got {p['rate']}")
        self.residual = ForceResidual(load_robot(p["robot"]), block_s=1.0 / p["rate"])
        self.server = ViewServer(p["host"], p["port"])
        self.topic = {kind: self.resolve_topic_name(kind) for kind in (*STREAMS, schemas.LIVE,
                      schemas.RECORDER_STATUS, schemas.IDENTIFIED, schemas.FORCES)}
        for kind, topic in self.topic.items():
            self.server.add(topic, kind)
        self.latched: dict[str, tuple[dict, int]] = {}  # kind -> last (message, log time)
        self.buffers = {k: collections.deque(maxlen=BUFFER) for k in STREAMS}
        self.decimators = {k: StampDecimator(round(1e9 / p["rate"])) for k in STREAMS}
        self.qos = {k: self._offered_qos(k) for k in STREAMS}
        latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL, reliability=ReliabilityPolicy.RELIABLE)
        self.create_subscription(LiveIdentification, schemas.LIVE, self.on_live, 10)
        self.create_subscription(RecorderStatus, schemas.RECORDER_STATUS, self.on_status, latched)
        self.create_subscription(IdentifiedParameters, schemas.IDENTIFIED, self.on_identified, latched)
        self.create_timer(PROCESS_PERIOD_S, self.process)
        self.create_timer(QOS_CHECK_PERIOD_S, self.follow_qos)
        self.taker = BatchTaker(self, [self._stream(k) for k in STREAMS], period_s=0.01)
        self.get_logger().info(f"Foxglove view on {self.server.url}: in Foxglove or Lichtblick, Open connection -> "
                               f"Foxglove WebSocket -> {self.server.url}")

    # ---- high-rate topics: taken raw in batches, processed every PROCESS_PERIOD_S ------------------
    def _stream(self, kind: str) -> BatchTopic:
        buf = self.buffers[kind]
        return BatchTopic(STREAMS[kind], kind, self.qos[kind], lambda batch: buf.extend(m[0] for m in batch))

    def _offered_qos(self, kind: str) -> QoSProfile:
        """Reliable unless a publisher offers best effort (a reliable subscription would not match it)."""
        offered = self.get_publishers_info_by_topic(self.topic[kind])
        best_effort = any(i.qos_profile.reliability == ReliabilityPolicy.BEST_EFFORT for i in offered)
        return QoSProfile(depth=1000, reliability=ReliabilityPolicy.BEST_EFFORT if best_effort
                          else ReliabilityPolicy.RELIABLE)

    def follow_qos(self) -> None:
        for kind in STREAMS:
            qos = self._offered_qos(kind)
            if qos != self.qos[kind]:
                self.qos[kind] = qos
                self.taker.add(self._stream(kind))
                self.get_logger().info(f"{self.topic[kind]}: now taken {qos.reliability.name.lower()}")

    def process(self) -> None:
        """Decode what the batches brought, send one message per period, feed the force residual."""
        for kind, buf in self.buffers.items():
            raw = [buf.popleft() for _ in range(len(buf))]
            if raw:
                self._guarded(kind, self._stream_out, kind, raw)
        self._guarded(schemas.FORCES, self._forces_out)
        if self.server.listener.new.is_set():  # a client subscribed: give it the latched state
            self.server.listener.new.clear()
            for kind, (msg, ns) in self.latched.items():
                self.server.log(self.topic[kind], msg, ns)

    def _guarded(self, kind: str, fn: Any, *args: Any) -> None:
        """A failure costs that topic's frames of this round, with its reason in the log: the view
        of the other topics goes on (a dead timer would leave the node up and silent)."""
        try:
            fn(*args)
        except OrthoglideError as e:  # wrong joint names, undecodable messages
            self.get_logger().warning(f"{self.topic[kind]}: {e}", throttle_duration_sec=10.0)
        except Exception as e:  # noqa: BLE001 - a bug in the view, reported with its reason
            self.get_logger().error(f"{self.topic[kind]}: internal error, frames lost: {type(e).__name__}: {e}",
                                    throttle_duration_sec=10.0)

    def _stream_out(self, kind: str, raw: list[bytes]) -> None:
        if kind == schemas.SETPOINTS:  # no bulk decoder: deserialize only the messages sent
            for i in self.decimators[kind].pick(cdr_stamps(raw)):
                m = deserialize_message(raw[i], JointSetpoint)
                self.server.log(self.topic[kind], schemas.joint_values(
                    stamp_ns(m), m.name, position=m.position, velocity=m.velocity, acceleration=m.acceleration),
                    stamp_ns(m))
            return
        stamps, names, values = decode_messages(raw, JOINT_STATE_TYPE if kind == schemas.JOINT_STATES
                                                else CURRENT_REFERENCE_TYPE)
        field = "position" if kind == schemas.JOINT_STATES else "current"
        for i in self.decimators[kind].pick(stamps):
            self.server.log(self.topic[kind], schemas.joint_values(int(stamps[i]), names, **{field: values[i]}),
                            int(stamps[i]))
        self.residual.add("q" if kind == schemas.JOINT_STATES else "v", stamps, tuple(names), values)

    def _forces_out(self) -> None:
        names = self.residual.model.joint_names
        for b in self.residual.take():
            self.server.log(self.topic[schemas.FORCES], schemas.forces(b.stamp_ns, names, b.measured, b.model,
                                                                      b.ticks), b.stamp_ns)

    # ---- low-rate topics ---------------------------------------------------------------------------
    def _send(self, kind: str, msg: dict, ns: int, latch: bool = False) -> None:
        ns = ns or self.get_clock().now().nanoseconds
        if latch:
            self.latched[kind] = (msg, ns)
        self.server.log(self.topic[kind], msg, ns)

    def on_live(self, msg: LiveIdentification) -> None:
        self._send(schemas.LIVE, schemas.live(stamp_ns(msg), fields(msg)), stamp_ns(msg))

    def on_status(self, msg: RecorderStatus) -> None:
        self.residual.set_payload(msg.payload_mass if msg.condition == "loaded" else 0.0)
        self._send(schemas.RECORDER_STATUS, schemas.recorder_status(stamp_ns(msg), fields(msg)), stamp_ns(msg), True)

    def on_identified(self, msg: IdentifiedParameters) -> None:
        try:
            self.residual.set_parameters(list(msg.joint_names), list(msg.drive_gains), list(msg.names),
                                         list(msg.values))
            self.get_logger().info(f"model force from the identified parameters ({msg.method}, "
                                   f"{len(msg.names)} base parameters)")
        except OrthoglideError as e:
            self.get_logger().error(f"{self.topic[schemas.IDENTIFIED]}: {e}")
        self._send(schemas.IDENTIFIED, schemas.identified(stamp_ns(msg), fields(msg)), stamp_ns(msg), True)

    def close(self) -> None:
        self.taker.close()
        self.server.close()


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv if argv is None else argv
    if any(a in ("-h", "--help") for a in argv[1:]):
        print(usage("usage: ros2 run orthoglide_ident viewer [--ros-args -p NAME:=VALUE ... | --params-file "
                    "config/viewer.yaml]", DOC, PARAMETERS))
        return 0
    return spin(ViewerNode, argv, "viewer")


if __name__ == "__main__":
    sys.exit(main())
