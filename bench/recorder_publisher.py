"""Stand-in controller for recorder tests and benchmarks: publishes both topics at a fixed rate.

Each tick k carries header.stamp = t0 + k / rate on /orthoglide/joint_states and
/orthoglide/current_reference (serialized once, in bulk, then published as raw bytes). A tick that
is late is published at once (catch-up), so every tick is sent and any gap in the stamps a recorder
sees is a loss. Prints ``sent N ticks`` on stdout at the end.

    python bench/recorder_publisher.py --rate 1000 --duration 10 [--wait-subscribers 1]
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rate", type=float, default=1000.0, help="ticks per second")
    ap.add_argument("--duration", type=float, default=10.0, help="seconds of publishing")
    ap.add_argument(
        "--wait-subscribers", type=int, default=1, help="wait for this many subscribers per topic"
    )
    a = ap.parse_args(argv)

    import rclpy
    from rclpy.duration import Duration
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
    from rclpy.signals import SignalHandlerOptions
    from sensor_msgs.msg import JointState

    from orthoglide_ident import bags
    from orthoglide_msgs.msg import CurrentReference

    rclpy.init(signal_handler_options=SignalHandlerOptions.NO)  # SIGTERM: the default, an exit
    node = rclpy.create_node("recorder_test_publisher")
    qos = QoSProfile(
        history=HistoryPolicy.KEEP_LAST, depth=5000, reliability=ReliabilityPolicy.RELIABLE
    )
    pub_js = node.create_publisher(JointState, bags.topics.JOINT_STATES_TOPIC, qos)
    pub_cr = node.create_publisher(CurrentReference, bags.topics.CURRENT_REFERENCE_TOPIC, qos)
    deadline = time.monotonic() + 20
    while (
        min(pub_js.get_subscription_count(), pub_cr.get_subscription_count()) < a.wait_subscribers
        and time.monotonic() < deadline
    ):
        time.sleep(0.05)
    print("publishing", flush=True)

    n = int(round(a.rate * a.duration))
    period = 1.0 / a.rate
    t0_ns = time.time_ns()
    names = ("q11", "q12", "q13")
    block = 1000
    k = 0
    start = time.monotonic()
    while k < n:
        m = min(block, n - k)
        ticks = np.arange(k, k + m)
        stamps = t0_ns + np.rint(ticks * period * 1e9).astype(np.int64)
        q = 0.05 * np.sin(np.outer(ticks * period, [1.0, 1.3, 1.7]))
        encode, topics = bags.encoding.encode_messages, bags.topics
        js = encode(topics.JOINT_STATE_TYPE, names, stamps, q)
        cr = encode(topics.CURRENT_REFERENCE_TYPE, names, stamps, 0.1 * q)
        for i in range(m):
            delay = start + (k + i) * period - time.monotonic()
            if delay > 0:
                time.sleep(delay)
            pub_js.publish(js[i].tobytes())
            pub_cr.publish(cr[i].tobytes())
        k += m
    elapsed = time.monotonic() - start
    # a publisher that vanishes takes the ticks it still had to resend with it: wait until every
    # subscriber has all of them (as the simulator's driver does on its way out)
    for pub in (pub_js, pub_cr):
        if not pub.wait_for_all_acked(Duration(seconds=5)):
            print(
                f"{pub.topic_name}: a subscriber had not received every tick 5 s after the last "
                "one",
                file=sys.stderr,
                flush=True,
            )
    print(f"sent {n} ticks in {elapsed:.3f} s", flush=True)
    node.destroy_node()
    rclpy.shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
