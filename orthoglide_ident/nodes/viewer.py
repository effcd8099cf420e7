"""Viewer node: the graph's topics served live to Foxglove (or Lichtblick) over its WebSocket.

    ros2 run orthoglide_ident viewer [--ros-args --params-file config/viewer.yaml]
"""
from __future__ import annotations

import collections
import sys
from typing import Any

import numpy as np
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import JointState

from orthoglide_ident.bags.reader import decode_messages
from orthoglide_ident.bags.sources import CURRENT_SOURCES, DEFAULT_INTERFACE
from orthoglide_ident.bags.topics import (
    CURRENT_REFERENCE_TYPE,
    DYNAMIC_JOINT_STATE_TYPE,
    JOINT_STATE_TYPE,
)
from orthoglide_ident.errors import ConfigError, OrthoglideError
from orthoglide_ident.identify.records.record import torque_as_current
from orthoglide_ident.model.registry import load_robot
from orthoglide_ident.ros.batch import BatchTaker, BatchTopic
from orthoglide_ident.ros.params import Param, declare, usage
from orthoglide_ident.ros.spin import spin
from orthoglide_ident.view import schemas
from orthoglide_ident.view.decimate import StampDecimator, cdr_stamps
from orthoglide_ident.view.residual import ForceResidual
from orthoglide_ident.view.server import ViewServer
from orthoglide_msgs.msg import (
    CurrentReference,
    IdentifiedParameters,
    JointSetpoint,
    LiveIdentification,
    RecorderStatus,
)

DOC = """\
Serves the graph's topics to Foxglove (or Lichtblick) over the Foxglove WebSocket protocol
(foxglove-sdk, subprotocol foxglove.sdk.v1): in the app, "Open connection" -> Foxglove WebSocket
-> ws://host:port (the node prints the address), then import the layout
share/orthoglide_ident/foxglove/orthoglide_layout.json for a ready view.

JSON channels, named after the topics (resolved: /orthoglide/..., or under the namespace):
  orthoglide/joint_states, orthoglide/current_reference, orthoglide/setpoints   at `rate` Hz (the
      first message of each period of their stamps); next to ros2_control (config/ros2_control.yaml)
      joint_states (positions), joint_states/effort (the effort, as currents) and
      dynamic_joint_states (the current interface, as currents) instead; the model force takes the
      current from the interface, else the effort, else the CurrentReference, as the identification
  orthoglide/identification/live    the live estimate: each gain, its sigma and gain +- sigma as
                                    numbers, the status and the warnings as text
  orthoglide/recorder/status        the recorder's state, with a one-line summary
  orthoglide/identified_parameters  the latched IDIM-TLS result (gains +- sigma, base parameters)
  orthoglide/forces                 per joint the measured force g_tau v_tau, the identified
      model's W chi + W_kl m_7 (positions differentiated by the identification's filter, the
      payload the recorder says is on) and their difference, means over 1/rate s, ~0.2 s late
A robot with a transmission (its robot file's transmission:, docs/guide/robot_files.md) is viewed as
it
is identified: the gains are the motors', named by actuator; positions and currents are read on
the channels of their side and mapped to the motors; orthoglide/forces is per motor, with the
joints' residual N^T (measured - model) beside it (joint_name, joint_residual).
Joint names and counts come from the messages. Browsers that do not keep up lose frames, never the
node: the topics are taken in batches on a thread of their own, and the server drops a slow
client's oldest messages."""

PARAMETERS = (
    Param(
        "host",
        "127.0.0.1",
        "address the Foxglove WebSocket server listens on (0.0.0.0: every interface)",
    ),
    Param(
        "port",
        8765,
        "TCP port of the Foxglove WebSocket server (0: any free port, printed at start)",
    ),
    Param(
        "rate",
        50.0,
        "Hz of the high-rate channels sent to clients (joint states, currents, setpoints, forces)",
    ),
    Param(
        "robot",
        "",
        "robot model of the model force, as the identification's robot parameter: empty = the "
        "Orthoglide, a bundled name, a URDF or a robot YAML",
    ),
    Param(
        "joint_states_topic",
        schemas.JOINT_STATES,
        "JointState topic of the positions (ros2_control: "
        "joint_states); its effort, when it has one, is shown as currents on <topic>/effort",
    ),
    Param(
        "current_reference_topic",
        schemas.CURRENT_REFERENCE,
        'CurrentReference topic of the currents ("": not read)',
    ),
    Param(
        "dynamic_joint_states_topic",
        "",
        "DynamicJointState topic whose current_interface is the current "
        '(ros2_control: dynamic_joint_states; "": not read)',
    ),
    Param("current_interface", "", 'the DynamicJointState interface of the current ("" = current)'),
    Param(
        "effort_unit",
        "A",
        "the JointState effort: A (a current) or torque (N·m or N, divided by the "
        "nominal gains), as the identification's",
    ),
)
PROCESS_PERIOD_S = 0.1  # the batches taken are decoded, decimated and sent this often
QOS_CHECK_PERIOD_S = 2.0
BUFFER = 5000  # serialized messages kept per high-rate topic between two processings (5 s at 1 kHz)
# the ros2_control sources of the currents (kinds of their own)
EFFORT, DYNAMIC = "effort", "dynamic"
_KIND = {"d": DYNAMIC, "effort": EFFORT, "v": schemas.CURRENT_REFERENCE}  # of bags.sources' keys
CURRENT_PREFERENCE = tuple(_KIND[s.key] for s in CURRENT_SOURCES)  # the one order of preference


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
        if p["effort_unit"] not in ("A", "torque"):
            raise ConfigError(f"parameter effort_unit: A or torque, got {p['effort_unit']!r}")
        self.p = p
        self.residual = ForceResidual(load_robot(p["robot"]), block_s=1.0 / p["rate"])
        self.server = ViewServer(p["host"], p["port"])
        self.streams = self._streams(p)
        names = {
            schemas.JOINT_STATES: p["joint_states_topic"],
            schemas.CURRENT_REFERENCE: p["current_reference_topic"],
            DYNAMIC: p["dynamic_joint_states_topic"],
        }
        self.topic = {
            kind: self.resolve_topic_name(names.get(kind, kind))
            for kind in (
                *self.streams,
                schemas.LIVE,
                schemas.RECORDER_STATUS,
                schemas.IDENTIFIED,
                schemas.FORCES,
            )
        }
        for kind, topic in self.topic.items():
            self.server.add(topic, schemas.CURRENT_REFERENCE if kind == DYNAMIC else kind)
        self.topic[EFFORT] = self.topic[schemas.JOINT_STATES] + "/effort"
        # the Orthoglide's joint states carry no effort
        if p["joint_states_topic"] != schemas.JOINT_STATES:
            self.server.add(self.topic[EFFORT], schemas.CURRENT_REFERENCE)
        # the currents of the model force (CURRENT_PREFERENCE)
        self.current_source: str | None = None
        self.latched: dict[str, tuple[dict, int]] = {}  # kind -> last (message, log time)
        self.buffers = {k: collections.deque(maxlen=BUFFER) for k in self.streams}
        self.decimators = {k: StampDecimator(round(1e9 / p["rate"])) for k in self.streams}
        self.qos = {k: self._offered_qos(k) for k in self.streams}
        latched = QoSProfile(
            depth=1,
            durability=DurabilityPolicy.TRANSIENT_LOCAL,
            reliability=ReliabilityPolicy.RELIABLE,
        )
        self.create_subscription(LiveIdentification, schemas.LIVE, self.on_live, 10)
        self.create_subscription(RecorderStatus, schemas.RECORDER_STATUS, self.on_status, latched)
        self.create_subscription(
            IdentifiedParameters, schemas.IDENTIFIED, self.on_identified, latched
        )
        self.create_timer(PROCESS_PERIOD_S, self.process)
        self.create_timer(QOS_CHECK_PERIOD_S, self.follow_qos)
        self.taker = BatchTaker(self, [self._stream(k) for k in self.streams], period_s=0.01)
        self.get_logger().info(
            f"Foxglove view on {self.server.url}: in Foxglove or Lichtblick, Open connection -> "
            f"Foxglove WebSocket -> {self.server.url}"
        )

    @staticmethod
    def _streams(p: dict[str, Any]) -> dict[str, tuple[Any, str | None]]:
        """The high-rate topics read: kind -> (message class, bulk-decoder type name)."""
        streams: dict[str, tuple[Any, str | None]] = {
            schemas.JOINT_STATES: (JointState, JOINT_STATE_TYPE),
            schemas.SETPOINTS: (JointSetpoint, None),
        }
        if p["current_reference_topic"]:
            streams[schemas.CURRENT_REFERENCE] = (CurrentReference, CURRENT_REFERENCE_TYPE)
        if p["dynamic_joint_states_topic"]:
            from control_msgs.msg import (
                DynamicJointState,  # built by make setup, or a ROS install's
            )

            streams[DYNAMIC] = (DynamicJointState, DYNAMIC_JOINT_STATE_TYPE)
        return streams

    # ---- high-rate topics: taken raw in batches, processed every PROCESS_PERIOD_S
    # ------------------
    def _stream(self, kind: str) -> BatchTopic:
        buf = self.buffers[kind]
        return BatchTopic(self.streams[kind][0], self.topic[kind], self.qos[kind],
                          lambda batch: buf.extend(m[0] for m in batch))

    def _offered_qos(self, kind: str) -> QoSProfile:
        """Reliable unless a publisher offers best effort (a reliable subscription would not match
        it)."""
        offered = self.get_publishers_info_by_topic(self.topic[kind])
        best_effort = any(
            i.qos_profile.reliability == ReliabilityPolicy.BEST_EFFORT for i in offered
        )
        return QoSProfile(depth=1000, reliability=ReliabilityPolicy.BEST_EFFORT if best_effort
                          else ReliabilityPolicy.RELIABLE)

    def follow_qos(self) -> None:
        for kind in self.streams:
            qos = self._offered_qos(kind)
            if qos != self.qos[kind]:
                self.qos[kind] = qos
                self.taker.add(self._stream(kind))
                self.get_logger().info(
                    f"{self.topic[kind]}: now taken {qos.reliability.name.lower()}"
                )

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
            self.get_logger().error(
                f"{self.topic[kind]}: internal error, frames lost: {type(e).__name__}: {e}",
                throttle_duration_sec=10.0,
            )

    def _stream_out(self, kind: str, raw: list[bytes]) -> None:
        if kind == schemas.SETPOINTS:  # no bulk decoder: deserialize only the messages sent
            for i in self.decimators[kind].pick(cdr_stamps(raw)):
                m = deserialize_message(raw[i], JointSetpoint)
                self.server.log(
                    self.topic[kind],
                    schemas.joint_values(
                        stamp_ns(m),
                        m.name,
                        position=m.position,
                        velocity=m.velocity,
                        acceleration=m.acceleration,
                    ),
                    stamp_ns(m),
                )
            return
        msgtype = self.streams[kind][1]
        iface = (self.p["current_interface"] or DEFAULT_INTERFACE) if kind == DYNAMIC else None
        stamps, names, values = decode_messages(raw, msgtype, iface)
        picked = self.decimators[kind].pick(stamps)
        if kind == schemas.JOINT_STATES:
            self._log(kind, picked, stamps, names, "position", values)
            self.residual.add("q", stamps, tuple(names), values)
            # the joints that have one
            stamps, names, values = decode_messages(raw, msgtype, "effort")
            if not names:
                return
            if self.p["effort_unit"] == "torque":  # N·m or N -> A with the nominal gains (as live)
                values = torque_as_current(self.residual.model, names, values)
            kind = EFFORT
        self._log(kind, picked, stamps, names, "current", values)
        self._current(kind, stamps, tuple(names), values)

    def _log(
        self, kind: str, picked: Any, stamps: Any, names: Any, field: str, values: Any
    ) -> None:
        topic = self.topic[kind]
        if topic not in self.server.channels:
            self.server.add(topic, schemas.CURRENT_REFERENCE)  # joint_states/effort, once it comes
        for i in picked:
            self.server.log(
                topic,
                schemas.joint_values(int(stamps[i]), names, **{field: values[i]}),
                int(stamps[i]),
            )

    def _current(self, source: str, stamps: Any, names: tuple[str, ...], values: Any) -> None:
        """The model force's currents from the most preferred source that has them all (finite)."""
        rank = CURRENT_PREFERENCE.index(source)
        if self.current_source is not None and rank > CURRENT_PREFERENCE.index(self.current_source):
            return
        joints = self.residual.channels["v"][0]  # the model's joints, or a transmission's side
        if source == EFFORT and not (
            set(joints) <= set(names)
            and np.isfinite(values[:, [names.index(j) for j in joints]]).all()
        ):
            return  # an effort without the robot's currents: not a current source
        if source != self.current_source:
            self.current_source = source
            self.get_logger().info(f"model force: currents from {self.topic[source]}")
        self.residual.add("v", stamps, names, values)

    def _forces_out(self) -> None:
        names = self.residual.model.joint_names  # a transmission's motors, its joints beside them
        t = self.residual.transmission
        joints = () if t is None else t.joints
        for b in self.residual.take():
            joint = () if b.joint_residual is None else b.joint_residual
            self.server.log(
                self.topic[schemas.FORCES],
                schemas.forces(b.stamp_ns, names, b.measured, b.model, b.ticks, joints, joint),
                b.stamp_ns,
            )

    # ---- low-rate topics
    # ---------------------------------------------------------------------------
    def _send(self, kind: str, msg: dict, ns: int, latch: bool = False) -> None:
        ns = ns or self.get_clock().now().nanoseconds
        if latch:
            self.latched[kind] = (msg, ns)
        self.server.log(self.topic[kind], msg, ns)

    def on_live(self, msg: LiveIdentification) -> None:
        self._send(schemas.LIVE, schemas.live(stamp_ns(msg), fields(msg)), stamp_ns(msg))

    def on_status(self, msg: RecorderStatus) -> None:
        self.residual.set_payload(msg.payload_mass if msg.condition == "loaded" else 0.0)
        self._send(
            schemas.RECORDER_STATUS,
            schemas.recorder_status(stamp_ns(msg), fields(msg)),
            stamp_ns(msg),
            True,
        )

    def on_identified(self, msg: IdentifiedParameters) -> None:
        try:
            self.residual.set_parameters(
                list(msg.joint_names), list(msg.drive_gains), list(msg.names), list(msg.values)
            )
            self.get_logger().info(f"model force from the identified parameters ({msg.method}, "
                                   f"{len(msg.names)} base parameters)")
        except OrthoglideError as e:
            self.get_logger().error(f"{self.topic[schemas.IDENTIFIED]}: {e}")
        self._send(
            schemas.IDENTIFIED, schemas.identified(stamp_ns(msg), fields(msg)), stamp_ns(msg), True
        )

    def close(self) -> None:
        self.taker.close()
        self.server.close()


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv if argv is None else argv
    if any(a in ("-h", "--help") for a in argv[1:]):
        print(
            usage(
                "usage: ros2 run orthoglide_ident viewer [--ros-args -p NAME:=VALUE ... | "
                "--params-file "
                "config/viewer.yaml]",
                DOC,
                PARAMETERS,
            )
        )
        return 0
    return spin(ViewerNode, argv, "viewer")


if __name__ == "__main__":
    sys.exit(main())
