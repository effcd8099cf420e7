"""Fraction of 1 kHz ticks the driver publishes on time (realtime mode), measured by a listener.

    PYTHONPATH=. .venv/bin/python bench/sim_driver_ontime.py [--duration 60] [--controller pid]

"On time": the message arrives within 1 ms of its stamp (stamps are the tick's nominal wall time).
Also counts ticks missing from the stamps (should be 0) and mismatched stamps across the two topics.
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time

import numpy as np


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=5.0, help="seconds of publishing (default 5; the issue asks 60)")
    ap.add_argument("--controller", default="pid", choices=["pid", "pid_ff"])
    args = ap.parse_args()

    import rclpy
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState

    from orthoglide_msgs.msg import CurrentReference

    env = dict(os.environ, PYTHONPATH=os.pathsep.join([os.getcwd(), os.environ.get("PYTHONPATH", "")]))
    proc = subprocess.Popen([sys.executable, "-m", "orthoglide_sim.driver_node", "--ros-args", "-p",
                             f"duration:={args.duration}", "-p", f"controller:={args.controller}"], env=env)
    rclpy.init()
    node = rclpy.create_node("driver_ontime_bench")
    js, cr = [], []
    qos = QoSProfile(depth=10000, reliability=ReliabilityPolicy.RELIABLE)

    def stamp(m):
        return m.header.stamp.sec * 10**9 + m.header.stamp.nanosec

    node.create_subscription(JointState, "/orthoglide/joint_states", lambda m: js.append((stamp(m), time.time_ns())), qos)
    node.create_subscription(CurrentReference, "/orthoglide/current_reference", lambda m: cr.append(stamp(m)), qos)
    try:
        while proc.poll() is None:
            rclpy.spin_once(node, timeout_sec=0.01)
        for _ in range(50):
            rclpy.spin_once(node, timeout_sec=0.01)
    finally:
        if proc.poll() is None:
            proc.terminate()
        node.destroy_node()
        rclpy.shutdown()
    if not js:
        print("no messages received")
        return
    s = np.array([a for a, _ in js])
    arrival = np.array([b for _, b in js])
    expected = int(round(args.duration * 1000))
    gaps = int(np.sum(np.diff(s) // 1_000_000 - 1))
    on_time = float(np.mean(arrival - s <= 1_000_000))
    print(f"{'duration s':>10} {'expected':>8} {'received':>8} {'missing':>7} {'on time':>8} {'p99 latency ms':>15} {'stamp mismatch':>14}")
    print(f"{args.duration:>10.1f} {expected:>8} {len(s):>8} {expected - len(s):>7} {on_time:>8.4f} "
          f"{np.percentile(arrival - s, 99) / 1e6:>15.3f} {len(np.setxor1d(s, np.array(cr))):>14}")
    print(f"(gaps between received stamps: {gaps} ticks)")


if __name__ == "__main__":
    main()
