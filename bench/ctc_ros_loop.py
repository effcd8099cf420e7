"""CTC over ROS 2: the driver (controller:=external) and the ctc node in closed loop, real time.

    .venv/bin/python bench/ctc_ros_loop.py [--trajectory test2] [--duration 4]

Publishes the parameters identified from the sample bags (latched, as the identification node
does), starts `ctc` and the simulated robot with controller:=external and payload 1.983 kg, records
/orthoglide/joint_states and prints the tracking error (encoder position - reference, µm) next to
the same CTC run in-process (no transport delay: each command acts on its own tick). Over ROS the
command computed from tick k's joint state reaches the driver after it has integrated tick k, so
it acts one tick or more later: the price of the transport, visible in the table.
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time

import numpy as np


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trajectory", default="test2")
    ap.add_argument("--duration", type=float, default=4.0, help="s of robot time (default 4)")
    ap.add_argument("--bags", nargs=2, default=["bags/unloaded", "bags/loaded"])
    args = ap.parse_args(argv)

    import rclpy
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState

    from orthoglide_ident.control import CTC, CTCParameters
    from orthoglide_ident.identify.pipeline import identify
    from orthoglide_msgs.msg import CurrentReference, IdentifiedParameters
    from orthoglide_sim.record import simulate_external
    from orthoglide_sim.trajectories import get_trajectory

    res = identify(args.bags)
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    ctc = subprocess.Popen([sys.executable, "-m", "orthoglide_ident.nodes.ctc", "--ros-args",
                            "-p", f"trajectory:={args.trajectory}", "-p", "payload_mass:=1.983"], env=env)
    rclpy.init()
    node = rclpy.create_node("bench_ctc_ros_loop")
    latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                         reliability=ReliabilityPolicy.RELIABLE)
    pub = node.create_publisher(IdentifiedParameters, "/orthoglide/identified_parameters", latched)
    msg = IdentifiedParameters()
    for key, value in res.message_fields().items():
        setattr(msg, key, value)
    pub.publish(msg)
    js: list[tuple[int, list[float]]] = []
    cmd: dict[tuple, int] = {}  # command values -> stamp of the joint state it answered
    applied: list[tuple[int, tuple]] = []  # (stamp, current) the driver applied at each tick
    node.create_subscription(JointState, "/orthoglide/joint_states",
                             lambda m: js.append((m.header.stamp.sec * 10**9 + m.header.stamp.nanosec,
                                                  list(m.position))), 2000)
    node.create_subscription(CurrentReference, "/orthoglide/current_command",
                             lambda m: cmd.setdefault(tuple(m.current), m.header.stamp.sec * 10**9
                                                      + m.header.stamp.nanosec), 2000)
    node.create_subscription(CurrentReference, "/orthoglide/current_reference",
                             lambda m: applied.append((m.header.stamp.sec * 10**9 + m.header.stamp.nanosec,
                                                       tuple(m.current))), 2000)
    t_end = time.monotonic() + 10  # let the ctc node come up and take the parameters
    while time.monotonic() < t_end:
        rclpy.spin_once(node, timeout_sec=0.05)
    driver = subprocess.Popen([sys.executable, "-m", "orthoglide_sim.driver_node", "--ros-args",
                               "-p", "controller:=external", "-p", "payload:=1.983", "-p", "realtime:=true",
                               "-p", f"duration:={args.duration}"], env=env)
    try:
        while driver.poll() is None:
            rclpy.spin_once(node, timeout_sec=0.05)
        for _ in range(20):
            rclpy.spin_once(node, timeout_sec=0.05)
    finally:
        ctc.terminate()
        ctc.wait(timeout=20)
        node.destroy_node()
        rclpy.shutdown()
    if not js:
        print("no joint states received")
        return 1
    stamps = np.array([s for s, _ in js])
    q = np.array([p for _, p in js])
    t = (stamps - stamps[0]) * 1e-9
    lags = np.array([(s - cmd[c]) / 1e6 for s, c in applied if c in cmd])  # ticks
    print(f"\n{args.trajectory}, {args.duration} s, payload 1.983 kg: {len(js)} joint states, {len(cmd)} commands "
          f"received; the driver applied {len(lags)} of them, {len(applied) - len(lags)} ticks held 0 or an "
          "unseen command; command age when applied (ticks): "
          + (f"median {np.median(lags):.0f}, max {lags.max():.0f}" if len(lags) else "-"))
    bad = np.flatnonzero(~np.all(np.isfinite(q), axis=1))
    if len(bad):
        print(f"the plant diverged at t = {t[bad[0]]:.3f} s")
        q, t = q[:bad[0]], t[:bad[0]]
    e_ros = (q - get_trajectory(args.trajectory).evaluate(t)[0]) * 1e6
    params = CTCParameters.from_result(res, payload_mass=1.983)
    local = CTC(params, get_trajectory(args.trajectory).evaluate)
    rec = simulate_external(args.duration, local.command, "1.983", args.trajectory)
    e_loc = (rec.q - rec.q_ref) * 1e6
    print("encoder position - reference (µm)")
    print(f"{'':<22}{'max j1':>9}{'max j2':>9}{'max j3':>9}{'rms j1':>9}{'rms j2':>9}{'rms j3':>9}")
    for name, e in (("CTC over ROS 2", e_ros), ("CTC in-process", e_loc)):
        print(f"{name:<22}" + "".join(f"{v:9.1f}" for v in np.abs(e).max(0))
              + "".join(f"{v:9.1f}" for v in np.sqrt(np.mean(e**2, 0))))
    return 0


if __name__ == "__main__":
    sys.exit(main())
