"""CPU a node spends taking the driver's 1 kHz topics: rclpy's executor vs batches (ros/batch.py).

    .venv/bin/python bench/ros_intake.py [--seconds 5]

Starts the simulated driver (real time, 3 topics at 1 kHz: joint_states, current_reference,
setpoints), then in this process takes all three for --seconds with a SingleThreadedExecutor (one
callback per message, what every rclpy node does) and then with a BatchTaker (every pending message
at each wake-up, at most every 5 ms), and prints messages per second and % of one core for each.
"""
from __future__ import annotations

import argparse
import subprocess
import sys
import threading
import time
from pathlib import Path

from _figures import Figures, add_json_option

from orthoglide_ident.ros import processes as children  # children end with this process

EMITS_JSON = True  # --json PATH: the figures for bench/write_benchmarks.py


def measure(node, seconds: float, counter: list[int]) -> tuple[float, float]:
    time.sleep(1.0)
    n0, c0 = counter[0], time.process_time()
    time.sleep(seconds)
    return (counter[0] - n0) / seconds, 100 * (time.process_time() - c0) / seconds


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=5.0)
    add_json_option(ap)
    args = ap.parse_args(argv)
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from rclpy.signals import SignalHandlerOptions
    from sensor_msgs.msg import JointState

    from orthoglide_ident.ros.batch import BatchTaker, BatchTopic
    from orthoglide_msgs.msg import CurrentReference, JointSetpoint

    topics = [
        (JointState, "/orthoglide/joint_states"),
        (CurrentReference, "/orthoglide/current_reference"),
        (JointSetpoint, "/orthoglide/setpoints"),
    ]
    qos = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
    driver = children.popen(
        [
            sys.executable,
            "-m",
            "orthoglide_sim.nodes.driver",
            "--ros-args",
            "-p",
            f"duration:={2 * args.seconds + 6}",
        ],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    # SIGTERM (timeout, CI) like Ctrl-C: one line, the driver stopped
    children.interrupt_on_signals()
    rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
    try:
        node = rclpy.create_node("bench_intake_executor")
        count = [0]
        for cls, topic in topics:
            node.create_subscription(
                cls, topic, lambda m: count.__setitem__(0, count[0] + 1), qos, raw=True
            )
        executor = SingleThreadedExecutor()
        executor.add_node(node)
        threading.Thread(target=executor.spin, daemon=True).start()
        rate_ex, cpu_ex = measure(node, args.seconds, count)
        executor.shutdown()
        node.destroy_node()

        owner = rclpy.create_node("bench_intake_batch")
        count = [0]
        taker = BatchTaker(
            owner,
            [
                BatchTopic(cls, topic, qos, lambda b: count.__setitem__(0, count[0] + len(b)))
                for cls, topic in topics
            ],
        )
        rate_b, cpu_b = measure(owner, args.seconds, count)
        taker.close()
        owner.destroy_node()
    except children.Interrupted as e:
        print(f"ros_intake: interrupted by {e}", file=sys.stderr)
        return e.exit_code
    finally:
        rclpy.try_shutdown()
        driver.terminate()
        driver.wait(30)
    print(f"{'intake':<34} {'msgs/s':>8} {'% of one core':>14}")
    print(f"{'rclpy executor, one callback each':<34} {rate_ex:8.0f} {cpu_ex:14.1f}")
    print(f"{'BatchTaker (ros/batch.py)':<34} {rate_b:8.0f} {cpu_b:14.1f}")
    write_figures(args.json, args.seconds, [("rclpy executor, one callback each", rate_ex, cpu_ex),
                                            ("BatchTaker (ros/batch.py)", rate_b, cpu_b)])
    return 0


def write_figures(path: Path | None, seconds: float, rows: list) -> None:
    figs = Figures()
    table = figs.table(f"the driver's three 1 kHz topics taken for {seconds:g} s",
                       ["intake", "msgs/s", ("CPU", "% of one core")])
    for name, rate, cpu in rows:
        table.row(name, f"{rate:.0f}", f"{cpu:.1f}")
    figs.write(path)


if __name__ == "__main__":
    sys.exit(main())
