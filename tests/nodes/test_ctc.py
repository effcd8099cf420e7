"""The CTC node: --help without ROS, silence until parameters arrive, then the model feed-forward
of every setpoint tick, stamped for that tick."""
from __future__ import annotations

import subprocess
import sys
import threading
import time

import numpy as np
import pytest
from ff_reference import orthoglide_currents

from orthoglide_ident.ros import processes as children  # children end with this process

HANG_S = 120.0  # s: a bound on a hang (a busy machine takes what it takes), not a figure


def test_ctc_help_does_not_start_ros(capsys):
    from orthoglide_ident.nodes.ctc import main

    assert main(["ctc", "--help"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("usage:")
    for word in (
        "orthoglide/setpoints",
        "orthoglide/feedforward",
        "identified_parameters",
        "payload_mass",
        "current_limit",
    ):
        assert word in out


def test_ctc_help_from_the_command_line():
    out = children.run(
        [sys.executable, "-m", "orthoglide_ident.nodes.ctc", "--help"],
        capture_output=True,
        text=True,
        timeout=60,
    )
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


def _stamp(m) -> int:
    return m.header.stamp.sec * 10**9 + m.header.stamp.nanosec


class _CTCRun:
    """A ctc node process with ``args`` and a client node that publishes its inputs and takes
    its feed-forward (``on_feedforward(msg)``); ``close()`` stops both."""

    def __init__(self, ros_env, args: list[str], client: str, on_feedforward):
        import rclpy
        from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

        from orthoglide_msgs.msg import CurrentReference, IdentifiedParameters, JointSetpoint

        self.rclpy = rclpy
        self.proc = children.popen(
            [sys.executable, "-m", "orthoglide_ident.nodes.ctc", "--ros-args", *args],
            env=ros_env,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
        )
        self.lines: list[str] = []
        threading.Thread(target=lambda: self.lines.extend(iter(self.proc.stdout.readline, "")),
                         daemon=True).start()
        rclpy.init()
        self.node = rclpy.create_node(client)
        latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                             reliability=ReliabilityPolicy.RELIABLE)
        self.pub_par = self.node.create_publisher(
            IdentifiedParameters, "/orthoglide/identified_parameters", latched
        )
        self.pub_sp = self.node.create_publisher(JointSetpoint, "/orthoglide/setpoints", 5000)
        self.node.create_subscription(CurrentReference, "/orthoglide/feedforward", on_feedforward,
                                      5000)  # every tick of a run, however late this test spins

    def wait_for(self, text: str, timeout: float) -> None:
        _wait_for(self.lines, text, timeout, self.proc)

    def spin(self, seconds: float) -> None:
        t_end = time.monotonic() + seconds
        while time.monotonic() < t_end:
            self.rclpy.spin_once(self.node, timeout_sec=0.01)

    def spin_until(self, done, timeout: float, what: str) -> None:
        """Spin until ``done()`` (no fixed waits: DDS discovery and delivery take what they
        take)."""
        t_end = time.monotonic() + timeout
        while not done():
            assert time.monotonic() < t_end and self.proc.poll() is None, (
                f"{what}; output:\n" + "".join(self.lines)
            )
            self.rclpy.spin_once(self.node, timeout_sec=0.01)

    def said(self, text: str) -> int:
        return sum(text in line for line in self.lines)

    def start(self) -> None:
        """Until the node is up and subscribed to the setpoints."""
        self.wait_for("waiting for", 60)
        t_end = time.monotonic() + 30
        while self.node.count_subscribers("/orthoglide/setpoints") < 1 and time.monotonic() < t_end:
            self.spin(0.05)

    def publish_parameters(self, p, values: list[float]) -> None:
        from orthoglide_msgs.msg import IdentifiedParameters

        self.pub_par.publish(IdentifiedParameters(names=list(p.names), values=values,
                                                  drive_gains=[float(g) for g in p.drive_gains],
                                                  payload_mass=1.983))

    def publish_setpoint(
        self, ref, k: int, stamp_ns: int, order=(0, 1, 2), qdd_scale: float = 1.0
    ) -> None:
        """Tick k of ``ref`` (q, qd, qdd arrays), joints in ``order``, then a 3 ms spin."""
        from orthoglide_msgs.msg import JointSetpoint

        m = JointSetpoint(
            name=[f"q1{i + 1}" for i in order],
            position=[ref[0][k, i] for i in order],
            velocity=[ref[1][k, i] for i in order],
            acceleration=[qdd_scale * ref[2][k, i] for i in order],
        )
        m.header.stamp.sec, m.header.stamp.nanosec = divmod(stamp_ns, 10**9)
        self.pub_sp.publish(m)
        self.spin(0.003)

    def close(self) -> None:
        self.node.destroy_node()
        self.rclpy.shutdown()
        self.proc.terminate()
        self.proc.wait(timeout=60)


def test_ctc_node_waits_for_parameters_then_feeds_forward(ros_env):
    import rclpy  # noqa: F401
    from test_control import true_params

    import orthoglide_msgs.msg  # noqa: F401
    from orthoglide_ident.control import feedforward_currents
    from orthoglide_sim.common.trajectories import get_trajectory

    p = true_params()
    got: dict[int, list[float]] = {}
    run = _CTCRun(ros_env, ["-p", "batch:=4"], "test_ctc_client",
                  lambda m: got.__setitem__(_stamp(m), list(m.current)))
    ref = get_trajectory("test2").evaluate(np.arange(40) * 1e-3)
    t0 = 100 * 10**9

    def publish_setpoints(first: int, n: int) -> None:
        for k in range(first, first + n):
            # names in another order than q11, q12, q13: matched by name
            run.publish_setpoint(ref, k, t0 + k * 10**6, order=(1, 0, 2))

    try:
        run.start()
        publish_setpoints(0, 10)
        run.spin(0.5)
        assert got == {}, "published a feed-forward before parameters arrived"
        run.wait_for("no identified parameters yet", HANG_S)
        run.publish_parameters(p, [float(v) for v in p.chi_b])
        run.wait_for("parameters in", HANG_S)
        publish_setpoints(10, 30)
        run.spin_until(
            lambda: set(range(10, 35)) <= {(s - t0) // 10**6 for s in got}, HANG_S, "not fed"
        )
    finally:
        run.close()
    # every tick from the parameters on is fed (setpoints kept from before them too, when their
    # successor came); 39 has no successor yet and the last batch may still wait for more
    expected = feedforward_currents(*ref, p)
    # the same from the simulator's plant (tests/ff_reference.py): not the model under test
    independent = orthoglide_currents(p.drive_gains, p.payload_mass, *ref)
    ticks = sorted((s - t0) // 10**6 for s in got)
    assert set(range(10, 35)) <= set(ticks) <= set(range(0, 39)), (ticks, "".join(run.lines))
    for k in ticks:
        np.testing.assert_allclose(got[t0 + k * 10**6], expected[k], rtol=1e-9)  # transported
        np.testing.assert_allclose(got[t0 + k * 10**6], independent[k], rtol=1e-9,
                                   atol=1e-9 * np.abs(independent).max())


@pytest.mark.parametrize(
    "args, reason",
    [
        (["-p", "batch:=0"], "parameter batch: must be >= 1"),
        (["-p", "payload_mass:=heavy"], "parameter payload_mass: expected float"),
    ],
)
def test_ctc_node_bad_parameter_is_a_one_line_error(ros_env, args, reason):
    import rclpy  # noqa: F401
    out = children.run([sys.executable, "-m", "orthoglide_ident.nodes.ctc", "--ros-args", *args],
                         env=ros_env, capture_output=True, text=True, timeout=60)
    assert out.returncode == 2, out.stderr
    assert reason in out.stderr and "Traceback" not in out.stderr


def test_ctc_node_clips_to_the_current_limit_and_stops_on_nan(ros_env):
    """Safety: parameters 1000x too large give currents clipped to current_limit (and a warning);
    NaN parameters are refused (the previous ones stay); a NaN setpoint stops the feed-forward
    with the reason, and nothing more is published."""
    import rclpy  # noqa: F401
    from test_control import true_params

    import orthoglide_msgs.msg  # noqa: F401
    from orthoglide_sim.common.trajectories import get_trajectory

    p = true_params()
    got: list[list[float]] = []
    run = _CTCRun(
        ros_env,
        ["-p", "batch:=2", "-p", "current_limit:=[0.5, 0.5, 0.5]"],
        "test_ctc_safety",
        lambda m: got.append(list(m.current)),
    )
    ref = get_trajectory("test2").evaluate(np.arange(60) * 1e-3)

    def publish(
        values: list[float], first: int, answer: str, fed: int, qdd_scale: float = 1.0
    ) -> None:
        """The parameters, until the node answers them (in or rejected), then 20 setpoints, until
        ``fed`` feed-forwards arrived."""
        before = run.said(answer)
        run.publish_parameters(p, values)
        run.spin_until(
            lambda: run.said(answer) > before, HANG_S, f"the node never logged {answer!r}"
        )
        for k in range(first, first + 20):
            run.publish_setpoint(ref, k, 10**11 + k * 10**6, qdd_scale=qdd_scale)
        run.spin_until(lambda: len(got) >= fed, HANG_S, f"{len(got)} of {fed} feed-forwards")

    try:
        run.start()
        publish([1000.0 * float(v) for v in p.chi_b], 0, "parameters in", 15)
        run.wait_for("clipped", HANG_S)
        assert np.max(np.abs(got)) == pytest.approx(0.5), got
        publish([float("nan")] * len(p.names), 20, "rejected, keeping the previous ones", 35)
        n = len(got)
        assert np.max(np.abs(got)) == pytest.approx(0.5)  # still fed, with the old ones
        publish(
            [1000.0 * float(v) for v in p.chi_b], 40, "parameters in", 0, qdd_scale=float("nan")
        )
        run.wait_for("stopped: non-finite feed-forward", HANG_S)
        # the tick held back before the NaN, at most
        assert len(got) <= n + 1 and run.proc.poll() is None
    finally:
        run.close()


def test_ctc_node_with_consistent_uses_the_consistent_set_only(ros_env):
    import rclpy  # noqa: F401
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    from test_control import true_params

    from orthoglide_msgs.msg import IdentifiedParameters

    p = true_params()
    run = _CTCRun(ros_env, ["-p", "consistent:=true"], "test_ctc_consistent", lambda m: None)
    latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                         reliability=ReliabilityPolicy.RELIABLE)
    pub = run.node.create_publisher(IdentifiedParameters,
                                    "/orthoglide/identified_parameters/consistent", latched)
    try:
        run.wait_for("waiting for /orthoglide/identified_parameters/consistent", 60)
        run.publish_parameters(p, [float(v) for v in p.chi_b])  # the unconstrained topic
        run.spin(1.0)
        assert not any("parameters in" in line for line in run.lines)
        pub.publish(IdentifiedParameters(method="tls consistent", names=list(p.names),
                                         values=[float(v) for v in p.chi_b],
                                         drive_gains=[float(g) for g in p.drive_gains],
                                         payload_mass=1.983))
        run.wait_for("parameters in (tls consistent)", HANG_S)
    finally:
        run.close()


def test_ctc_node_refuses_a_model_that_does_not_fit_and_keeps_the_old_one(ros_env):
    """Parameters of another robot's model (names the Orthoglide's base model does not have), then
    drive gains for two joints: each refused with the reason in the log, and the feed-forward
    goes on from the model in use, to the last digit."""
    import rclpy  # noqa: F401
    from test_control import true_params

    import orthoglide_msgs.msg  # noqa: F401
    from orthoglide_ident.control import feedforward_currents
    from orthoglide_msgs.msg import IdentifiedParameters
    from orthoglide_sim.common.trajectories import get_trajectory

    p = true_params()
    got: dict[int, list[float]] = {}
    run = _CTCRun(
        ros_env,
        ["-p", "batch:=2"],
        "test_ctc_unfit",
        lambda m: got.__setitem__(_stamp(m), list(m.current)),
    )
    ref = get_trajectory("test2").evaluate(np.arange(70) * 1e-3)
    t0 = 100 * 10**9
    try:
        run.start()
        run.publish_parameters(p, [float(v) for v in p.chi_b])
        run.spin_until(lambda: run.said("parameters in"), HANG_S, "no parameters in")
        for k in range(0, 20):
            run.publish_setpoint(ref, k, t0 + k * 10**6)
        other_robot = IdentifiedParameters(
            names=["m_shoulder_link", "zz_upper_arm_link"],
            values=[3.7, 0.1],
            drive_gains=[13.0] * 6,
            payload_mass=1.0,
        )
        run.pub_par.publish(other_robot)
        run.spin_until(
            lambda: run.said(
                "rejected, keeping the previous ones: unknown base parameter name(s) "
                "m_shoulder_link"
            ),
            HANG_S,
            "the other robot's model was not refused",
        )
        for k in range(20, 40):
            run.publish_setpoint(ref, k, t0 + k * 10**6)
        two_gains = IdentifiedParameters(names=list(p.names), values=[float(v) for v in p.chi_b],
                                         drive_gains=[2100.0, 2100.0], payload_mass=1.983)
        run.pub_par.publish(two_gains)
        run.spin_until(
            lambda: run.said("drive_gains must be 3 positive numbers"),
            HANG_S,
            "two gains not refused",
        )
        for k in range(40, 60):
            run.publish_setpoint(ref, k, t0 + k * 10**6)
        run.spin_until(
            lambda: set(range(55)) <= {(s - t0) // 10**6 for s in got},
            HANG_S,
            "feed-forward stopped",
        )
    finally:
        run.close()
    expected = feedforward_currents(*ref, p)
    independent = orthoglide_currents(p.drive_gains, p.payload_mass, *ref)  # the plant's
    ticks = sorted((s - t0) // 10**6 for s in got)
    assert set(range(0, 55)) <= set(ticks), (ticks, "".join(run.lines))
    for k in ticks:
        np.testing.assert_allclose(got[t0 + k * 10**6], expected[k], rtol=1e-9)  # transported
        np.testing.assert_allclose(got[t0 + k * 10**6], independent[k], rtol=1e-9,
                                   atol=1e-9 * np.abs(independent).max())
    assert run.proc.returncode == 0


def test_ctc_node_through_a_coupled_transmission_feeds_each_motor(ros_env, tmp_path):
    """The coupled-wrist UR5 (identified in actuator space): joint-side setpoints in, one
    current per motor out under the motors' names, the law's v_m = diag(g)⁻¹ N⁻ᵀ τ_j + motor
    terms (test_control), clipped to current_limit per motor."""
    import rclpy  # noqa: F401
    from ff_reference import arm_currents
    from test_control import COUPLED_N, _coupled_ur5

    import orthoglide_msgs.msg  # noqa: F401
    from orthoglide_ident.control import CTCParameters, feedforward_currents
    from orthoglide_ident.model.registry import ROBOTS_DIR
    from orthoglide_msgs.msg import IdentifiedParameters, JointSetpoint

    robot = _coupled_ur5(tmp_path)
    joints = robot.transmission.joints
    chi_st = robot.standard_values()
    p = CTCParameters.from_values(robot.names, robot.K @ chi_st,
                                  [0.13, 0.13, 0.1, 0.1, 0.1, 0.1], 0.0, model=robot)
    got: dict[int, tuple[list[str], list[float]]] = {}
    limit = [5.0, 5.0, 5.0, 5.0, 5.0, 0.02]  # the coupled motor's clips
    run = _CTCRun(ros_env, ["-p", f"robot:={tmp_path / 'ur5_coupled_ctc.yaml'}", "-p", "batch:=4",
                            "-p", f"current_limit:={limit}", "-p", "payload_mass:=0.0"],
                  "test_ctc_coupled", lambda m: got.__setitem__(_stamp(m), (list(m.name),
                                                                               list(m.current))))
    t = np.arange(30) * 1e-3
    q = 0.3 * np.sin(np.outer(t, np.arange(1, 7)) * 3)
    qd = 0.9 * np.cos(np.outer(t, np.arange(1, 7)) * 3) * np.arange(1, 7)
    qdd = -2.7 * np.sin(np.outer(t, np.arange(1, 7)) * 3) * np.arange(1, 7) ** 2
    t0 = 100 * 10**9
    try:
        run.start()
        run.pub_par.publish(IdentifiedParameters(
            names=list(p.names), values=[float(v) for v in p.chi_b],
            drive_gains=[float(g) for g in p.drive_gains], payload_mass=0.0))
        run.wait_for("parameters in", HANG_S)
        for k in range(30):
            m = JointSetpoint(name=list(joints), position=list(q[k]), velocity=list(qd[k]),
                              acceleration=list(qdd[k]))
            m.header.stamp.sec, m.header.stamp.nanosec = divmod(t0 + k * 10**6, 10**9)
            run.pub_sp.publish(m)
            run.spin(0.003)
        run.spin_until(lambda: set(range(0, 25)) <= {(s - t0) // 10**6 for s in got}, HANG_S,
                       "not fed")
    finally:
        run.close()
    expected = np.clip(feedforward_currents(q, qd, qdd, p), -np.array(limit), limit)
    # the same from Pinocchio's RNEA of the URDF through N, the motor terms by hand
    independent = np.clip(
        arm_currents(
            robot,
            ROBOTS_DIR / "ur5.urdf",
            chi_st,
            None,
            p.drive_gains,
            0.0,
            q,
            qd,
            qdd,
            reduction=COUPLED_N,
        ),
        -np.array(limit),
        limit,
    )
    for s, (names, v) in got.items():
        assert names == list(robot.joint_names)
        # transported
        np.testing.assert_allclose(v, expected[(s - t0) // 10**6], rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(v, independent[(s - t0) // 10**6], rtol=1e-9, atol=1e-12)
    assert any(abs(v[5]) == pytest.approx(0.02) for _, v in got.values())


def test_ctc_monitor_brings_motor_side_positions_to_the_joints(ros_env, tmp_path):
    """position_side actuator (the hardware publishes its motors' encoders, under m1 .. m6, in its
    own order, a gripper beside them): the tracking monitor compares q_j = N⁻¹ (q_m − offset)
    with the joint-side setpoints, so a joint error of 10 / −20 µrad on the coupled wrist is
    logged as that, not as the 320 .. 960 µrad it makes on the motors."""
    import rclpy  # noqa: F401
    import yaml
    from sensor_msgs.msg import JointState
    from test_control import _coupled_ur5

    import orthoglide_msgs.msg  # noqa: F401
    from orthoglide_msgs.msg import JointSetpoint

    robot = _coupled_ur5(tmp_path)
    path = tmp_path / "ur5_coupled_ctc.yaml"
    data = yaml.safe_load(path.read_text())
    data["transmission"]["position_side"] = "actuator"
    path.write_text(yaml.safe_dump(data))
    t = robot.transmission
    run = _CTCRun(ros_env, ["-p", f"robot:={path}", "-p", "monitor:=true"], "test_ctc_monitor",
                  lambda m: None)
    pub_js = run.node.create_publisher(JointState, "/orthoglide/joint_states", 100)
    error = np.array([0.0, 0.0, 0.0, 0.0, 10e-6, -20e-6])  # rad, joint side
    order = [5, 2, 0, 4, 1, 3]  # the hardware's order
    t0, step = 100 * 10**9, 10**8  # a setpoint every 0.1 s of stamps: 5 s in 51 ticks
    q_d = 0.2 * np.sin(np.outer(np.arange(60) * 0.1, np.arange(1, 7)))
    q_m = t.to_actuator_position(q_d + error)
    try:
        run.start()
        t_end = time.monotonic() + 30
        while pub_js.get_subscription_count() < 1:
            assert time.monotonic() < t_end, "the monitor never subscribed"
            run.spin(0.05)
        for k in range(60):
            m = JointSetpoint(name=list(t.joints), position=list(q_d[k]), velocity=[0.0] * 6,
                              acceleration=[0.0] * 6)
            m.header.stamp.sec, m.header.stamp.nanosec = divmod(t0 + k * step, 10**9)
            run.pub_sp.publish(m)
        run.spin(1.0)  # the setpoints are in before their joint states
        for k in range(60):
            js = JointState(name=[t.actuators[i] for i in order] + ["gripper"],
                            position=[float(q_m[k, i]) for i in order] + [0.01])
            js.header.stamp.sec, js.header.stamp.nanosec = divmod(t0 + k * step, 10**9)
            pub_js.publish(js)
            run.spin(0.003)
        run.wait_for("tracking error over", HANG_S)
    finally:
        run.close()
    line = next(x for x in run.lines if "tracking error over" in x)
    assert (
        "rms 0.0 / 0.0 / 0.0 / 0.0 / 10.0 / 20.0 um, max 0.0 / 0.0 / 0.0 / 0.0 / 10.0 / 20.0 um"
        in line
    ), line


def test_ctc_node_states_its_lead_and_cpu_on_diagnostics_and_sums_up_at_exit(ros_env):
    """Setpoints on the system clock, published in bursts ahead of their ticks: every tick gets
    its feed-forward, /diagnostics carries the ctc's lead and CPU once a second, and the node's
    last line sums up the run (ticks sent, lead, CPU). No timing is asserted."""
    import rclpy  # noqa: F401
    from diagnostic_msgs.msg import DiagnosticArray
    from test_control import true_params

    from orthoglide_msgs.msg import JointSetpoint
    from orthoglide_sim.common.trajectories import get_trajectory

    p = true_params()
    got: set[int] = set()
    run = _CTCRun(ros_env, [], "test_ctc_diag_client", lambda m: got.add(_stamp(m)))
    figures: list[dict[str, str]] = []
    run.node.create_subscription(
        DiagnosticArray,
        "/diagnostics",
        lambda m: figures.extend(
            {kv.key: kv.value for kv in st.values}
            for st in m.status
            if st.hardware_id == "orthoglide_ctc"
        ),
        10,
    )
    n = 2500
    ref = get_trajectory("test2").evaluate(np.arange(n) * 1e-3)
    try:
        run.start()
        run.publish_parameters(p, [float(v) for v in p.chi_b])
        run.wait_for("parameters in", HANG_S)
        t0 = time.time_ns() + 300 * 10**6  # tick k at t0 + k ms, published ~0.2 s ahead
        for first in range(0, n, 100):
            run.spin(max(0.0, (t0 + (first - 200) * 10**6 - time.time_ns()) * 1e-9))
            for k in range(first, first + 100):
                m = JointSetpoint(name=["q11", "q12", "q13"], position=list(ref[0][k]),
                                  velocity=list(ref[1][k]), acceleration=list(ref[2][k]))
                m.header.stamp.sec, m.header.stamp.nanosec = divmod(t0 + k * 10**6, 10**9)
                run.pub_sp.publish(m)
        # the last ticks, fewer than a batch, go out as they near: no setpoint comes after them
        run.spin_until(
            lambda: len(got) >= n - 1 and figures, HANG_S, "not every tick fed, or no diagnostics"
        )
    finally:
        run.close()
    # each tick once; the last has no successor
    assert got == {t0 + k * 10**6 for k in range(n - 1)}
    sent = [f for f in figures if f["lead_min_ms"]]  # a second with ticks sent
    assert sent and all(int(f["ticks_sent"]) > 0 and float(f["cpu_percent"]) >= 0 for f in sent)
    assert all(float(f["lead_min_ms"]) <= float(f["lead_median_ms"]) for f in sent)
    t_end = time.monotonic() + 10  # the reader thread may still be on the last lines
    while not (summary := [ln for ln in run.lines if "ctc: " in ln and "ticks sent" in ln]):
        assert time.monotonic() < t_end, "".join(run.lines[-5:])
        time.sleep(0.05)
    assert summary and "lead at sending min" in summary[-1] and "ctc CPU" in summary[-1], "".join(
        run.lines[-5:]
    )
