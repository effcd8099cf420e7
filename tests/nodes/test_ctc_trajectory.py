"""The ctc node's joint_trajectory_controller outlet, as a node: the identified model of a UR5,
its setpoints in, JointTrajectory points out whose effort is the feed-forward in the controller's
units, besides orthoglide/feedforward."""
from __future__ import annotations

import subprocess
import sys
import threading
import time

import numpy as np
import rclpy

ROBOT = "ur5_mount"
T0 = 500 * 10**9


def _stamp(m) -> int:
    return m.header.stamp.sec * 10**9 + m.header.stamp.nanosec


def test_trajectory_points_carry_the_feed_forward(ros_env):
    from ff_reference import arm_currents, random_standard_set
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    from trajectory_msgs.msg import JointTrajectory

    from orthoglide_ident.control import CTCParameters, feedforward_currents
    from orthoglide_ident.model.registry import load_robot
    from orthoglide_msgs.msg import CurrentReference, IdentifiedParameters, JointSetpoint
    from orthoglide_sim.arms.description import load_arm
    from orthoglide_sim.arms.excitation import designed_trajectory

    model = load_robot(ROBOT)
    chi_st, bodies = random_standard_set(model, seed=0)  # a physically consistent arm
    values = model.K @ chi_st  # its base parameters (eq. 21)
    gains = np.array([13.5, 12.6, 13.4, 8.9, 9.7, 9.1])
    p = CTCParameters.from_values(model.names, values, gains, 2.5, model)
    ref = designed_trajectory(load_arm(ROBOT), "exciting1").evaluate(np.arange(60) * 1e-3)
    expected = feedforward_currents(*ref, p)  # A, what orthoglide/feedforward carries
    # the same from Pinocchio's RNEA and the drive terms by hand (tests/ff_reference.py)
    independent = arm_currents(model, model.description.path, chi_st, bodies, gains, 2.5, *ref)

    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "orthoglide_ident.nodes.ctc",
            "--ros-args",
            "-p",
            f"robot:={ROBOT}",
            "-p",
            "trajectory_topic:=joint_trajectory_controller/joint_trajectory",
            "-p",
            "current_limit:=[100.0]",
            "-p",
            "batch:=5",
            "-p",
            "trajectory_overlap:=40",
        ],
        env=ros_env,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    lines: list[str] = []
    threading.Thread(
        target=lambda: lines.extend(iter(proc.stdout.readline, "")), daemon=True
    ).start()
    rclpy.init()
    node = rclpy.create_node("test_ctc_trajectory")
    traj: list = []
    ff: dict[int, list[float]] = {}
    try:
        latched = QoSProfile(
            depth=1,
            durability=DurabilityPolicy.TRANSIENT_LOCAL,
            reliability=ReliabilityPolicy.RELIABLE,
        )
        pub_par = node.create_publisher(
            IdentifiedParameters, "/orthoglide/identified_parameters", latched
        )
        pub_sp = node.create_publisher(JointSetpoint, "/orthoglide/setpoints", 100)
        node.create_subscription(
            JointTrajectory, "/joint_trajectory_controller/joint_trajectory", traj.append, 100
        )
        node.create_subscription(CurrentReference, "/orthoglide/feedforward",
                                 lambda m: ff.__setitem__(_stamp(m), list(m.current)), 100)
        pub_par.publish(
            IdentifiedParameters(
                names=list(model.names),
                values=[float(v) for v in values],
                drive_gains=[float(g) for g in gains],
                payload_mass=2.5,
            )
        )
        t_end = time.monotonic() + 60
        while (
            not any("parameters in" in x for x in lines)
            or node.count_subscribers("/orthoglide/setpoints") < 1
        ):
            assert time.monotonic() < t_end and proc.poll() is None, "".join(lines)
            rclpy.spin_once(node, timeout_sec=0.05)
        for k in range(60):
            m = JointSetpoint(
                name=list(model.joint_names),
                position=list(ref[0][k]),
                velocity=list(ref[1][k]),
                acceleration=list(ref[2][k]),
            )
            m.header.stamp.sec, m.header.stamp.nanosec = divmod(T0 + k * 10**6, 10**9)
            pub_sp.publish(m)
            rclpy.spin_once(node, timeout_sec=0.003)
        t_end = time.monotonic() + 60  # a bound on a hang
        while time.monotonic() < t_end and (len(ff) < 55 or not traj):
            rclpy.spin_once(node, timeout_sec=0.05)
    finally:
        node.destroy_node()
        rclpy.shutdown()
        proc.terminate()
        proc.wait(timeout=60)
    assert len(ff) >= 55 and traj, "".join(lines)
    scale = np.abs(independent).max()
    for s, v in ff.items():  # the Orthoglide's outlet as before
        np.testing.assert_allclose(v, expected[(s - T0) // 10**6], rtol=1e-9)  # transported
        np.testing.assert_allclose(v, independent[(s - T0) // 10**6], rtol=1e-9, atol=1e-9 * scale)
    last = traj[-1]
    assert tuple(last.joint_names) == model.joint_names and len(last.points) == 40
    first = (_stamp(last) - T0) // 10**6
    nominal = model.nominal_gains
    for i, point in enumerate(last.points):
        k = first + i
        assert point.time_from_start.sec * 10**9 + point.time_from_start.nanosec == i * 10**6
        np.testing.assert_array_equal(point.positions, ref[0][k])
        np.testing.assert_array_equal(point.velocities, ref[1][k])
        # point k: the feed-forward of tick k - 1, as the nominal gains turn it into that current
        np.testing.assert_allclose(point.effort, expected[k - 1] * nominal, rtol=1e-9)
        np.testing.assert_allclose(point.effort, independent[k - 1] * nominal, rtol=1e-9,
                                   atol=1e-9 * scale * nominal.max())
