"""Identification node: the orthoglide/identify service over the IDIM-TLS core.

    ros2 run orthoglide_ident identification [--ros-args --params-file config/identification.yaml]
"""
from __future__ import annotations

import json
import sys
import threading
from pathlib import Path
from typing import Any

from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import String

from orthoglide_ident.errors import ConfigError, OrthoglideError
from orthoglide_ident.flags import prepare_output
from orthoglide_ident.identify.live.session import LiveIdentification
from orthoglide_ident.identify.options import IdentifyOptions
from orthoglide_ident.identify.pipeline import identify
from orthoglide_ident.identify.solve.methods import DEFAULT_METHOD, METHODS, REFINEMENTS, get
from orthoglide_ident.model.mjcf_out import write_mjcf
from orthoglide_ident.model.registry import load_robot, load_robot_description
from orthoglide_ident.nodes.live_feed import LiveFeed
from orthoglide_ident.nodes.live_sources import LiveTopics
from orthoglide_ident.results import IdentificationResult, finite_only, lag_text
from orthoglide_ident.ros.core_log import CoreLog
from orthoglide_ident.ros.params import Param, declare, on_set, usage
from orthoglide_ident.ros.spin import spin
from orthoglide_msgs.msg import IdentifiedParameters
from orthoglide_msgs.srv import Identify

DOC = """\
Identifies a robot's drive gains and dynamic parameters together (IDIM-TLS, Briot & Gautier 2013)
from recorded bags when orthoglide/identify is called: the Orthoglide by default, any robot with
the robot parameter (a URDF, a robot YAML or a bundled robot's name). With robot empty, a URDF on
robot_description (std_msgs/String, transient local, as robot_state_publisher publishes it) is the
robot from when it arrives (every movable joint actuated, nominal gains 1; a recording under way
is then left out of the live identification).

Live (parameter live, default true): while the recorder records (orthoglide/recorder/status), the
joint states and currents it records are identified as they come (q from joint_states_topic; the
current from a dynamic_joint_states_topic interface, else the JointState effort, else
current_reference_topic, the first there is), and the estimate goes
out about once a second on orthoglide/identification/live (orthoglide_msgs/msg/LiveIdentification:
gains with %sigma, seconds used, s_c/s_(c-1), condition number, residual rms, lag, a one-line
status and the warnings: lost ticks, NaN, wrong joint names, weak excitation, current near the
limit).

Service  orthoglide/identify (orthoglide_msgs/srv/Identify)
  request: bags (paths; empty = the live data when there are some, else every bag in bag_dir),
           payload_mass (kg; 0 = from the bag tags / the recordings),
           method (tls | wls; "" = the parameter), essential (reduce to essential parameters)
  reply:   success, message (one line, with the warnings), parameters (the essential ones when
           essential is true); a partial answer (some gains not determined: their
           drive_gains_determined false, drive_gains_reason why, value NaN) succeeds, says which
           in the message, and is not latched
Topics   orthoglide/identified_parameters (orthoglide_msgs/msg/IdentifiedParameters, transient
         local, depth 1): the last successful full IDIM-TLS result, what the ctc node uses;
         orthoglide/identified_parameters/wls: the last IDIM-WLS result (gains given, payload
         estimated), so that a validation run does not switch a running CTC to other gains;
         orthoglide/identified_parameters/consistent (with the option consistent): the base
         parameters of physically consistent bodies identified under the constraints, gains
         held (what the ctc node uses with its parameter consistent);
         orthoglide/identify/json (std_msgs/String, transient local, depth 1): every successful
         answer (partial ones too) as the JSON of `orthoglide-ident identify --json`, in
         {"stamp": {"sec", "nanosec"}, "result": ...}, the stamp that of the reply's parameters
         (`identify --service --json FILE` writes its "result").
Every identification option is a ROS parameter (the keys of config/identification.yaml)."""

NODE_PARAMETERS = (
    Param(
        "robot",
        "",
        "the robot: a URDF, a robot YAML (docs/guide/robot_files.md) or a bundled robot "
        "(orthoglide, ur5, ...); empty: the Orthoglide",
    ),
    Param("bag_dir", "bags", "where to look for bags when a request names none"),
    Param(
        "method",
        DEFAULT_METHOD,
        "tls: gains identified, payload mass known; wls: gains given (wls_gains), "
        "payload mass estimated",
    ),
    Param(
        "essential",
        False,
        "also reduce to the essential parameters (Sect. 5.2) and answer with them",
    ),
    Param(
        "wls_gains",
        [0.0],
        "N/A (N·m/A for revolute joints), the drive gains IDIM-WLS uses, one "
        "per joint; [0.0]: the robot's nominal (manufacturer's) gains, the Orthoglide's 637 pi",
        dynamic=True,
    ),
    Param(
        "mjcf_out",
        "",
        "path: after each successful identification with every gain determined, write the "
        "identified robot there as an MJCF for MuJoCo (consistent inertials, armature, damping, "
        "frictionloss, motor gears; implies the option consistent, which needs the payload's "
        "CoM and inertia: its tag or the option payload_known) and say it in the reply; "
        "empty: off",
        dynamic=True,
    ),
    Param(
        "live",
        True,
        "identify the recordings while they run (orthoglide/identification/live); an "
        "identify call with no bags then answers from the live data",
    ),
    Param(
        "joint_states_topic",
        "orthoglide/joint_states",
        "live: the JointState topic of q (a ros2_control robot: joint_states)",
    ),
    Param(
        "dynamic_joint_states_topic",
        "dynamic_joint_states",
        "live: the DynamicJointState topic whose "
        'current_interface is the current, when published ("": not read)',
    ),
    Param(
        "current_reference_topic",
        "orthoglide/current_reference",
        "live: the CurrentReference topic, "
        'used when neither of the above carries a current ("": not read)',
    ),
)
# Every option (a flat key of one of IdentifyOptions' groups) is a parameter of the same name, so
# --params-file config/identification.yaml sets them (the CLI's --config reads the same file).
OPTION_PARAMETERS = tuple(
    Param(
        name,
        default,
        f"identification option of the {group} group (config/identification.yaml says what it "
        "does, under that group's header)",
        dynamic=True,
    )
    for name, default, group in IdentifyOptions.flat_fields()
)
OPTION_NAMES = frozenset(p.name for p in OPTION_PARAMETERS)
PARAMETERS = NODE_PARAMETERS + OPTION_PARAMETERS


JSON_TOPIC = "orthoglide/identify/json"  # the whole answer, as identify --json writes it


def json_message(result: IdentificationResult, stamp: Any) -> String:
    """The result's JSON (``identify --json``'s document) tagged with the reply's stamp, so that
    a client tells its own answer from a later caller's on the latched topic."""
    doc = {"stamp": {"sec": int(stamp.sec), "nanosec": int(stamp.nanosec)},
           "result": finite_only(result.to_json())}
    return String(data=json.dumps(doc, allow_nan=False))


def find_bags(bag_dir: Path) -> list[str]:
    """Bag directories (holding metadata.yaml) and lone .mcap files directly under bag_dir."""
    if not bag_dir.is_dir():
        return []
    return [str(p) for p in sorted(bag_dir.iterdir())
            if (p / "metadata.yaml").is_file() or (p.is_file() and p.suffix == ".mcap")]


def result_message(result: IdentificationResult, stamp: Any,
                   transform: Any = None) -> IdentifiedParameters:
    """The message of a result (``transform``: fields -> fields, e.g. the consistent set's)."""
    msg = IdentifiedParameters()
    msg.header.stamp = stamp
    fields = result.message_fields()
    for key, value in (transform(fields) if transform else fields).items():
        setattr(msg, key, value)
    return msg


class IdentificationNode(Node):
    """The service, the latched results. Threads (README "Threads"): the executor has two; the
    identify service is in a reentrant group of its own (a second call while one runs is refused
    at once by the other thread), everything else in the default group only hands over; the live
    update runs on LiveFeed's worker and the 1 kHz topics on its intake thread."""

    def __init__(self) -> None:
        super().__init__("orthoglide_identification")
        declare(self, PARAMETERS)
        self.options()  # bad option values stop the node at start with a one-line reason
        if self.param("mjcf_out"):  # its folder made now, or a one-line refusal at start
            prepare_output(self.param("mjcf_out"), "parameter mjcf_out")
        self.robot = load_robot(self.param("robot"))  # a bad robot file: one line, exit 2
        self._check_gains(self.param("wls_gains"))
        latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                             reliability=ReliabilityPolicy.RELIABLE)
        topics = {m.name: m.topic for m in METHODS.values()}  # identify/methods.py's tables
        topics["consistent"] = REFINEMENTS["consistent"].topic
        self.pub = {k: self.create_publisher(IdentifiedParameters, t, latched)
                    for k, t in topics.items()}
        self.json_pub = self.create_publisher(String, JSON_TOPIC, latched)
        self.busy = threading.Lock()
        self.live_lock = threading.Lock()
        self.live = None
        if self.param("live"):
            self.live = LiveIdentification(self.options(), model=self.robot)
            topics = LiveTopics(
                self.param("joint_states_topic"),
                self.param("current_reference_topic"),
                self.param("dynamic_joint_states_topic"),
                self.options().input.current_interface,
            )
            self.feed = LiveFeed(self, self.live, self.live_lock, topics, robot=self.robot,
                                 effort_unit=self.options().input.effort_unit)
        if not self.param("robot"):  # the URDF robot_state_publisher publishes, when there is one
            self.create_subscription(String, "robot_description", self._on_description, latched)
        self.create_service(
            Identify,
            "orthoglide/identify",
            self.on_identify,
            callback_group=ReentrantCallbackGroup(),
        )
        on_set(self, PARAMETERS, self._check_changes)  # bad values refused at `ros2 param set`
        self.get_logger().info(
            f"ready ({self.robot.name}: {self.robot.n_joints} joints "
            f"{', '.join(self.robot.joint_names)}, {self.robot.n_b} base "
            f"parameters): call {self.resolve_service_name('orthoglide/identify')}"
        )

    def close(self) -> None:
        if self.live is not None:
            self.feed.close()

    def _on_description(self, msg: String) -> None:
        """robot_description (robot parameter empty): that URDF is the robot from now on, for
        bags at once and live from the next recording (a recording under way is left out)."""
        try:
            robot = load_robot_description(msg.data)
        except OrthoglideError as e:
            self.get_logger().error(f"robot_description ignored, keeping {self.robot.name}: {e}")
            return
        if robot is self.robot:
            return  # published again, the same URDF
        self.robot = robot  # for the next identification from bags (one under way keeps its own)
        if self.live is not None:  # the live side changes on its worker, between two updates
            options = self.options()

            def replace() -> None:
                self.live = LiveIdentification(options, model=robot)
                self.feed.replace(self.live, robot)

            self.feed.submit(replace)
        self.get_logger().info(
            f"robot from robot_description: {robot.name}, {robot.n_joints} joints "
            f"{', '.join(robot.joint_names)}, {robot.n_b} base parameters (nominal gains 1)"
        )

    def param(self, name: str) -> Any:
        return next(p for p in PARAMETERS if p.name == name).coerce(self.get_parameter(name).value)

    def _check_changes(self, changes: dict[str, Any]) -> None:
        """A run-time change must leave valid options (ConfigError: refused with its reason)."""
        self.options(changes)
        if "wls_gains" in changes:
            self._check_gains(changes["wls_gains"])
        changed = [k for k in changes if k in OPTION_NAMES]
        if changed and self.live is not None:
            self.get_logger().info(
                f"{', '.join(changed)} changed: used by identifications from bags; "
                "the live identification keeps the options it started with"
            )

    def _check_gains(self, gains: list[float]) -> None:
        if gains != [0.0] and (len(gains) != self.robot.n_joints or min(gains) <= 0):
            raise ConfigError(f"parameter wls_gains: {self.robot.n_joints} positive gains "
                              f"({', '.join(self.robot.joint_names)}) or [0.0] for the nominal "
                              f"ones, got {gains}")

    def wls_gains(self) -> list[float]:
        gains = self.param("wls_gains")
        return list(self.robot.nominal_gains) if gains == [0.0] else gains

    def options(self, changes: dict[str, Any] | None = None) -> IdentifyOptions:
        """The pipeline options from the node's parameters (validated in the core), with
        ``changes`` (a ``ros2 param set`` being checked) in place of their current values."""
        values = {p.name: self.param(p.name) for p in OPTION_PARAMETERS}
        values.update((k, v) for k, v in (changes or {}).items() if k in OPTION_NAMES)
        if (changes or {}).get("mjcf_out", self.param("mjcf_out")):
            values["consistent"] = True  # MuJoCo needs physically consistent inertials
        return IdentifyOptions.from_mapping(values, source="parameters")

    def on_identify(
        self, request: Identify.Request, response: Identify.Response
    ) -> Identify.Response:
        if not self.busy.acquire(blocking=False):
            response.success = False
            response.message = (
                "busy: another identification is running; call again when it has answered"
            )
            return response
        try:
            self.run(request, response)
        finally:
            self.busy.release()
        return response

    def run(self, request: Identify.Request, response: Identify.Response) -> None:
        method = request.method or self.param("method")
        essential = bool(request.essential or self.param("essential"))
        robot = self.robot  # the one identified (robot_description may replace it meanwhile)
        try:
            with CoreLog(self.get_logger()):  # records read, ripple, lags: in the node's log
                result = self.identify(request, method, essential)
        except OrthoglideError as e:
            response.success, response.message = False, str(e).splitlines()[0]
            self.get_logger().error(f"identification failed: {response.message}")
            return
        except Exception as e:  # a bug must not kill the node: answer and log it
            response.success, response.message = False, f"internal error: {type(e).__name__}: {e}"
            self.get_logger().error(response.message)
            return
        self.answer(result, method, essential, response)
        if response.success and self.param("mjcf_out"):
            said = self.write_mjcf(result, robot, self.param("mjcf_out"))
            response.message += "; " + said
            self.get_logger().info(said)

    def write_mjcf(self, result: IdentificationResult, robot: Any, path: str) -> str:
        """Parameter mjcf_out: the identified robot as an MJCF (model/mjcf_out.py); what became
        of it, for the reply."""
        if result.consistency is None:
            return (f"MJCF not written to {path}: "
                    + ("a partial answer" if not result.complete else "no consistent set"))
        try:  # its folder made first (the path may have been set since the start)
            notes = write_mjcf(prepare_output(path, "parameter mjcf_out"), robot,
                               result.consistency.answer.chi_st,
                               [g.value for g in result.drive_gains])
        except OrthoglideError as e:
            return f"MJCF not written to {path}: {e}"
        return f"MJCF written to {path}" + "".join(f" ({n})" for n in notes)

    def identify(
        self, request: Identify.Request, method: str, essential: bool
    ) -> IdentificationResult:
        """From the bags named, else the live data, else every bag of bag_dir."""
        payload_mass = request.payload_mass if request.payload_mass > 0 else None
        gains = self.wls_gains() if get(method).gains_given else None
        if not request.bags and self.live is not None:
            with self.live_lock:
                est = self.live.estimate()
                # a recording refused by the record checks is answered with its reason
                if est.seconds_loaded + est.seconds_unloaded > 0 or self.live.refused:
                    self.source = (
                        f"the live data ({est.seconds_unloaded:.0f} s unloaded, "
                        f"{est.seconds_loaded:.0f} s "
                        "loaded)"
                    )
                    self.get_logger().info(f"identifying ({method}) from {self.source}")
                    return self.live.result(method, essential, gains, payload_mass)
        bags = list(request.bags) or find_bags(Path(self.param("bag_dir")))
        if not bags:
            raise OrthoglideError(
                f"no bags given and none found in bag_dir '{self.param('bag_dir')}'"
            )
        # no bags named and no live data (none recorded since this node started): say where from
        self.source = f"{len(bags)} bag(s)" + ("" if request.bags else " of bag_dir (no live data)")
        self.get_logger().info(f"identifying ({method}) from {self.source}: {', '.join(bags)}")
        return identify(
            bags,
            payload_mass=payload_mass,
            method=method,
            gains=gains,
            essential=essential,
            options=self.options(),
            model=self.robot,
        )

    def answer(self, result: IdentificationResult, method: str, essential: bool,
               response: Identify.Response) -> None:
        """Publish (latched) and answer with the result; its warnings go to the log and the
        reply."""
        chosen = result.essential if essential and result.essential is not None else result
        msg = result_message(chosen, self.get_clock().now().to_msg())
        if chosen.complete:  # a partial answer is not latched: the ctc takes only a full one
            self.pub[method].publish(msg)
        for w in result.warnings:
            self.get_logger().warning(w)
        gains = ", ".join(
            f"{n} {g:.5g}" if ok else f"{n} not determined"  # a motor's: 0.41704
            for n, g, ok in zip(msg.joint_names, msg.drive_gains, msg.drive_gains_determined)
        )
        response.success = True
        response.message = (
            f"{method}{' essential' if chosen is not result else ''}: drive gains [{gains}] "
            f"{chosen._units(chosen.gain_units, 'N/A')}, {len(msg.names)} parameters, payload "
            f"{msg.payload_mass:.4g} kg, residual rms {msg.residual_rms:.3g} "
            f"{chosen._units(chosen.effort_units, 'N')}, cond {msg.condition_number:.3g}"
        )
        if chosen.current_lag:  # a drive term, not a parameter of the message
            response.message += "; current-loop lag " + lag_text(chosen.current_lag)
        if chosen.payload is not None:  # identified with the robot (Sect. 4.3): in the reply
            response.message += "; " + chosen.payload.summary()
        if result.consistency is not None:  # parameter consistent: the set of real bodies, latched
            self.pub["consistent"].publish(result_message(result, msg.header.stamp,
                                                          result.consistency.message_fields))
            response.message += "; physical consistency: " + result.consistency.summary()
        if not chosen.complete:
            response.message += ("; partial answer, not latched for the ctc: "
                                 + chosen.not_determined_text())
        response.message += f"; from {self.source}"
        if result.warnings:
            response.message += f"; {len(result.warnings)} warning(s): " + " | ".join(
                result.warnings
            )
        response.parameters = msg
        self.json_pub.publish(json_message(result, msg.header.stamp))  # before the reply leaves
        self.get_logger().info(response.message)


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv if argv is None else argv
    if any(a in ("-h", "--help") for a in argv[1:]):
        print(
            usage(
                "usage: ros2 run orthoglide_ident identification [--ros-args -p NAME:=VALUE ... | "
                "--params-file config/identification.yaml]",
                DOC,
                NODE_PARAMETERS,
            )
            + "\n  ... and every identification option of config/identification.yaml (same names)"
        )
        return 0
    return spin(IdentificationNode, argv, "identification", threads=2)


if __name__ == "__main__":
    sys.exit(main())
