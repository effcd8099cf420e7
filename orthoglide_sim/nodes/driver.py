"""Driver node: the simulated Orthoglide and its 1 kHz controller (`ros2 run orthoglide_ident
driver`)."""

from __future__ import annotations

import gc
import sys
import threading
import time

from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_srvs.srv import Trigger

from orthoglide_ident.errors import OrthoglideError
from orthoglide_ident.model.orthoglide.geometry import JOINT_NAMES
from orthoglide_ident.ros.batch import BatchTaker, BatchTopic
from orthoglide_ident.ros.params import Param, declare, from_command_line, on_set, usage
from orthoglide_ident.ros.spin import spin
from orthoglide_msgs.msg import CurrentReference, JointSetpoint
from orthoglide_sim.common.packed_messages import PackedMessage
from orthoglide_sim.common.tick_clock import LATE_NS, TICK_NS, real_time_priority, sleep_until
from orthoglide_sim.common.ticks_ahead import TicksAhead
from orthoglide_sim.orthoglide.session import FF_HOLD_TICKS, DriverSession
from orthoglide_sim.orthoglide.truth import load_parameters

DOC = """\
The simulated Orthoglide (orthoglide_sim: Pinocchio closed-loop plant, 1 um encoder, current noise)
and its 1 kHz controller. Every tick k it publishes, with header.stamp = t_k:
  orthoglide/joint_states       sensor_msgs/JointState (q11..q13, position m)
  orthoglide/current_reference  orthoglide_msgs/CurrentReference (q11..q13, current A) applied over
  the tick
and, setpoint_lead ticks ahead (stamp = the tick it is for):
  orthoglide/setpoints          orthoglide_msgs/JointSetpoint (q_d, qd_d, qdd_d of the tracked
  reference)
Inputs: orthoglide/feedforward (CurrentReference stamped for the tick it is for; controller ctc adds
it
to its PID with velocity feed-forward) and orthoglide/current_command (CurrentReference stamped with
the joint state it was computed from; controller external applies the latest from the next tick, and
holds the robot with its own PID until the first command and whenever commands stop for 0.1 s).
Every current is clipped to current_limit. A non-finite input, or the robot leaving its stroke,
stops the simulated robot with an error in the log; call orthoglide_driver/reset (std_srvs/Trigger)
to put it back on its reference. Names are relative: -r __ns:=/robot2 moves the whole interface.
Once a second it publishes its counters on /diagnostics (diagnostic_msgs/DiagnosticArray, as
robot drivers do): ticks, late ticks, current-limited ticks, fresh and missing feed-forwards,
commands applied and ticks without one, the fault if any. A ctc tick whose own feed-forward has
not arrived holds the last one for 20 ticks at most, then runs on PID + velocity feed-forward
alone (feedforward_expired) until a fresh one comes.
In real time the simulated robot computes its ticks up to 10 at a time ahead of their deadlines
wherever their inputs are known (pid, pid_ff; ctc once the tick's feed-forward is in; never
external) and publishes each at its deadline: a parameter change or a reset reaches the plant at
the first tick not yet computed, within 10 ms, and setpoints go out setpoint_lead to
setpoint_lead + 10 ticks ahead (orthoglide_sim/common/ticks_ahead.py)."""

PARAMETERS = (
    Param(
        "robot",
        "",
        "empty or orthoglide: this driver; another robot (ur5, a robot YAML or a URDF): the "
        "ros2_control stand-in instead (ros2 run orthoglide_ident driver --ros-args -p robot:=ur5 "
        "--help)",
    ),
    Param(
        "payload",
        "none",
        "payload on the platform: none, 1.983, 1.136 or a mass in kg; set it while "
        "running to mount or remove one",
        dynamic=True,
        any_type=True,
    ),
    Param(
        "trajectory",
        "exciting",
        "reference: exciting, exciting2, test1, test2 or a .json Fourier file; a "
        "change blends in over 2 s",
        dynamic=True,
    ),
    Param(
        "controller",
        "pid",
        "pid | pid_ff (velocity feed-forward) | ctc (pid_ff + orthoglide/feedforward) | "
        "external (orthoglide/current_command)",
        dynamic=True,
    ),
    Param(
        "current_limit",
        [1.0, 1.0, 1.0],
        "A per joint (one or three values): every current is clipped to it",
        dynamic=True,
    ),
    Param(
        "setpoint_lead",
        50,
        "ticks: orthoglide/setpoints are published this far ahead of their tick",
    ),
    Param("duration", 0.0, "s to run, 0 = until shut down"),
    Param(
        "realtime",
        True,
        "false: simulated time as fast as the plant runs, /clock published; ctc and "
        "external then wait for their input of each tick (lockstep)",
    ),
    Param("params_file", "", "YAML overriding the true plant parameters (config/plant.yaml)"),
    Param(
        "plant",
        "reduced",
        "the plant's integration: reduced (Pinocchio reduced to the 3 actuators once per "
        "tick, RK4 compiled: ~1/8 of the CPU) or tree (the reference: Pinocchio's constraint "
        "dynamics on the "
        "15-joint tree at every RK4 stage); they agree to 0.04 um and 0.02 mA "
        "(tests/sim/orthoglide/test_plant_cheap.py)",
    ),
    Param(
        "rt_priority",
        40,
        "SCHED_FIFO priority of the tick loop (1-99), as robot controllers run; 0: "
        "normal scheduling. Needs CAP_SYS_NICE or an rtprio limit; without it the driver says so "
        "and goes on",
    ),
    Param("seed", 0, "seed of the current noise"),
    Param("noise", True, "current noise on/off"),
)
# the interface (docs/design/interfaces.md); the plant keeps its own truth
JOINTS = list(JOINT_NAMES)
LOCKSTEP_TIMEOUT_S = 2.0
STATUS_PERIOD_TICKS = 10_000  # a log line
HISTORY_TICKS = 5000  # 5 s of ticks kept for resending to a subscriber that fell behind
SUBSCRIBER_WAIT_S = 10.0  # simulated time: the first tick waits this long at most for a subscriber
ACK_WAIT_S = 4.0  # on the way out, wait this long at most for subscribers to have every tick (Fast
# DDS asks for acknowledgements with its heartbeat, every 3 s by default: 0 to 3 s here)
DIAGNOSTICS_PERIOD_TICKS = 1_000  # a /diagnostics message


def _usage() -> str:
    return usage(
        "usage: ros2 run orthoglide_ident driver [--ros-args -p NAME:=VALUE ...]", DOC, PARAMETERS
    )


class Driver(Node):
    """ROS side of the driver: parameters, topics and the tick loop around a DriverSession."""

    def __init__(self) -> None:
        super().__init__("orthoglide_driver")
        v = declare(self, PARAMETERS)
        self.realtime, self.duration, self.rt_priority = (
            v["realtime"],
            v["duration"],
            v["rt_priority"],
        )
        self.session = DriverSession(
            v["payload"],
            v["trajectory"],
            v["controller"],
            load_parameters(v["params_file"] or None),
            v["seed"],
            v["noise"],
            v["current_limit"],
            v["setpoint_lead"],
            v["plant"],
        )
        self.ahead = TicksAhead(self.session)
        self.lock = threading.Condition()
        self.finished = False
        self.late = 0
        self.start_ns = 0
        self.k = 0  # the next tick to publish (the session may have computed further: self.ahead)
        self._said_fault = False
        self._periodic_at = 0  # self.k at the last status line / diagnostics check
        # reliable, keep last HISTORY_TICKS: a subscriber starved of CPU (or stopped) for a moment
        # gets the ticks its DDS reader missed resent from this history (depth 100 lost ~280 on a
        # 0.5 s stall; a history shorter than the stall loses the oldest ticks of it)
        self.pub_js = self.create_publisher(JointState, "orthoglide/joint_states", HISTORY_TICKS)
        self.pub_cr = self.create_publisher(
            CurrentReference, "orthoglide/current_reference", HISTORY_TICKS
        )
        self.pub_sp = self.create_publisher(JointSetpoint, "orthoglide/setpoints", HISTORY_TICKS)
        self.pub_clock = None if self.realtime else self.create_publisher(Clock, "/clock", 10)
        self.pub_diag = self.create_publisher(DiagnosticArray, "/diagnostics", 10)
        # the per-tick messages serialised once, their stamps and values patched in each tick
        self.packed_js = PackedMessage(JointState, JOINTS, ["position"])
        self.packed_cr = PackedMessage(CurrentReference, JOINTS, ["current"])
        self.packed_sp = PackedMessage(
            JointSetpoint, JOINTS, ["position", "velocity", "acceleration"]
        )
        inputs = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
        # taken in batches on a thread of their own, not one executor callback per message: less
        # CPU and GIL taken from the tick loop (orthoglide_ident.ros.batch)
        self.taker = BatchTaker(
            self,
            [
                BatchTopic(
                    CurrentReference,
                    "orthoglide/current_command",
                    inputs,
                    lambda b: self._on_inputs(b, "command"),
                ),
                BatchTopic(
                    CurrentReference,
                    "orthoglide/feedforward",
                    inputs,
                    lambda b: self._on_inputs(b, "feed-forward"),
                ),
            ],
            period_s=0.0,
            # just below the tick loop: a feed-forward sent in time must not
            # wait for this thread behind the busy machine's processes
            rt_priority=self.rt_priority - 1 if self.realtime and self.rt_priority > 1 else 0,
        )
        self.create_service(Trigger, "~/reset", self._on_reset)
        on_set(self, PARAMETERS, self._apply)
        self.get_logger().info(
            f"controller {v['controller']}, payload {v['payload']}, trajectory {v['trajectory']}, "
            f"plant {v['plant']}, {'real time' if self.realtime else 'simulated time'}; publishing "
            f"{self.resolve_topic_name('orthoglide/joint_states')} at 1 kHz")

    # ---- inputs (executor thread) --------------------------------------------------------------
    def _tick_of(self, msg) -> int:
        stamp = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
        return round((stamp - self.start_ns) / TICK_NS)

    def _currents(self, msg, what: str):
        try:
            return (
                [msg.current[list(msg.name).index(j)] for j in JOINTS]
                if msg.name
                else list(msg.current)
            )
        except ValueError:
            self.get_logger().warning(
                f"ignored {what} without joints {', '.join(JOINTS)}: {list(msg.name)}",
                throttle_duration_sec=5.0,
            )
            return None

    def _on_inputs(self, batch: list, what: str) -> None:
        msgs = [deserialize_message(raw, CurrentReference) for raw, _, _ in batch]
        offer = self.session.offer_command if what == "command" else self.session.offer_feedforward
        with self.lock:
            for msg in msgs:
                current = self._currents(msg, what)
                if current is not None:
                    offer(self._tick_of(msg), current)
            self.lock.notify_all()

    def close(self) -> None:
        """On the way out, give reliable subscribers (the recorder) the last ticks: a publisher that
        vanishes takes the ticks it still had to resend with it."""
        self.taker.close()
        t_end = time.monotonic() + ACK_WAIT_S
        for pub in (self.pub_js, self.pub_cr, self.pub_sp):
            left = max(0.0, t_end - time.monotonic())
            try:
                acked = pub.wait_for_all_acked(Duration(nanoseconds=int(left * 1e9)))
            except Exception:  # noqa: BLE001 - shutting down already: nothing more to give
                return
            if not acked:
                self.get_logger().warning(
                    f"{pub.topic_name}: a subscriber had not received every tick "
                    f"{ACK_WAIT_S:g} s after the last one (stopped or too slow)"
                )

    def _apply(self, changes) -> None:
        with self.lock:
            s = self.session
            for name, value in changes.items():
                if name == "payload":
                    s.set_payload(value)
                elif name == "trajectory":
                    k = s.set_trajectory(value)
                    self.get_logger().info(f"trajectory {value} blends in from tick {k}")
                elif name == "controller":
                    s.set_controller(value)
                elif name == "current_limit":
                    s.set_current_limit(value)
                self.get_logger().info(f"{name} set to {value}")

    def _on_reset(self, request, response):
        with self.lock:
            was = self.session.fault
            if was and self.ahead.ticks:  # computed ahead: the ticks before it are not out yet
                response.success = False
                response.message = (
                    f"the robot stops at a tick {len(self.ahead.ticks)} ms from now ({was}): "
                    "call reset again once it has"
                )
                return response
            self.session.reset()
        response.success = True
        response.message = (
            f"robot back on its reference (was stopped: {was})" if was else "no fault to clear"
        )
        self.get_logger().info(response.message)
        return response

    # ---- the tick loop (main thread) -----------------------------------------------------------
    def _publish_js(self, k: int, q) -> None:
        self.pub_js.publish(self.packed_js.pack(*self._sec_nsec(k), q))

    def _wait_for_input_publisher(self, stop: threading.Event) -> None:
        """Simulated time: the first tick waits (SUBSCRIBER_WAIT_S at most) until the joint
        states have a subscriber — a run faster than real time would otherwise be over before
        discovery — and, with an outside controller, until its input is there."""
        self._wait_for_subscriber(stop)
        topic = {"ctc": "orthoglide/feedforward", "external": "orthoglide/current_command"}.get(
            self.session.controller
        )
        if topic is None:
            return
        t_end = time.monotonic() + LOCKSTEP_TIMEOUT_S * 10
        while not self.count_publishers(topic) and time.monotonic() < t_end and not stop.is_set():
            stop.wait(0.05)
        if not self.count_publishers(topic):
            self.get_logger().warning(
                f"no publisher on {self.resolve_topic_name(topic)}: ticks go on without "
                f"their input after {LOCKSTEP_TIMEOUT_S} s each"
            )
        time.sleep(0.2)  # discovery of the way back (its subscription to our joint states)

    def _wait_for_subscriber(self, stop: threading.Event) -> None:
        t_end = time.monotonic() + SUBSCRIBER_WAIT_S
        while (not self.pub_js.get_subscription_count() and time.monotonic() < t_end
               and not stop.is_set()):
            stop.wait(0.05)
        if not self.pub_js.get_subscription_count():
            self.get_logger().warning(f"no subscriber on {self.pub_js.topic_name} after "
                                      f"{SUBSCRIBER_WAIT_S:g} s: simulating anyway")

    def _publish_setpoint(self, k: int, sp) -> None:
        self.pub_sp.publish(self.packed_sp.pack(*self._sec_nsec(k), *sp))

    def _sec_nsec(self, k: int) -> tuple[int, int]:
        return divmod(self.start_ns + k * TICK_NS, 1_000_000_000)

    def _stamp(self, k: int) -> Time:
        sec, nsec = self._sec_nsec(k)
        return Time(sec=sec, nanosec=nsec)

    def _wait_input(self, k: int) -> None:
        """Simulated time: hold tick k until its feed-forward / command is in (lockstep)."""
        s = self.session
        if s.controller == "ctc":
            ready = lambda: s.has_feedforward(k)  # noqa: E731
        elif s.controller == "external":
            ready = lambda: s.has_command_from(k)  # noqa: E731
        else:
            return
        self.lock.wait_for(ready, timeout=LOCKSTEP_TIMEOUT_S)

    def main_loop(self, stop: threading.Event) -> None:
        """Publish ticks at their deadlines (real time) or back to back (simulated time)."""
        n_ticks = round(self.duration * 1000) if self.duration > 0 else None
        s = self.session
        if self.realtime and self.rt_priority > 0:
            real_time_priority(self.rt_priority, self.get_logger(), "tick loop")
        if not self.realtime:  # before the setpoint horizon, which the outside controller needs
            self._wait_for_input_publisher(stop)
        margin = 5 * TICK_NS if self.realtime else 0  # tick 0 is due once the horizon is out
        self.start_ns = time.time_ns() + margin if self.realtime else 0
        self.t0 = time.monotonic_ns() + margin
        for k in range(s.lead):  # the setpoint horizon is complete from the first tick on
            self._publish_setpoint(k, s.setpoint(k))
        gc.collect()
        gc.freeze()  # what exists now is never scanned again: no collection pause in the loop
        t_end = None if n_ticks is None else self.t0 + n_ticks * TICK_NS
        while not stop.is_set() and (n_ticks is None or self.k < n_ticks):
            stopped = s.fault and not self.ahead.ticks  # the tick that stopped the plant is out
            if stopped and t_end is not None and (not self.realtime or time.monotonic_ns() > t_end):
                # a run of given duration ends when its time is up, or stopped in simulated time
                break
            if stopped:
                self._periodic()
                self._idle_in_fault(stop)
                continue
            if self.realtime:
                self._refill(n_ticks)
                sleep_until(self.t0 + self.k * TICK_NS)
            if not (self._tick_ahead() if self.realtime else self._tick()):
                break
        self.finished = True
        self._summary()

    def _refill(self, n_ticks: int | None) -> None:
        """Real time, once every tick computed is out: the next ticks whose inputs are in,
        computed now (TicksAhead), their setpoints published. The counters are exactly those of
        the published ticks here, so the periodic log and /diagnostics go out here."""
        if self.ahead.ticks:
            return
        self._periodic()
        with self.lock:
            self.ahead.refill(n_ticks)
        try:
            for k, sp in self.ahead.take_setpoints():
                self._publish_setpoint(k, sp)
        except Exception:
            if self.context.ok():
                raise  # a bug: the node ends with code 1 and the reason (ros.spin)

    def _tick_ahead(self) -> bool:
        """Real time: publish tick k at its deadline, computed ahead (or now, if its input came
        late: ctc and external)."""
        with self.lock:
            tick = self.ahead.take()
            setpoints = self.ahead.take_setpoints()
        if tick is None:  # an input refused since the loop looked: the robot is stopped
            return True
        if time.monotonic_ns() - (self.t0 + tick.k * TICK_NS) > LATE_NS:
            self.late += 1
        try:
            self._publish_js(tick.k, tick.q_meas)
            self.pub_cr.publish(self.packed_cr.pack(*self._sec_nsec(tick.k), tick.v_tau))
            for k, sp in setpoints:
                self._publish_setpoint(k, sp)
        except Exception:
            if self.context.ok():
                raise  # a bug: the node ends with code 1 and the reason (ros.spin)
            return False  # Ctrl-C shut the context down between the check and the publish
        self.k = tick.k + 1
        return True

    def _tick(self) -> bool:
        """One tick: measure, control, publish, integrate. In simulated time with an outside
        controller the tick waits for its input: external mode publishes the joint state first and
        waits for the command computed from it; ctc waits for the tick's feed-forward."""
        s = self.session
        lockstep_external = not self.realtime and s.controller == "external"
        with self.lock:
            k = s.k
            q = s.measure()
        try:
            if self.pub_clock is not None:
                self.pub_clock.publish(Clock(clock=self._stamp(k)))
            if lockstep_external:
                self._publish_js(k, q)
            with self.lock:
                if not self.realtime:
                    self._wait_input(k)
                v_tau = s.control(q)
                sp_k = k + s.lead
                sp = s.setpoint(sp_k)
            if self.realtime and time.monotonic_ns() - (self.t0 + k * TICK_NS) > LATE_NS:
                self.late += 1
            if not lockstep_external:
                self._publish_js(k, q)
            self.pub_cr.publish(self.packed_cr.pack(*self._sec_nsec(k), v_tau))
            self._publish_setpoint(sp_k, sp)
        except Exception:
            if self.context.ok():
                raise  # a bug: the node ends with code 1 and the reason (ros.spin)
            return False  # Ctrl-C shut the context down between the check and the publish
        with self.lock:
            s.advance()
        self.k = s.k if not s.fault else k + 1
        self._periodic()
        return True

    def _periodic(self) -> None:
        """The status line every STATUS_PERIOD_TICKS, /diagnostics every DIAGNOSTICS_PERIOD_TICKS
        published ticks, and the fault once, when the tick that stopped the plant is out."""
        k, last = self.k, self._periodic_at
        self._periodic_at = k
        if self.session.fault is not None and not self.ahead.ticks and not self._said_fault:
            self._said_fault = True
            self.get_logger().error(
                f"stopped: {self.session.fault}; call {self.get_name()}/reset to put "
                "the robot back on its reference"
            )
            self._publish_diagnostics()
            return
        if k // STATUS_PERIOD_TICKS > last // STATUS_PERIOD_TICKS:
            self.get_logger().info(self._status())
        if k // DIAGNOSTICS_PERIOD_TICKS > last // DIAGNOSTICS_PERIOD_TICKS:
            self._publish_diagnostics()

    def _publish_diagnostics(self) -> None:
        """The counters on /diagnostics (rqt_robot_monitor, Foxglove and the demo read them)."""
        s, st = self.session, self.session.stats
        values = {"ticks": self.k, "late": self.late, "current_limited": st.saturated,
                  "feedforward_fresh": st.ff_used, "feedforward_missing": st.ff_missing,
                  "feedforward_expired": st.ff_expired,
                  "commands_applied": sum(st.command_ages.values()), "no_command": st.no_command,
                  "controller": s.controller, "fault": s.fault or ""}
        level = DiagnosticStatus.ERROR if s.fault else (
            DiagnosticStatus.WARN if self.late > 0.01 * max(self.k, 1) else DiagnosticStatus.OK)
        status = DiagnosticStatus(
            level=level,
            name=f"{self.get_fully_qualified_name()}: tick loop",
            hardware_id="orthoglide_sim",
            message=s.fault or self._status(),
            values=[KeyValue(key=k, value=str(v)) for k, v in values.items()],
        )
        msg = DiagnosticArray(status=[status])
        msg.header.stamp = self.get_clock().now().to_msg()
        try:
            self.pub_diag.publish(msg)
        except Exception:  # shutting down
            pass

    def _idle_in_fault(self, stop: threading.Event) -> None:
        """The robot is stopped: wait for a reset, then go on from now (stamps keep their grid)."""
        stop.wait(0.05)
        if not self.session.fault:  # reset: the session goes on from the tick that stopped it
            self.k, self._said_fault = self.session.k, False
            self.t0 = time.monotonic_ns() - self.k * TICK_NS
            self.start_ns = time.time_ns() - self.k * TICK_NS

    def _status(self) -> str:
        st = self.session.stats
        text = f"{self.k} ticks, {self.late} late (> 0.5 ms), {st.saturated} current-limited"
        if st.ff_used or st.ff_missing:
            text += f", feed-forward: {st.ff_used} fresh, {st.ff_missing} missing (held)"
            if st.ff_expired:
                text += (
                    f", {st.ff_expired} of them more than {FF_HOLD_TICKS} ticks after the last "
                    "fresh one (PID + velocity feed-forward alone)"
                )
        if self.session.controller == "external" or st.command_ages:
            text += (f"; {st.age_summary()}; {st.no_command} ticks held by the PID without a "
                     "fresh command")
        return text

    def _summary(self) -> None:
        done = f"driver: {self._status()}"
        try:
            self.get_logger().info(done)
        except Exception:
            print(done, file=sys.stderr)


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv if argv is None else argv
    try:
        robot = from_command_line(argv, "robot", ("orthoglide_driver", "ros2_control_standin"))
    except OrthoglideError as e:
        print(f"driver: {e}", file=sys.stderr)
        return 2
    if str(robot or "").strip() not in ("", "orthoglide"):  # another robot: ros2_control's topics
        from orthoglide_sim.nodes import ros2_control as ros2_control_node

        return ros2_control_node.main(argv)
    if "-h" in argv or "--help" in argv:
        print(_usage())
        return 0
    sys.setswitchinterval(2e-4)  # the tick loop gets the GIL back within 0.2 ms of a callback
    return spin(Driver, argv, "driver")


if __name__ == "__main__":
    sys.exit(main())
