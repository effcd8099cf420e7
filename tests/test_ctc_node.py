"""The CTC node: --help without ROS, silence until parameters arrive, then the control law."""
from __future__ import annotations

import subprocess
import sys
import threading
import time

import numpy as np
import pytest


def test_ctc_help_does_not_start_ros(capsys):
    from orthoglide_ident.nodes.ctc import main

    assert main(["ctc", "--help"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("usage:")
    for word in ("trajectory", "payload_mass", "/orthoglide/current_command", "identified_parameters"):
        assert word in out


def test_ctc_help_from_the_command_line():
    out = subprocess.run([sys.executable, "-m", "orthoglide_ident.nodes.ctc", "--help"], capture_output=True,
                         text=True, timeout=60)
    assert out.returncode == 0 and out.stdout.startswith("usage:")


def _wait_for(lines: list[str], text: str, timeout: float, proc) -> None:
    t_end = time.monotonic() + timeout
    while time.monotonic() < t_end:
        if any(text in line for line in lines):
            return
        if proc.poll() is not None:
            break
        time.sleep(0.05)
    raise AssertionError(f"ctc node never logged {text!r}; output:\n" + "".join(lines))


def test_ctc_node_waits_for_parameters_then_commands(ros_env):
    rclpy = pytest.importorskip("rclpy")
    pytest.importorskip("orthoglide_msgs.msg")
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState

    from orthoglide_ident.control import CTC, CTCParameters
    from orthoglide_msgs.msg import CurrentReference, IdentifiedParameters
    from orthoglide_sim.trajectories import get_trajectory
    from test_control import true_params

    p = true_params()
    proc = subprocess.Popen([sys.executable, "-m", "orthoglide_ident.nodes.ctc", "--ros-args",
                             "-p", "trajectory:=test2"], env=ros_env, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)
    lines: list[str] = []
    threading.Thread(target=lambda: lines.extend(iter(proc.stdout.readline, "")), daemon=True).start()
    rclpy.init()
    node = rclpy.create_node("test_ctc_client")
    got: dict[int, list[float]] = {}
    latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                         reliability=ReliabilityPolicy.RELIABLE)
    pub_par = node.create_publisher(IdentifiedParameters, "/orthoglide/identified_parameters", latched)
    pub_js = node.create_publisher(JointState, "/orthoglide/joint_states", 100)
    node.create_subscription(CurrentReference, "/orthoglide/current_command",
                             lambda m: got.__setitem__(m.header.stamp.sec * 10**9 + m.header.stamp.nanosec,
                                                       list(m.current)), 100)

    def spin(seconds: float) -> None:
        t_end = time.monotonic() + seconds
        while time.monotonic() < t_end:
            rclpy.spin_once(node, timeout_sec=0.01)

    q_ref = get_trajectory("test2").evaluate(np.arange(30) * 1e-3)[0]
    q_meas = q_ref + np.random.default_rng(0).normal(0.0, 5e-6, q_ref.shape)
    t0 = 100 * 10**9

    def publish_ticks(first: int, n: int) -> None:
        for k in range(first, first + n):
            js = JointState(name=["q12", "q11", "q13"], position=[q_meas[k, 1], q_meas[k, 0], q_meas[k, 2]])
            js.header.stamp.sec, js.header.stamp.nanosec = divmod(t0 + k * 10**6, 10**9)
            pub_js.publish(js)
            spin(0.005)

    try:
        _wait_for(lines, "waiting for", 60, proc)
        t_end = time.monotonic() + 30
        while node.count_subscribers("/orthoglide/joint_states") < 1 and time.monotonic() < t_end:
            spin(0.05)
        publish_ticks(0, 10)
        spin(0.5)
        assert got == {}, "published commands before parameters arrived"
        _wait_for(lines, "no identified parameters yet", 10, proc)
        msg = IdentifiedParameters(names=list(p.names), values=[float(v) for v in p.chi_b],
                                   drive_gains=[float(g) for g in p.drive_gains], payload_mass=p.payload_mass)
        pub_par.publish(msg)
        _wait_for(lines, "parameters in", 30, proc)
        publish_ticks(10, 20)  # trajectory time 0 at tick 10
        spin(1.0)
    finally:
        node.destroy_node()
        rclpy.shutdown()
        proc.terminate()
        proc.wait(timeout=60)  # Fast DDS teardown can be slow when both sides leave at once
    assert len(got) == 20, (len(got), "".join(lines))
    local = CTC(CTCParameters.from_message_fields({"names": p.names, "values": p.chi_b,
                                                   "drive_gains": p.drive_gains, "payload_mass": 1.983}),
                get_trajectory("test2").evaluate)
    for k in range(10, 30):
        stamp = t0 + k * 10**6
        np.testing.assert_allclose(got[stamp], local.command(k - 10, q_meas[k]), rtol=1e-9)


def test_ctc_node_bad_trajectory_is_a_one_line_error(ros_env):
    pytest.importorskip("rclpy")
    out = subprocess.run([sys.executable, "-m", "orthoglide_ident.nodes.ctc", "--ros-args", "-p", "trajectory:=nope"],
                         env=ros_env, capture_output=True, text=True, timeout=60)
    assert out.returncode == 2
    assert "unknown trajectory 'nope'" in out.stderr and "Traceback" not in out.stderr
