"""CTC node: the identified model's feed-forward for every setpoint tick (paper Sect. 5.2).

    ros2 run orthoglide_ident ctc [--ros-args --params-file config/ctc.yaml]
"""
from __future__ import annotations

import sys
import threading
import time

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import JointState
from trajectory_msgs.msg import JointTrajectory

from orthoglide_ident.control import CTCParameters, feedforward_currents
from orthoglide_ident.errors import OrthoglideError
from orthoglide_ident.feedforward_schedule import FeedforwardSchedule, LeadStats
from orthoglide_ident.model.registry import load_robot
from orthoglide_ident.model.robot import RobotModel
from orthoglide_ident.nodes._jtc import TrajectoryOutlet
from orthoglide_ident.ros.batch import BatchTaker, BatchTopic, real_time_thread
from orthoglide_ident.ros.params import Param, declare, usage
from orthoglide_ident.ros.spin import spin
from orthoglide_msgs.msg import CurrentReference, IdentifiedParameters, JointSetpoint

DOC = """\
Computed torque control (Briot & Gautier 2013, Sect. 5.2) of the Orthoglide or any robot the
identification knows (robot parameter), split as robot controllers are: this node computes the
model part, the controller keeps its linear part.

For every setpoint tick k on orthoglide/setpoints (orthoglide_msgs/JointSetpoint, published ahead of
its tick by the controller) it publishes on orthoglide/feedforward the current
    v_ff[k] = (W_b chi_b + W_kl m_7)(reference in the middle of tick k) / g_tau      (eqs. 29, 17)
(orthoglide_msgs/CurrentReference, A, header.stamp = tick k), with the base parameters chi_b and
drive gains g_tau of orthoglide/identified_parameters (transient local, the identification node's
result). The controller (the driver with controller:=ctc) adds v_ff[k] to its PID with velocity
feed-forward at tick k, so transport delay does not enter the loop: the feed-forward is computed
as soon as batch ticks are ready, or at once when a tick is due within 2 x margin_ms
(feedforward_schedule.py), tens of ms before it is needed. A tick sent less than margin_ms ahead
makes the node say that it is falling behind and why (its setpoint came late, or it waited in
this node: a busy machine), once, then at most every 10 s. Every 10 s the log states the ticks
sent, their lead and the node's own CPU, and once a second /diagnostics (diagnostic_msgs, as the
driver's) carries the same: ticks_sent, short, late, dropped since start, lead_min_ms,
lead_median_ms and cpu_percent over the last second; on the way out one line sums up the run.
The intake wakes at least every margin_ms, so ready ticks go out as they near even when no
setpoint follows them. Until parameters arrive nothing is published (the setpoints are not
even decoded), and the log says so; new parameters replace the old ones at once. Feed-forward
currents are clipped to
current_limit; a non-finite one stops the output with an error until new parameters arrive.
With monitor true it also pairs orthoglide/joint_states with the setpoints and logs the tracking
error every 5 s. Names are relative: -r __ns:=/robot2 moves the whole interface.

Next to ros2_control (trajectory_topic, e.g. joint_trajectory_controller/joint_trajectory): the
setpoints also go to a joint_trajectory_controller whose only command interface is effort, as
trajectory_msgs/JointTrajectory points (q_d, qd_d, qdd_d) whose effort is the feed-forward in the
controller's units (trajectory_effort); the JTC adds it to its PID (README "Next to ros2_control").

A robot with a transmission (docs/guide/robot_files.md "Transmissions": identified in actuator
space):
the setpoints are the joints', the feed-forward one current per motor, v_m = diag(g)⁻¹ N⁻ᵀ τ_j
plus the motors' own inertia and friction, clipped to current_limit per motor and published
under the motors' names; the trajectory points' efforts are joint-side, Nᵀ (scale x v_m), which
the hardware's transmission turns back into the motors' (the four-bar linkage: see
model/transmission.py)."""

PARAMETERS = (
    Param(
        "robot",
        "",
        "the robot: a URDF, a robot YAML or a bundled robot's name, as the "
        "identification node's; empty: the Orthoglide",
    ),
    Param(
        "payload_mass",
        -1.0,
        "kg put in the model (the paper: the nominal weighed mass); < 0: the "
        "identified parameters' payload_mass",
    ),
    Param(
        "batch",
        10,
        "setpoint ticks per feed-forward computation (one vectorised model call); "
        "fewer when a tick is due within 2 x margin_ms. More ticks share the call's fixed cost "
        "but wait longer: 20 cut the node's CPU from 20-22 to 17-18 % of a core in make demo, "
        "and its first tick's lead from ~40 to ~30 ms (less room for a busy machine)",
    ),
    Param(
        "margin_ms",
        10.0,
        "ms: ready ticks are computed at once when one is due within twice this; a "
        "feed-forward sent later than this before its tick is reported (falling behind)",
    ),
    Param(
        "rt_priority",
        30,
        "SCHED_FIFO priority (1-99) of the thread that takes the setpoints and "
        "sends the feed-forward, below the controller's (the simulated driver's 40), so that a "
        "busy machine does not make it late; the node's other Python threads run one below it "
        "(none holds Python's lock off a core while the intake waits for it); 0: ordinary "
        "scheduling",
    ),
    Param(
        "current_limit",
        [1.0],
        "A per joint, per motor for a robot with a transmission (one "
        "number: every one): feed-forward currents are clipped to it",
    ),
    Param(
        "monitor",
        False,
        "log the tracking error (joint states vs setpoints) every 5 s (one more 1 kHz "
        "subscription)",
    ),
    Param(
        "consistent",
        False,
        "use the physically consistent set (orthoglide/identified_parameters/"
        "consistent: real bodies identified under the constraints, the identification node's "
        "option "
        ""
        ""
        ""
        ""
        "consistent) instead of the unconstrained base parameters",
    ),
    Param(
        "trajectory_topic",
        "",
        "also send the setpoints to a joint_trajectory_controller as "
        "trajectory_msgs/JointTrajectory with effort = the feed-forward, e.g. "
        "joint_trajectory_controller/joint_trajectory; empty: not sent",
    ),
    Param(
        "trajectory_effort",
        "nominal",
        "the points' effort: nominal (v_ff x nominal gain, N·m or N: what "
        "the hardware turns into the model's current), torque (v_ff x identified gain, the model's "
        "torque) or current (v_ff, A)",
    ),
    Param(
        "trajectory_overlap",
        100,
        "ticks already sent repeated at the start of each trajectory message, "
        "so that it starts before the controller's now (more than setpoint_lead)",
    ),
)
MONITOR_PERIOD_NS = 5_000_000_000
REPORT_PERIOD_S = 10.0  # the feed-forward lead and the node's CPU are logged this often
DIAGNOSTICS_PERIOD_S = 1.0  # ... and published on /diagnostics this often


def _stamp_ns(msg) -> int:
    return msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec


def check_current_limit(value, robot: RobotModel) -> np.ndarray:
    """The current_limit parameter as one limit per joint of ``robot`` (A); OrthoglideError with
    the reason unless it is one positive current or one per joint."""
    limit = np.asarray(value, float)
    n_j = robot.n_joints
    if limit.shape not in ((1,), (n_j,)) or not np.all(limit > 0):
        raise OrthoglideError(f"parameter current_limit: one positive current (A) or {n_j} "
                              f"({', '.join(robot.joint_names)}), got {value}")
    return np.broadcast_to(limit, (n_j,))


class CTCNode(Node):
    """Identified parameters + setpoints -> feed-forward currents stamped for their tick."""

    def __init__(self) -> None:
        super().__init__("orthoglide_ctc")
        v = declare(self, PARAMETERS)
        if v["batch"] < 1:
            raise OrthoglideError(f"parameter batch: must be >= 1, got {v['batch']}")
        if not v["margin_ms"] >= 0:
            raise OrthoglideError(f"parameter margin_ms: must be >= 0, got {v['margin_ms']}")
        if not 0 <= v["rt_priority"] <= 99:
            raise OrthoglideError(f"parameter rt_priority: 0 (off) or 1-99, got {v['rt_priority']}")
        self.payload_mass = v["payload_mass"]
        self.schedule = FeedforwardSchedule(v["batch"], int(v["margin_ms"] * 1e6))
        # wall, CPU
        self._started = self._report_at = self._diag_at = (time.monotonic(), time.process_time())
        self._window = LeadStats()  # the seconds since the last log line
        self.robot = load_robot(v["robot"])
        t = self.robot.transmission  # setpoints are the joints', currents the motors' (issue 33)
        self.joints = list(self.robot.joint_names if t is None else t.joints)
        self.motors = list(self.robot.joint_names)
        self.current_limit = check_current_limit(v["current_limit"], self.robot)
        self.model: CTCParameters | None = None
        self.stopped: str | None = None
        self.published = self.clipped = 0
        latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                             reliability=ReliabilityPolicy.RELIABLE)
        stream = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
        self.params_topic = "orthoglide/identified_parameters" + (
            "/consistent" if v["consistent"] else "")
        self.create_subscription(IdentifiedParameters, self.params_topic, self.on_params, latched)
        self.pub = self.create_publisher(CurrentReference, "orthoglide/feedforward", stream)
        self.pub_diag = self.create_publisher(DiagnosticArray, "/diagnostics", 10)
        self.monitor = TrackingMonitor(self, self.robot) if v["monitor"] else None
        self.outlet = None  # to a joint_trajectory_controller (nodes._jtc)
        if v["trajectory_topic"]:
            self.outlet = TrajectoryOutlet(
                self.joints,
                v["trajectory_effort"],
                self.robot.nominal_gains,
                v["trajectory_overlap"],
                None if t is None else t.to_joint_effort,
            )
            self.pub_traj = self.create_publisher(JointTrajectory, v["trajectory_topic"], 10)
        if v["rt_priority"] > 1:  # this thread's later ones too (the executor's, ros.spin)
            # every Python thread of the node just below the intake: a thread holding Python's
            # lock (the GIL) while the busy machine keeps it off a core held the intake waiting
            # 48-73 ms in make demo beside a hog (priority inversion); its refusal is said below
            real_time_thread(v["rt_priority"] - 1)
        # last: the taker's thread calls on_setpoints at once, which needs everything above
        self.taker = BatchTaker(
            self,
            [BatchTopic(JointSetpoint, "orthoglide/setpoints", stream, self.on_setpoints)],
            rt_priority=v["rt_priority"],
            on_wake=self.on_wake,
            wake_s=max(v["margin_ms"], 1.0) * 1e-3,
        )
        self.get_logger().info(f"waiting for {self.resolve_topic_name(self.params_topic)} "
                               "(no feed-forward until they arrive)")

    def on_params(self, msg: IdentifiedParameters) -> None:
        fields = {"names": msg.names, "values": msg.values, "drive_gains": msg.drive_gains,
                  "payload_mass": msg.payload_mass}
        try:
            model = CTCParameters.from_message_fields(
                fields, None if self.payload_mass < 0 else self.payload_mass, model=self.robot)
        except OrthoglideError as e:
            state = "keeping the previous ones" if self.model else "still waiting"
            self.get_logger().error(f"identified parameters rejected, {state}: {e}")
            return
        self.model, self.stopped = model, None
        gains = ", ".join(f"{n} {g:.5g}" for n, g in zip(self.motors, model.drive_gains))
        units = "/".join(dict.fromkeys(self.robot.gain_units))
        self.get_logger().info(f"parameters in ({msg.method}): drive gains [{gains}] {units}, "
                               f"{len(model.names)} base parameters, payload "
                               f"{model.payload_mass:.4g} kg")

    def on_setpoints(self, batch: list) -> None:
        """A batch of serialized setpoints (taken together, see ros.batch)."""
        if self.model is None and self.monitor is None:  # nothing to compute: not even decoded
            self.get_logger().warning("no identified parameters yet: no feed-forward published",
                                      throttle_duration_sec=10.0)
            return
        for raw, received_ns, _ in batch:
            msg = deserialize_message(raw, JointSetpoint)
            try:
                idx = [list(msg.name).index(j) for j in self.joints]
            except ValueError:
                self.get_logger().warning(f"setpoint without joints {', '.join(self.joints)}: "
                                          f"{list(msg.name)}", throttle_duration_sec=5.0)
                continue
            stamp = _stamp_ns(msg)
            sp = np.array([[msg.position[i] for i in idx], [msg.velocity[i] for i in idx],
                           [msg.acceleration[i] for i in idx]])
            self.schedule.add(stamp, sp, received_ns)
            if self.monitor is not None:
                self.monitor.setpoint(stamp, sp[0])

    def on_wake(self) -> None:
        """After every wake-up of the intake (at least every margin_ms): the ticks now due
        (a tick nearing with fewer than batch ready still goes out, setpoints or not)."""
        if self.schedule.pending() > 1:
            self.flush()
        self._report()

    def close(self) -> None:
        self.taker.close()
        self.get_logger().info(self.summary())

    def flush(self) -> None:
        """Feed-forward of the runs of ticks the schedule says are due (feedforward_schedule.py),
        each one vectorised model call; nothing while there are no (valid) parameters."""
        runs = self.schedule.take(time.time_ns())
        if self.model is None:
            if runs:
                self.get_logger().warning("no identified parameters yet: no feed-forward published",
                                          throttle_duration_sec=10.0)
            return
        for run in runs:
            if self.stopped:
                return
            ref = run.ref  # (n + 1, 3, n_j): q_d, qd_d, qdd_d
            if not np.all(np.isfinite(ref)):  # the model refuses it; stop rather than guess
                bad = np.flatnonzero(~np.isfinite(ref).all(axis=(1, 2)))[0]
                self._stop(f"non-finite feed-forward: setpoint at stamp "
                           f"{int(run.stamps[min(bad, len(run.stamps) - 1)])} is not finite")
                return
            self._publish(
                run.stamps,
                feedforward_currents(ref[:, 0], ref[:, 1], ref[:, 2], self.model),
                ref[:-1],
            )
            behind = self.schedule.sent(run.stamps, time.time_ns())
            if behind:
                self.get_logger().warning(behind)

    def _report(self) -> None:
        """Every DIAGNOSTICS_PERIOD_S the figures on /diagnostics; every REPORT_PERIOD_S a log
        line: the feed-forward sent, its lead, and this process's CPU."""
        wall, cpu = time.monotonic(), time.process_time()
        if wall - self._diag_at[0] < DIAGNOSTICS_PERIOD_S:
            return
        share = (cpu - self._diag_at[1]) / (wall - self._diag_at[0])
        self._diag_at = (wall, cpu)
        stats = self.schedule.reset_stats()
        self._window.merge(stats)
        self._publish_diagnostics(stats, share)
        if wall - self._report_at[0] < REPORT_PERIOD_S:
            return
        share = (cpu - self._report_at[1]) / (wall - self._report_at[0])
        self._report_at, window, self._window = (wall, cpu), self._window, LeadStats()
        if window.sent or window.dropped:
            self.get_logger().info(
                f"feed-forward over {REPORT_PERIOD_S:.0f} s: {window.summary()}; "
                f"ctc CPU {100 * share:.0f} % of a core"
            )

    def _publish_diagnostics(self, stats: LeadStats, cpu_share: float) -> None:
        """The last second's figures (lead, CPU) and the counts since start, as robot drivers
        publish theirs (rqt_robot_monitor, Foxglove; the demo reads them)."""
        total, lead = self.schedule.total, stats.lead_ms()
        values = {"ticks_sent": total.sent, "short": total.short, "late": total.late,
                  "dropped": total.dropped, "cpu_percent": f"{100 * cpu_share:.1f}",
                  "lead_min_ms": "" if lead is None else f"{lead[0]:.2f}",
                  "lead_median_ms": "" if lead is None else f"{lead[1]:.2f}"}
        status = DiagnosticStatus(
            level=DiagnosticStatus.WARN if stats.short else DiagnosticStatus.OK,
            name=f"{self.get_fully_qualified_name()}: feed-forward",
            hardware_id="orthoglide_ctc",
            message=stats.summary(),
            values=[KeyValue(key=k, value=str(v)) for k, v in values.items()],
        )
        msg = DiagnosticArray(status=[status])
        msg.header.stamp = self.get_clock().now().to_msg()
        self.pub_diag.publish(msg)

    def summary(self) -> str:
        """The whole run: what was sent, its lead, and the node's CPU."""
        wall, cpu = time.monotonic() - self._started[0], time.process_time() - self._started[1]
        return (
            f"ctc: {self.schedule.total.summary()} in {wall:.0f} s; ctc CPU "
            f"{100 * cpu / max(wall, 1e-9):.0f} % "
            "of a core"
        )

    def _stop(self, reason: str) -> None:
        self.stopped = reason
        self.get_logger().error(f"stopped: {reason}; waiting for new identified parameters")

    def _publish(self, stamps: np.ndarray, v_ff: np.ndarray, ref: np.ndarray) -> None:
        if not np.all(np.isfinite(v_ff)):
            self._stop(f"non-finite feed-forward at stamp {stamps[0]}")
            return
        clipped = np.clip(v_ff, -self.current_limit, self.current_limit)
        n_clip = int(np.sum(np.any(clipped != v_ff, axis=1)))
        if n_clip:
            self.clipped += n_clip
            self.get_logger().warning(
                f"feed-forward beyond current_limit clipped ({self.clipped} ticks so far)",
                throttle_duration_sec=5.0,
            )
        for stamp, v in zip(stamps, clipped):
            msg = CurrentReference(name=self.motors, current=[float(x) for x in v])
            msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(int(stamp), 1_000_000_000)
            self.pub.publish(msg)
        self.published += len(stamps)
        if self.outlet is not None:
            raw = self.outlet.message(stamps, ref, clipped, self.model.drive_gains)
            if raw is not None:
                self.pub_traj.publish(raw)


class TrackingMonitor:
    """Joint states vs setpoints of the same stamp: rms and max error per joint every 5 s.

    The joint states are taken by name, on the side the robot's transmission publishes them
    (position_side actuator: the motors' positions, brought to the joints, q_j = N⁻¹ (q_m −
    offset); model/transmission.py)."""

    def __init__(self, node: Node, robot: RobotModel) -> None:
        self.node = node
        t = robot.transmission
        motors = t is not None and t.position_side == "actuator"
        self.channels = list(
            robot.joint_names if t is None else t.actuators if motors else t.joints
        )
        self.to_joint = t.to_joint_position if motors else None
        # setpoints come from the batch thread, joint states from the executor
        self.lock = threading.Lock()
        self.setpoints: dict[int, np.ndarray] = {}
        self.errors: list[np.ndarray] = []
        self.t_last = None
        node.create_subscription(JointState, "orthoglide/joint_states", self.joint_state,
                                 QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE))

    def setpoint(self, stamp: int, q_d: np.ndarray) -> None:
        with self.lock:
            self.setpoints[stamp] = q_d
            if len(self.setpoints) > 5000:
                for s in sorted(self.setpoints)[:1000]:
                    del self.setpoints[s]

    def joint_state(self, msg: JointState) -> None:
        stamp = _stamp_ns(msg)
        with self.lock:
            q_d = self.setpoints.pop(stamp, None)
        if q_d is None:
            return
        try:
            q = np.array([msg.position[list(msg.name).index(c)] for c in self.channels])
        except (ValueError, IndexError):
            self.node.get_logger().warning(f"joint states without {', '.join(self.channels)}: "
                                           f"{list(msg.name)}", throttle_duration_sec=5.0)
            return
        self.errors.append((q if self.to_joint is None else self.to_joint(q)) - q_d)
        self.t_last = self.t_last or stamp
        if stamp - self.t_last >= MONITOR_PERIOD_NS:
            e = np.array(self.errors) * 1e6
            rms, mx = np.sqrt(np.mean(e**2, axis=0)), np.abs(e).max(axis=0)
            self.node.get_logger().info(
                f"tracking error over {len(e) / 1000:.1f} s: rms "
                f"{' / '.join(f'{x:.1f}' for x in rms)} um, max "
                f"{' / '.join(f'{x:.1f}' for x in mx)} um")
            self.errors, self.t_last = [], stamp


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv if argv is None else argv
    if any(a in ("-h", "--help") for a in argv[1:]):
        print(
            usage(
                "usage: ros2 run orthoglide_ident ctc [--ros-args -p NAME:=VALUE ... | "
                "--params-file "
                "config/ctc.yaml]",
                DOC,
                PARAMETERS,
            )
        )
        return 0
    return spin(CTCNode, argv, "ctc")


if __name__ == "__main__":
    sys.exit(main())
