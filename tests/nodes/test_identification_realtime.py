"""A slow live update never delays the identification node's services nor its intake: while one
update is held in numpy work (a test hook, released only when the test says), the node answers
its parameter and identify services and takes every message of the recording; the ctc beside it
sends the feed-forward of every tick. Deterministic: the hook holds the update until the answers
are in, so a service waiting for the update would never answer (no timing is asserted)."""
from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from orthoglide_ident.ros import processes as children  # children end with this process

ROOT = Path(__file__).resolve().parents[2]
BAGS = ROOT / "bags"
T0 = 10**12  # the recording's stamps (ns): the sample bag's, shifted off zero

# The identification node with its first live update held in numpy work (QR of a block of rows,
# what a live update does) until the file RELEASE exists; it says when it entered, and how many
# samples each topic has handed to live identification. Not pure-Python work: a thread that never
# releases the GIL but at the 5 ms switch interval slows every other thread's numpy calls (each
# gives the GIL up and waits up to 5 ms to get it back): the sample bags' identify took 0.27 s
# alone and 12.6 s beside such a thread (2026-12-03), however the node's callbacks are arranged.
HOOKED_NODE = """
import os, sys
entered, release = sys.argv.pop(1), sys.argv.pop(1)
from orthoglide_ident.identify.live import session as live
fed = {"q": 0, "v": 0}

def hooked(name, key):
    original = getattr(live.LiveIdentification, name)
    def add(self, stamps, *args):
        if not os.path.exists(entered):
            open(entered, "w").close()
            import numpy as np
            rows = np.random.default_rng(0).standard_normal((300, 60))
            while not os.path.exists(release):
                np.linalg.qr(rows)
        fed[key] += len(stamps)
        print(f"fed {key} {fed[key]}", flush=True)
        return original(self, stamps, *args)
    setattr(live.LiveIdentification, name, add)

hooked("add_joint_states", "q")
hooked("add_current_reference", "v")
from orthoglide_ident.nodes.identification import main
sys.exit(main())
"""


def _spin_until(rclpy, node, done, timeout: float, what: str) -> None:
    t_end = time.monotonic() + timeout
    while not done():
        assert time.monotonic() < t_end, what
        rclpy.spin_once(node, timeout_sec=0.02)


def _lines_until(proc, text: str, timeout: float) -> str:
    from test_identification import read_available

    out = read_available(proc.stdout, until=text, timeout=timeout)
    assert text in out, f"never printed {text!r}: {out[-500:]}"
    return out


def test_a_slow_live_update_delays_neither_services_nor_intake_nor_the_ctc(
    spawn_python, ros_env, tmp_path
):
    import rclpy
    from rclpy.parameter_client import AsyncParameterClient
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState
    from test_control import true_params

    from orthoglide_ident.bags import read_bag
    from orthoglide_msgs.msg import (
        CurrentReference,
        IdentifiedParameters,
        JointSetpoint,
        RecorderStatus,
    )
    from orthoglide_msgs.srv import Identify
    from orthoglide_sim.common.trajectories import get_trajectory

    entered, release = tmp_path / "entered", tmp_path / "release"
    node = spawn_python(
        HOOKED_NODE, str(entered), str(release), "--ros-args", "-p", f"bag_dir:={BAGS}"
    )
    ctc = children.popen([sys.executable, "-m", "orthoglide_ident.nodes.ctc"], env=ros_env,
                         stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    bag = read_bag(BAGS / "unloaded")
    stamps = bag.joint_states.stamps_ns.astype(np.int64) + T0
    q, v = bag.joint_states.position, bag.current_reference.current
    assert np.array_equal(bag.current_reference.stamps_ns + T0, stamps)
    n_first, n = 1000, 6000  # ticks sent before the update is held, and in all
    names = ["q11", "q12", "q13"]
    rclpy.init()
    client = rclpy.create_node("test_slow_update_client")
    try:
        latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                             reliability=ReliabilityPolicy.RELIABLE)
        stream = QoSProfile(depth=n, reliability=ReliabilityPolicy.RELIABLE)
        pub_status = client.create_publisher(RecorderStatus, "/orthoglide/recorder/status", latched)
        pub_js = client.create_publisher(JointState, "/orthoglide/joint_states", stream)
        pub_cr = client.create_publisher(CurrentReference, "/orthoglide/current_reference", stream)
        pub_par = client.create_publisher(
            IdentifiedParameters, "/orthoglide/identified_parameters", latched
        )
        pub_sp = client.create_publisher(JointSetpoint, "/orthoglide/setpoints", stream)
        fed_forward: set[int] = set()
        client.create_subscription(
            CurrentReference,
            "/orthoglide/feedforward",
            lambda m: fed_forward.add(m.header.stamp.sec * 10**9 + m.header.stamp.nanosec),
            stream,
        )
        identify = client.create_client(Identify, "/orthoglide/identify")
        params = AsyncParameterClient(client, "orthoglide_identification")
        assert identify.wait_for_service(timeout_sec=60) and params.wait_for_services(
            timeout_sec=60
        )
        _spin_until(
            rclpy,
            client,
            lambda: all(
                client.count_subscribers(t) >= 1
                for t in (
                    "/orthoglide/joint_states",
                    "/orthoglide/current_reference",
                    "/orthoglide/recorder/status",
                    "/orthoglide/setpoints",
                )
            ),
            60,
            "the nodes never subscribed",
        )
        p = true_params()  # the ctc fed with a model, as after an identification
        pub_par.publish(
            IdentifiedParameters(
                names=list(p.names),
                values=[float(x) for x in p.chi_b],
                drive_gains=[float(g) for g in p.drive_gains],
                payload_mass=1.983,
            )
        )
        pubs = (pub_status, pub_js, pub_cr, pub_par, pub_sp)  # DDS matching after discovery
        _spin_until(
            rclpy,
            client,
            lambda: all(
                p.get_subscription_count() >= max(1, client.count_subscribers(p.topic_name))
                for p in pubs
            ),
            60,
            "the publishers never matched their subscribers",
        )

        def publish_ticks(a: int, b: int) -> None:
            for k in range(a, b):
                js = JointState(name=names, position=[float(x) for x in q[k]])
                js.header.stamp.sec, js.header.stamp.nanosec = divmod(int(stamps[k]), 10**9)
                pub_js.publish(js)
                pub_cr.publish(
                    CurrentReference(header=js.header, name=names, current=[float(x) for x in v[k]])
                )
                if k % 100 == 0:
                    rclpy.spin_once(client, timeout_sec=0.0)

        status = RecorderStatus(
            recording=True, condition="unloaded", bag_path=str(tmp_path / "slow")
        )
        status.first_tick.sec, status.first_tick.nanosec = divmod(int(stamps[0]), 10**9)
        pub_status.publish(status)
        publish_ticks(0, n_first)
        _spin_until(rclpy, client, entered.exists, 60, "the live update never started")

        # the update is held: the rest of the recording, the services, and the ctc's work
        publish_ticks(n_first, n)
        got = params.get_parameters(["method"])
        _spin_until(rclpy, client, got.done, 60, "the parameter service waited for the live update")
        assert got.result().values[0].string_value == "tls"
        answer = identify.call_async(
            Identify.Request(bags=[str(BAGS / "unloaded"), str(BAGS / "loaded")])
        )
        _spin_until(
            rclpy, client, answer.done, 120, "orthoglide/identify waited for the live update"
        )
        assert answer.result().success, answer.result().message
        ref = get_trajectory("test2").evaluate(np.arange(1000) * 1e-3)
        t_sp = time.time_ns() + 10**9
        for k in range(1000):
            sp = JointSetpoint(name=names, position=list(ref[0][k]), velocity=list(ref[1][k]),
                               acceleration=list(ref[2][k]))
            sp.header.stamp.sec, sp.header.stamp.nanosec = divmod(t_sp + k * 10**6, 10**9)
            pub_sp.publish(sp)
        _spin_until(
            rclpy, client, lambda: len(fed_forward) >= 999, 60, "the ctc did not feed every tick"
        )
        assert fed_forward == {t_sp + k * 10**6 for k in range(999)}
        assert not release.exists()  # all of the above while the update was held

        release.touch()
        done = RecorderStatus(recording=False, condition="unloaded", bag_path=status.bag_path,
                              first_tick=status.first_tick)
        done.last_tick.sec, done.last_tick.nanosec = divmod(int(stamps[n - 1]), 10**9)
        pub_status.publish(done)
        # every tick of the recording reached live identification: none lost while it was held
        out = _lines_until(node, f"fed v {n}", 60)
        assert f"fed q {n}" in out or f"fed q {n}" in _lines_until(node, f"fed q {n}", 10)
    finally:
        client.destroy_node()
        rclpy.shutdown()
        ctc.terminate()
        ctc.wait(timeout=30)
