"""Driver node: identical stamps on joint_states and current_reference, strictly increasing."""
from __future__ import annotations

import os
import subprocess
import sys
import time

import numpy as np
import pytest

rclpy = pytest.importorskip("rclpy")
pytest.importorskip("orthoglide_msgs.msg")


def test_driver_help_does_not_start_ros(capsys):
    from orthoglide_sim.driver_node import main

    assert main(["driver", "--help"]) == 0
    out = capsys.readouterr().out
    for name in ("payload", "trajectory", "controller", "realtime"):
        assert name in out


def test_session_ticks_share_stamp_and_advance():
    from orthoglide_sim.session import DriverSession

    s = DriverSession(payload="1.136", trajectory="test1", controller="pid", start_ns=5)
    stamps = [s.next_tick()[0] for _ in range(3)]
    assert stamps == [5, 1_000_005, 2_000_005]


def test_driver_node_stamps_identical_and_increasing():
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState

    from orthoglide_msgs.msg import CurrentReference

    env = dict(os.environ, PYTHONPATH=os.getcwd())
    proc = subprocess.Popen([sys.executable, "-m", "orthoglide_sim.driver_node", "--ros-args",
                             "-p", "realtime:=false", "-p", "duration:=3.0", "-p", "trajectory:=test1",
                             "-p", "controller:=pid", "-p", "payload:=1.983"], env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    rclpy.init()
    node = rclpy.create_node("test_driver_listener")
    js, cr = {}, {}
    qos = QoSProfile(depth=5000, reliability=ReliabilityPolicy.RELIABLE)
    node.create_subscription(JointState, "/orthoglide/joint_states",
                             lambda m: js.setdefault("s", []).append(m.header.stamp.sec * 10**9 + m.header.stamp.nanosec), qos)
    node.create_subscription(CurrentReference, "/orthoglide/current_reference",
                             lambda m: cr.setdefault("s", []).append(m.header.stamp.sec * 10**9 + m.header.stamp.nanosec), qos)
    try:
        t_end = time.monotonic() + 180
        while proc.poll() is None and time.monotonic() < t_end:
            rclpy.spin_once(node, timeout_sec=0.01)
        for _ in range(100):
            rclpy.spin_once(node, timeout_sec=0.01)
    finally:
        if proc.poll() is None:
            proc.kill()
        out = proc.communicate()[0].decode(errors="replace")
        node.destroy_node()
        rclpy.shutdown()
    a, b = np.array(js.get("s", [])), np.array(cr.get("s", []))
    assert len(a) > 1000 and len(b) > 1000, out
    assert np.all(np.diff(a) > 0) and np.all(np.diff(b) > 0)
    common = np.intersect1d(a, b)
    assert len(common) >= 0.95 * min(len(a), len(b))
    assert np.all(np.mod(common, 1_000_000) == 0)  # sim time: stamps on the 1 kHz grid


def test_external_mode_applies_commands():
    from orthoglide_sim.session import DriverSession

    s = DriverSession(controller="external", noise=False)
    q0 = s.next_tick(np.zeros(3))[1]
    for _ in range(20):
        _, q, v = s.next_tick(np.array([0.05, 0.0, 0.0]))
    assert np.allclose(v, [0.05, 0.0, 0.0])
    assert q[0] - q0[0] > 1e-5  # pushed forward by ~100 N for 20 ms
