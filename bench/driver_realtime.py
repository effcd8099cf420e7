"""The simulated driver as a user meets it: time to first tick, plant cost, real time in every mode.

    .venv/bin/python bench/driver_realtime.py [--duration 60] [--starts 5]

1. time to first tick: `python -m orthoglide_sim.nodes.driver` spawned, until a subscriber in this
   process has received the first message on both orthoglide/joint_states and
   orthoglide/current_reference (median and worst of --starts starts);
2. plant step per tick (Pinocchio closed-loop dynamics, RK4, PID) p50/p99, in-process;
3. real-time factor of a batch record (orthoglide_sim.orthoglide.record.simulate, 10 s);
4. controller:=external for --duration s in real time, this process being the outside
   controller (PID with velocity feed-forward on orthoglide/setpoints, 40 rad/s): ticks
   published more than 0.5 ms after their deadline (the driver's count), arrival latency here, and
   the age of every applied command, found by matching each published current_reference with the
   command it applied (age 1 = the command computed from the previous tick's joint state).
Figures before this driver (jax plant): first tick 28-31 s, ~2 ms per external tick, 3999 of
4000 ticks late, commands applied a median 3 ticks late.
"""
from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import time

import numpy as np

from orthoglide_ident.ros import processes as children  # children end with this process

JOINTS = ["q11", "q12", "q13"]


def _stamp(msg) -> int:
    return msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec


def _spawn(params: list[str]) -> subprocess.Popen:
    args = [sys.executable, "-m", "orthoglide_sim.nodes.driver", "--ros-args"]
    for p in params:
        args += ["-p", p]
    return children.popen(args, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)


def time_to_first_tick(node, starts: int) -> list[float]:
    import rclpy
    from sensor_msgs.msg import JointState

    from orthoglide_msgs.msg import CurrentReference

    out = []
    for _ in range(starts):
        first: dict[str, float] = {}
        subs = [node.create_subscription(JointState, "/orthoglide/joint_states",
                                         lambda m: first.setdefault("js", time.monotonic()), 100),
                node.create_subscription(CurrentReference, "/orthoglide/current_reference",
                                         lambda m: first.setdefault("cr", time.monotonic()), 100)]
        t0 = time.monotonic()
        proc = _spawn(["duration:=1.5"])
        while len(first) < 2 and time.monotonic() - t0 < 60:
            rclpy.spin_once(node, timeout_sec=0.005)
        out.append(max(first.values()) - t0 if len(first) == 2 else float("nan"))
        proc.wait(timeout=30)
        for s in subs:
            node.destroy_subscription(s)
    return out


def plant_step_and_batch() -> tuple[np.ndarray, float]:
    from orthoglide_sim.orthoglide.record import simulate
    from orthoglide_sim.orthoglide.session import DriverSession

    s = DriverSession(controller="pid", payload="1.983")
    dt = []
    for _ in range(5000):
        t = time.perf_counter_ns()
        s.control(s.measure())
        s.advance()
        dt.append(time.perf_counter_ns() - t)
    t = time.perf_counter()
    simulate(10.0, payload="1.983", trajectory="exciting")
    return np.array(dt) / 1e6, 10.0 / (time.perf_counter() - t)


class ExternalController:
    """A PID with velocity feed-forward outside the driver: a command per joint state, stamped
    with it. Its bandwidth (default 40 rad/s, triple pole on 10 kg) is lower than the driver's own
    100 rad/s: a loop closed over DDS sees its commands one tick late or more, and the 100 rad/s
    loop has no margin for that (the reason the ctc node sends feed-forward, not commands)."""

    def __init__(self, node, omega: float = 40.0):
        from rclpy.qos import QoSProfile, ReliabilityPolicy
        from sensor_msgs.msg import JointState

        from orthoglide_msgs.msg import CurrentReference, JointSetpoint
        from orthoglide_sim.orthoglide import simulator as sm

        self.sm, self.CurrentReference = sm, CurrentReference
        qos = QoSProfile(depth=5000, reliability=ReliabilityPolicy.RELIABLE)
        from rclpy.serialization import deserialize_message

        from orthoglide_ident.ros.batch import BatchTaker, BatchTopic

        self.pub = node.create_publisher(CurrentReference, "/orthoglide/current_command", qos)

        def each(cls, handler):  # the node set's batch intake, woken by every message (period 0)
            return lambda batch: [handler(deserialize_message(raw, cls)) for raw, _, _ in batch]

        self.taker = BatchTaker(
            node,
            [
                BatchTopic(
                    JointSetpoint,
                    "/orthoglide/setpoints",
                    qos,
                    each(JointSetpoint, self.on_setpoint),
                ),
                BatchTopic(
                    JointState,
                    "/orthoglide/joint_states",
                    qos,
                    each(JointState, self.on_joint_state),
                ),
            ],
            period_s=0.0,
        )
        node.create_subscription(
            CurrentReference, "/orthoglide/current_reference", self.on_applied, qos
        )
        self.setpoints: dict[int, tuple] = {}
        self.last_setpoint: tuple | None = None
        self.gains = (3 * 10.0 * omega**2, 3 * 10.0 * omega, 10.0 * omega**3)  # Kp, Kd, Ki
        self.q_prev: np.ndarray | None = None
        self.integral = np.zeros(3)
        self.sent: dict[float, int] = {}  # first current of each command -> stamp it came from
        # (tick stamp, stamp of the command applied)
        self.applied: list[tuple[int, int | None]] = []
        self.latency: list[int] = []

    def on_setpoint(self, m) -> None:
        self.setpoints[_stamp(m)] = (np.array(m.position), np.array(m.velocity))

    def on_joint_state(self, m) -> None:
        st = _stamp(m)
        self.latency.append(time.time_ns() - st)
        # the first ones come before we listen
        sp = self.setpoints.pop(st, None) or self.last_setpoint
        if sp is None:
            return
        self.last_setpoint = sp
        q = np.array(m.position)
        q_d, qd_d = sp
        v_est = qd_d if self.q_prev is None else (q - self.q_prev) / self.sm.TICK
        self.q_prev = q
        kp, kd, ki = self.gains
        self.integral = self.integral + (q_d - q) * self.sm.TICK
        v = (kp * (q_d - q) + ki * self.integral + kd * (qd_d - v_est)) / self.sm.G_TAU_MANUFACTURER
        self.sent[float(v[0])] = st
        self.pub.publish(
            self.CurrentReference(header=m.header, name=JOINTS, current=[float(x) for x in v])
        )

    def on_applied(self, m) -> None:
        self.applied.append((_stamp(m), self.sent.get(float(m.current[0]))))


def external_run(node, duration: float, omega: float = 40.0) -> dict:
    import threading

    from rclpy.executors import SingleThreadedExecutor

    ctl = ExternalController(node, omega)
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    spinner = threading.Thread(target=executor.spin, daemon=True)
    spinner.start()
    proc = _spawn(
        [f"duration:={duration}", "controller:=external", "payload:=1.983", "trajectory:=test2"]
    )
    try:
        proc.wait(timeout=duration + 60)
    except subprocess.TimeoutExpired:
        proc.terminate()
    time.sleep(0.5)
    executor.remove_node(node)  # free for the next phase's spin_once (a node has one executor)
    executor.shutdown()
    ctl.taker.close()
    err = proc.communicate(timeout=30)[1] if proc.poll() is not None else ""
    m = (re.findall(r"driver: (\d+) ticks, (\d+) late", err or "") or [None])[-1]
    ages = [round((t - c) / 1e6) for t, c in ctl.applied if c is not None]
    return {"ticks": int(m[0]) if m else 0, "late": int(m[1]) if m else -1,
            "latency_ms": np.array(ctl.latency) / 1e6, "ages": np.array(ages),
            "unmatched": sum(c is None for _, c in ctl.applied), "received": len(ctl.applied),
            "log_tail": (err or "").strip().splitlines()[-2:]}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--duration", type=float, default=60.0, help="s of external-mode real time (default 60)"
    )
    ap.add_argument(
        "--starts", type=int, default=5, help="driver starts for the time to first tick"
    )
    args = ap.parse_args(argv)
    os.environ.setdefault("PYTHONUNBUFFERED", "1")
    import rclpy
    from rclpy.signals import SignalHandlerOptions

    # SIGTERM (timeout, CI) like Ctrl-C: one line, the driver stopped
    children.interrupt_on_signals()
    rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
    node = rclpy.create_node("bench_driver_realtime")
    try:
        ext = external_run(node, args.duration)
        firsts = time_to_first_tick(node, args.starts)
        step_ms, rtf = plant_step_and_batch()
    except children.Interrupted as e:
        print(f"driver_realtime: interrupted by {e}", file=sys.stderr)
        return e.exit_code
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    print(
        f"time to first tick on both topics, {args.starts} starts: median {np.median(firsts):.2f} "
        "s, "
        f"worst {np.max(firsts):.2f} s (before: 28-31 s)"
    )
    print(f"plant + controller per tick: p50 {np.percentile(step_ms, 50):.3f} ms, "
          f"p99 {np.percentile(step_ms, 99):.3f} ms (before: ~2 ms)")
    print(f"batch record real-time factor: {rtf:.1f}x")
    n, late = ext["ticks"], ext["late"]
    lat = ext["latency_ms"]
    print(
        f"controller:=external, {args.duration:.0f} s: {n} ticks, {late} published > 0.5 ms after "
        "their "
        f"deadline ({100 * (1 - late / max(n, 1)):.2f} % on time; before: 3999 of 4000 late)"
    )
    if lat.size:
        print(
            f"  joint_states arrival here: p50 {np.percentile(lat, 50):.3f} ms, p99 "
            f"{np.percentile(lat, 99):.3f} ms "
            f"after the deadline; {np.mean(lat <= 0.5) * 100:.2f} % within 0.5 ms"
        )
    ages = ext["ages"]
    if ages.size:
        values, counts = np.unique(ages, return_counts=True)
        hist = ", ".join(f"{v}: {c}" for v, c in zip(values[:8], counts[:8]))
        print(
            f"  applied command age (ticks): {hist}; {np.mean(ages <= 1) * 100:.2f} % from the "
            "previous tick, "
            f"median {np.median(ages):.0f}, max {ages.max()}; {ext['unmatched']} of "
            f"{ext['received']} ticks "
            "applied no command of this run (start)"
        )
    print("  driver: " + " | ".join(ext["log_tail"]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
