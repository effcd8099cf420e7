"""The client side of the node set for ``orthoglide-ident``: one command per service, and a watch.

    orthoglide-ident record start --condition loaded --payload-mass 1.983 [--name run2]
        [--payload-frame LINK --payload-com X,Y,Z --payload-inertia ... --payload-known point]
    orthoglide-ident record stop
    orthoglide-ident record status
    orthoglide-ident identify --service [BAG...] [--method tls|wls] [--essential] [--payload-mass
    KG]
    orthoglide-ident watch [--seconds S]

The same services and topics as `ros2 service call` / `ros2 topic echo` (names relative to
``--namespace``, default the root: /orthoglide/...), without the ros2 CLI, which a venv made by
`make setup` does not have. rclpy is imported only here, and only when one of these runs.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

from orthoglide_ident.errors import OrthoglideError

SERVICE_TIMEOUT_S = 30.0


class ServiceError(OrthoglideError):
    """A node of the graph did not answer, or answered success: false."""


def add_parsers(sub: Any) -> None:
    """``record`` and ``watch`` subcommands (``identify --service`` lives with ``identify``)."""
    p = sub.add_parser(
        "record",
        help="start / stop a recording, or print the recorder's status (ROS 2)",
        description="Call the recorder node's services (orthoglide/recorder/start|stop) or "
        "print its latched status (orthoglide/recorder/status).",
    )
    p.add_argument("action", choices=("start", "stop", "status"))
    p.add_argument(
        "--condition", choices=("loaded", "unloaded"), help="start: with or without the payload"
    )
    p.add_argument(
        "--payload-mass", type=float, default=0.0, metavar="KG", help="start: weighed payload, kg"
    )
    p.add_argument(
        "--name", default="", help="start: bag folder name (default <condition>_<date>_<time>)"
    )
    p.add_argument(
        "--payload-frame",
        default=None,
        metavar="LINK",
        help="start loaded: the link the payload is fixed to (default the robot's payload frame)",
    )
    p.add_argument("--payload-com", default=None, metavar="X,Y,Z",
                   help="start loaded: its centre of mass in that frame, m (default its origin)")
    p.add_argument(
        "--payload-inertia",
        default=None,
        metavar="IXX,IXY,IXZ,IYY,IYZ,IZZ",
        help="start loaded: its inertia about the centre of mass, kg·m² (default 0: a point mass); "
        "the three set the recorder's payload_* parameters for this start only (tagged "
        "in the bag; nothing carries over to the next start)",
    )
    p.add_argument("--payload-known", choices=("mass", "com", "all", "point"), default=None,
                   help="start loaded: what is known of the payload (paper Sect. 4.3), tagged "
                        "orthoglide.payload_known: mass (weighed only: its CoM and inertia are "
                        "identified), com, all, or point (a point mass at the frame); default: "
                        "what --payload-com/--payload-inertia give")
    p.add_argument("--recorder", default="orthoglide_recorder", metavar="NODE",
                   help="the recorder node's name, for --payload-* (default orthoglide_recorder)")
    add_namespace(p)
    p = sub.add_parser(
        "watch",
        help="follow the recording and the live identification (ROS 2)",
        description="Print orthoglide/recorder/status and orthoglide/identification/live "
        "as they come, until Ctrl-C or --seconds.",
    )
    p.add_argument(
        "--seconds", type=float, default=0.0, help="stop after this long (default: Ctrl-C)"
    )
    add_namespace(p)


def add_namespace(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--namespace", default="", help="namespace of the robot's graph (default: the root)"
    )


class Client:
    """A short-lived rclpy node in the robot's namespace (``with Client(ns) as c: ...``)."""

    def __init__(self, namespace: str = ""):
        self.namespace = namespace

    def __enter__(self) -> Client:
        import rclpy
        from rclpy.signals import SignalHandlerOptions

        # Ctrl-C: KeyboardInterrupt, one line
        rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
        self.rclpy = rclpy
        self.node = rclpy.create_node("orthoglide_ident_cli", namespace=self.namespace or "/")
        return self

    def __exit__(self, *exc: Any) -> None:
        self.node.destroy_node()
        self.rclpy.try_shutdown()

    def call(
        self, srv_type: Any, service: str, timeout: float = SERVICE_TIMEOUT_S, **fields: Any
    ) -> Any:
        client = self.node.create_client(srv_type, service)
        name = client.srv_name
        if not client.wait_for_service(timeout_sec=min(timeout, 10.0)):
            raise ServiceError(
                f"no service {name}: is the node running (ros2 launch orthoglide_ident "
                "orthoglide.launch.py) in this ROS_DOMAIN_ID and namespace?"
            )
        future = client.call_async(srv_type.Request(**fields))
        self.rclpy.spin_until_future_complete(self.node, future, timeout_sec=timeout)
        if not future.done():
            raise ServiceError(f"{name} did not answer within {timeout:.0f} s")
        return future.result()

    def latched(self, msg_type: Any, topic: str, timeout: float = 3.0) -> Any | None:
        """The last message of a transient-local topic, or None."""
        from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

        got: list = []
        qos = QoSProfile(
            depth=1,
            durability=DurabilityPolicy.TRANSIENT_LOCAL,
            reliability=ReliabilityPolicy.RELIABLE,
        )
        self.node.create_subscription(msg_type, topic, got.append, qos)
        t_end = time.monotonic() + timeout
        while not got and time.monotonic() < t_end:
            self.rclpy.spin_once(self.node, timeout_sec=0.1)
        return got[-1] if got else None


def record(args: argparse.Namespace) -> int:
    from std_srvs.srv import Trigger

    from orthoglide_msgs.msg import RecorderStatus
    from orthoglide_msgs.srv import StartRecording

    with Client(args.namespace) as c:
        if args.action == "status":
            msg = c.latched(RecorderStatus, "orthoglide/recorder/status")
            if msg is None:
                raise ServiceError("no orthoglide/recorder/status: is the recorder running?")
            print(status_line(msg))
            return 0
        if args.action == "start":
            if args.condition is None:
                raise ServiceError("record start needs --condition loaded|unloaded")
            set_payload_shape(c, args)
            res = c.call(StartRecording, "orthoglide/recorder/start", condition=args.condition,
                         payload_mass=float(args.payload_mass), name=args.name)
        else:
            res = c.call(Trigger, "orthoglide/recorder/stop")
    if not res.success:
        raise ServiceError(res.message)
    print(res.message)
    return 0


def _numbers(text: str, n: int, option: str) -> list[float]:
    from orthoglide_ident.flags import parse_vector  # the one grammar of vector flags

    return list(parse_vector(text, n, option))


def set_payload_shape(c: Client, args: argparse.Namespace) -> None:
    """--payload-frame/-com/-inertia into the recorder's payload_* parameters (given ones only;
    the recorder uses them for the next start only, then falls back to its launch values);
    --payload-known into payload_known on every loaded start ("" when not given)."""
    from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
    from rcl_interfaces.srv import SetParametersAtomically

    params = []
    if args.payload_frame is not None:
        params.append(Parameter(name="payload_frame", value=ParameterValue(
            type=ParameterType.PARAMETER_STRING, string_value=args.payload_frame)))
    for name, text, n in (("payload_com", args.payload_com, 3),
                          ("payload_inertia", args.payload_inertia, 6)):
        if text is not None:
            params.append(Parameter(name=name, value=ParameterValue(
                type=ParameterType.PARAMETER_DOUBLE_ARRAY,
                double_array_value=_numbers(text, n, "--" + name.replace("_", "-")))))
    if args.condition == "loaded":  # this start's knowledge, never an earlier start's
        params.append(Parameter(name="payload_known", value=ParameterValue(
            type=ParameterType.PARAMETER_STRING, string_value=args.payload_known or "")))
    if not params:
        return
    # atomically: a refused one leaves none of them set (nothing half-given reaches a start)
    res = c.call(SetParametersAtomically, f"{args.recorder}/set_parameters_atomically",
                 parameters=params)
    if not res.result.successful:
        raise ServiceError(f"recorder refused the payload ({', '.join(p.name for p in params)}): "
                           f"{res.result.reason}")


SERVICE_FLAGS_REFUSED = (  # identify flags the node takes from its own parameters, not a call
    ("robot", "--robot", "the node's parameter robot (--robot goes with --mjcf-out or "
     "--urdf-out: the robot the client writes the node's answer into)"),
    ("gains", "--gains", "the node's parameter wls_gains"),
    ("payload_known", "--payload-known", "the recorder's payload_known tag or the node's option"),
    ("r_sigma", "--r-sigma", "the node's parameter r_sigma"),
    ("config", "--config", "the node's --params-file"),
    ("validate", "--validate", "an offline identify with the bags"),
    ("consistent", "--consistent", "the node's parameter consistent (the consistent set is "
     "latched on orthoglide/identified_parameters/consistent)"),
)
WRITTEN_HERE = (("mjcf_out", "--mjcf-out"), ("urdf_out", "--urdf-out"))  # from the node's JSON
JSON_WAIT_S = 10.0  # the JSON is published before the reply: it is there or on its way


def refuse_service_flags(args: argparse.Namespace) -> None:
    """One line naming the first flag the service cannot carry (Identify.srv is fixed): never
    ignored silently."""
    writes = [flag for attr, flag in WRITTEN_HERE if getattr(args, attr, None)]
    for attr, flag, where in SERVICE_FLAGS_REFUSED:
        if getattr(args, attr, None) and not (attr == "robot" and writes):
            raise ServiceError(f"identify --service: {flag} is not sent to the node; use {where}")
    if writes and not getattr(args, "robot", None):
        raise ServiceError(f"identify --service {writes[0]}: give --robot, the robot the node "
                           "identifies (the file is written here from the node's answer and that "
                           "description)")


def identify_service(args: argparse.Namespace) -> Any:
    """Call orthoglide/identify; the IdentifiedParameters of the answer. With ``--json FILE`` the
    answer's JSON (the node's orthoglide/identify/json, the same document as an offline run's);
    with ``--mjcf-out``/``--urdf-out FILE`` the identified robot written here from that JSON
    into ``--robot``'s description (:func:`write_identified`)."""
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    from std_msgs.msg import String

    from orthoglide_msgs.srv import Identify

    refuse_service_flags(args)
    robot = None
    if getattr(args, "mjcf_out", None) or getattr(args, "urdf_out", None):
        from orthoglide_ident.model.registry import load_robot_from_args

        robot = load_robot_from_args(args)  # a bad robot: refused before the node works
    want_json = bool(args.json) or robot is not None
    docs: list = []
    with Client(args.namespace) as c:
        if want_json:  # subscribed before the call: the answer's JSON cannot pass unseen
            qos = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                             reliability=ReliabilityPolicy.RELIABLE)
            c.node.create_subscription(String, "orthoglide/identify/json",
                                       lambda m: docs.append(json.loads(m.data)), qos)
        res = c.call(Identify, "orthoglide/identify", timeout=600.0, bags=list(args.bags or []),
                     payload_mass=float(args.payload_mass or 0.0), method=args.method or "",
                     essential=bool(args.essential))
        if res.success and want_json:
            stamp = {"sec": res.parameters.header.stamp.sec,
                     "nanosec": res.parameters.header.stamp.nanosec}
            doc = _wait_for(c, docs, lambda d: d.get("stamp") == stamp, JSON_WAIT_S)
            if doc is None:
                raise ServiceError("the node answered but published no JSON on "
                                   "orthoglide/identify/json: is it an older identification node?")
    if not res.success:
        raise ServiceError(res.message)
    print(res.message)
    if args.json:
        _write_json(args.json, doc["result"])
    if robot is not None:
        write_identified(args, robot, doc["result"])
    return res.parameters


def write_identified(args: argparse.Namespace, robot: Any, result: dict) -> None:
    """``--mjcf-out`` / ``--urdf-out`` from the node's answer (``identify --json``'s document):
    its consistent standard parameters and drive gains in ``robot``'s description."""
    from orthoglide_ident.model.mjcf_out import answer_of_json, write_mjcf

    for attr, flag in WRITTEN_HERE:
        path = getattr(args, attr, None)
        if not path:
            continue
        chi, gains = answer_of_json(result, robot, f"identify --service {flag}")
        if attr == "mjcf_out":
            notes = write_mjcf(path, robot, chi, gains)
        else:
            notes = []
            try:
                Path(path).write_text(robot.identified_urdf(chi, gains))
            except OSError as exc:
                raise ServiceError(f"cannot write {path}: {exc.strerror or exc}") from None
        print(f"orthoglide-ident: wrote {path} (the node's consistent parameters)"
              + "".join(f"; {n}" for n in notes), file=sys.stderr)


def _wait_for(c: Client, got: list, match: Any, timeout: float) -> Any | None:
    """The first of ``got`` (filled by a subscription) that ``match``es, spinning until then."""
    t_end = time.monotonic() + timeout
    while time.monotonic() < t_end:
        hit = next((d for d in got if match(d)), None)
        if hit is not None:
            return hit
        c.rclpy.spin_once(c.node, timeout_sec=0.1)
    return None


def _write_json(path: str, doc: Any) -> None:
    from orthoglide_ident.results import json_text

    try:
        Path(path).write_text(json_text(doc))
    except OSError as exc:
        raise ServiceError(f"cannot write {path}: {exc.strerror or exc}") from None


def status_line(m: Any) -> str:
    """orthoglide/recorder/status in one line."""
    what = f"recording {m.condition}" if m.recording else f"idle (last: {m.condition or 'none'})"
    mass = f", {m.payload_mass:g} kg" if m.condition == "loaded" else ""
    return (f"recorder: {what}{mass} {m.bag_path} | {m.ticks_written} ticks, "
            f"{m.ticks_missing} missing | {m.message}")


def live_line(m: Any) -> str:
    """orthoglide/identification/live in one line."""
    units = list(getattr(m, "gain_units", [])) or ["N/A"] * len(m.drive_gains)
    gains = "gains -" if not m.drive_gains else "  ".join(
        f"{n} {g:8.5g} {u} ±{100 * s:.2f}%"  # a motor's 0.41704 N·m/A too
        for n, g, s, u in zip(m.joint_names, m.drive_gains, m.drive_gains_rel_std, units))
    line = (f"live: {m.unloaded_seconds:.0f} s unloaded, {m.loaded_seconds:.0f} s loaded | "
            f"{gains} | {m.status}")
    return line + "".join(f"\n  warning: {w}" for w in m.warnings)


def watch(args: argparse.Namespace) -> int:
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

    from orthoglide_msgs.msg import LiveIdentification, RecorderStatus

    latched = QoSProfile(
        depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL, reliability=ReliabilityPolicy.RELIABLE
    )
    with Client(args.namespace) as c:
        c.node.create_subscription(RecorderStatus, "orthoglide/recorder/status",
                                   lambda m: print(status_line(m), flush=True), latched)
        c.node.create_subscription(LiveIdentification, "orthoglide/identification/live",
                                   lambda m: print(live_line(m), flush=True), 10)
        t_end = time.monotonic() + args.seconds if args.seconds > 0 else None
        while t_end is None or time.monotonic() < t_end:
            c.rclpy.spin_once(c.node, timeout_sec=0.1)
    return 0
