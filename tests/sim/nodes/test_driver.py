"""The driver: a session tick by tick (no ROS), then the node: first tick, stamps, setpoints ahead,
commands applied from the next tick, lockstep in simulated time."""
from __future__ import annotations

import os
import re
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.ros import processes as children  # children end with this process
from orthoglide_sim.common.trajectories import Q_CENTER, Q_HALF, get_trajectory
from orthoglide_sim.orthoglide.session import DriverSession

# the bench's outside controller
sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "bench"))


def _start_driver(children, ros_env, **params):
    """The driver node as a child process, ``-p name:=value`` for each keyword in order; its
    output on stdout."""
    args = [sys.executable, "-m", "orthoglide_sim.nodes.driver", "--ros-args"]
    for name, value in params.items():
        args += ["-p", f"{name}:={value}"]
    return children.popen(args, env=ros_env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                          text=True)


def test_driver_help_does_not_start_ros(capsys):
    from orthoglide_sim.nodes.driver import main

    assert main(["driver", "--help"]) == 0
    out = capsys.readouterr().out
    for name in (
        "payload",
        "trajectory",
        "controller",
        "realtime",
        "setpoint_lead",
        "current_limit",
        "orthoglide/setpoints",
        "orthoglide/feedforward",
    ):
        assert name in out


def _run(s: DriverSession, n: int) -> tuple[np.ndarray, np.ndarray]:
    q, ref = [], []
    for _ in range(n):
        ref.append(s.setpoint(s.k)[0])
        q.append(s.measure())
        s.control(q[-1])
        s.advance()
        assert s.fault is None, s.fault
    return np.array(q), np.array(ref)


def test_session_tracks_its_trajectory_and_knows_the_setpoints_ahead():
    s = DriverSession(payload="1.136", trajectory="test1", controller="pid", lead=20)
    q, ref = _run(s, 300)
    np.testing.assert_allclose(
        ref, get_trajectory("test1").evaluate(np.arange(300) * 1e-3)[0], atol=1e-15
    )
    assert np.sqrt(np.mean((q - ref) ** 2)) < 2e-3  # PID: ~1 mm on test1
    assert s.k == 300 and s.setpoint(s.k + s.lead)[0].shape == (3,)


def test_trajectory_change_blends_in_inside_the_box():
    s = DriverSession(trajectory="exciting", controller="pid_ff", lead=5)
    _run(s, 200)
    k_start = s.set_trajectory("test2")
    assert k_start == 206
    _, ref = _run(s, 3000)
    assert np.all(ref >= Q_CENTER - Q_HALF - 1e-12) and np.all(ref <= Q_CENTER + Q_HALF + 1e-12)
    assert np.abs(np.diff(ref, axis=0)).max() < 2e-3  # continuous: < 2 m/s between ticks
    np.testing.assert_allclose(
        ref[-1], get_trajectory("test2").evaluate((s.k - 1 - k_start) * 1e-3)[0][0], atol=1e-12
    )
    with pytest.raises(ConfigError, match="unknown trajectory"):
        s.set_trajectory("nope")


def test_payload_mounted_while_running_changes_the_plant():
    s = DriverSession(payload="none", trajectory="exciting", controller="pid", noise=False)
    _run(s, 200)
    s.set_payload(1.983)
    q, ref = _run(s, 300)  # the motion goes on from the same state, now carrying 1.983 kg
    assert s.plant.payload_vector[9] == pytest.approx(1.983)
    assert np.abs(q - ref).max() < 5e-3
    with pytest.raises(ConfigError, match="payload"):
        s.set_payload("heavy")


def test_external_commands_limits_and_faults():
    s = DriverSession(
        controller="external", trajectory="test1", noise=False, current_limit=[0.5, 0.5, 0.5]
    )
    q = s.measure()
    v = s.control(q)  # no command yet: the driver's PID holds the robot
    assert s.stats.no_command == 1
    s.advance()
    s.offer_command(s.k - 1, [0.05, 0.0, 3.0])  # computed from the previous tick's joint state
    v = s.control(s.measure())
    np.testing.assert_allclose(v, [0.05, 0.0, 0.5])  # clipped to the current limit
    assert s.stats.saturated == 1 and s.stats.command_ages == {1: 1}
    s.advance()
    s.offer_command(s.k, [float("nan"), 0.0, 0.0])
    assert s.fault and "not three finite currents" in s.fault
    s.reset()
    assert s.fault is None
    with pytest.raises(ConfigError):
        DriverSession(current_limit=[-1.0])


def test_session_plant_option_reduced_by_default_or_the_tree_reference():
    """plant:=reduced (default) and plant:=tree run the same session to within the encoder's
    count."""
    from orthoglide_sim.orthoglide.reduced_plant import ReducedIntegrator
    from orthoglide_sim.orthoglide.simulator import Integrator

    runs = {}
    for plant in ("reduced", "tree"):
        s = DriverSession(payload="1.983", trajectory="exciting", noise=False, plant=plant)
        assert type(s.sim) is (ReducedIntegrator if plant == "reduced" else Integrator)
        _run(s, 300)
        runs[plant] = s.sim.q
    assert np.abs(runs["reduced"] - runs["tree"]).max() < 1e-6
    with pytest.raises(ConfigError, match="plant must be one of reduced, tree"):
        DriverSession(plant="mujoco")


def test_packed_messages_read_back_by_rclpy_and_rosbags():
    """The driver publishes its per-tick messages as bytes patched in a template: rclpy reads them
    as the message, and rosbags (strict about a message's length: the recorder writes the bytes
    as they come) reads the same stamp and values, from as many bytes as its own serialisation
    (rclpy's serialize_message gave JointState 8 trailing bytes more, which rosbags refused).
    Padding bytes may differ: CDR leaves them free."""
    from builtin_interfaces.msg import Time
    from rclpy.serialization import deserialize_message
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore
    from sensor_msgs.msg import JointState

    from orthoglide_msgs.msg import CurrentReference, JointSetpoint
    from orthoglide_sim.common.packed_messages import PackedMessage

    # rosbags' own, the project's two types from their files
    store = get_typestore(Stores.ROS2_JAZZY)
    for name in ("CurrentReference", "JointSetpoint"):
        text = (Path(__file__).parents[3] / f"msg_defs/orthoglide_msgs/msg/{name}.msg").read_text()
        store.register(get_types_from_msg(text, f"orthoglide_msgs/msg/{name}"))
    rng = np.random.default_rng(0)
    joints = ["q11", "q12", "q13"]
    for msg_type, fields in ((JointState, ["position"]), (CurrentReference, ["current"]),
                             (JointSetpoint, ["position", "velocity", "acceleration"])):
        typename = msg_type.__module__.split(".")[0] + "/msg/" + msg_type.__name__
        packed = PackedMessage(msg_type, joints, fields)
        for sec, nsec in ((0, 0), (1_764_700_000, 999_000_000), (7, 1_000)):
            values = rng.normal(size=(len(fields), 3)) * 10.0 ** rng.integers(-6, 3)
            msg = msg_type(name=joints, **{f: list(v) for f, v in zip(fields, values)})
            msg.header.stamp = Time(sec=sec, nanosec=nsec)
            raw = packed.pack(sec, nsec, *values)
            assert deserialize_message(raw, msg_type) == msg
            back = store.deserialize_cdr(raw, typename)  # strict: refuses a wrong length
            assert len(raw) == len(store.serialize_cdr(back, typename))
            assert (back.header.stamp.sec, back.header.stamp.nanosec) == (sec, nsec)
            for f, v in zip(fields, values):
                np.testing.assert_array_equal(getattr(back, f), v)


TICK_NS = 1_000_000  # the driver's 1 kHz tick
# s, a bound against a hang only: beside two CPU hogs on 2 cores the driver took over 60 s to
# publish its first 300 ticks and over 30 s to end on SIGTERM
HANG_S = 300.0


def _stamp(m) -> int:
    return m.header.stamp.sec * 10**9 + m.header.stamp.nanosec


def test_driver_node_first_tick_stamps_and_setpoints(ros_env):
    """Simulated time, pid: both topics on the 1 kHz grid with identical stamps; setpoints carry
    the tracked reference, published setpoint_lead ticks ahead; first tick within seconds; the
    driver's counters on /diagnostics once a second."""
    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState

    from orthoglide_msgs.msg import CurrentReference, JointSetpoint

    rclpy.init()
    node = rclpy.create_node("test_driver_listener")
    js, cr, sp, first = [], [], {}, {}
    qos = QoSProfile(depth=5000, reliability=ReliabilityPolicy.RELIABLE)
    node.create_subscription(
        JointState,
        "/orthoglide/joint_states",
        lambda m: (first.setdefault("js", time.monotonic()), js.append(_stamp(m))),
        qos,
    )
    node.create_subscription(
        CurrentReference,
        "/orthoglide/current_reference",
        lambda m: (first.setdefault("cr", time.monotonic()), cr.append(_stamp(m))),
        qos,
    )
    node.create_subscription(JointSetpoint, "/orthoglide/setpoints",
                             lambda m: sp.setdefault(_stamp(m), (len(js), list(m.position))), qos)
    diag = []
    node.create_subscription(
        DiagnosticArray,
        "/diagnostics",
        lambda m: diag.extend(
            {kv.key: kv.value for kv in st.values}
            for st in m.status
            if st.hardware_id == "orthoglide_sim"
        ),
        10,
    )
    t0 = time.monotonic()
    proc = _start_driver(children, ros_env, realtime="false", duration="3.0", trajectory="test1",
                         controller="pid", payload="1.983", setpoint_lead="20")
    try:
        t_end = time.monotonic() + 120
        while proc.poll() is None and time.monotonic() < t_end:
            rclpy.spin_once(node, timeout_sec=0.01)
        for _ in range(100):
            rclpy.spin_once(node, timeout_sec=0.01)
    finally:
        if proc.poll() is None:
            proc.kill()
        out = proc.communicate()[0]
        node.destroy_node()
        rclpy.shutdown()
    a, b = np.array(js), np.array(cr)
    assert len(a) > 1000 and len(b) > 1000, out
    # how soon: bench/driver_realtime.py times the first tick (a figure, not a test)
    print(f"first tick on both topics {max(first.values()) - t0:.2f} s after start")
    assert np.all(np.diff(a) > 0) and np.all(np.diff(b) > 0)
    common = np.intersect1d(a, b)
    assert len(common) >= 0.95 * min(len(a), len(b))
    assert np.all(np.mod(common, 1_000_000) == 0)  # simulated time: stamps on the 1 kHz grid
    ref = get_trajectory("test1")
    stamps = sorted(sp)[:500]
    np.testing.assert_allclose(
        [sp[s][1] for s in stamps], ref.evaluate(np.array(stamps) * 1e-9)[0], atol=1e-12
    )
    ahead = [s / 1e6 - sp[s][0] for s in stamps[100:]]  # tick of the setpoint - ticks received then
    assert np.median(ahead) >= 10
    # once a second (every 1000 ticks); in simulated time the first one can go out before this
    # subscriber is matched (volatile, like every /diagnostics publisher), the last one cannot
    ticks = [int(d["ticks"]) for d in diag]
    assert ticks and ticks[-1] == 3000 and all(t % 1000 == 0 for t in ticks), diag
    # no deadlines in simulated time
    assert diag[-1]["controller"] == "pid" and diag[-1]["late"] == "0", diag


def test_external_mode_lockstep_applies_each_command_at_its_tick(ros_env):
    """Simulated time, controller external: the driver waits for the command computed from the
    joint state of tick k and applies it at tick k (age 0), the outside PID keeping the robot on
    its setpoints."""
    import rclpy
    from driver_realtime import ExternalController
    from rclpy.executors import SingleThreadedExecutor

    rclpy.init()
    node = rclpy.create_node("test_external_controller")
    ctl = ExternalController(node)
    ex = SingleThreadedExecutor()
    ex.add_node(node)
    threading.Thread(target=ex.spin, daemon=True).start()
    proc = _start_driver(children, ros_env, realtime="false", duration="1.5",
                         controller="external", trajectory="test1")
    try:
        out = proc.communicate(timeout=120)[0]
        time.sleep(0.3)
    finally:
        ex.shutdown()
        node.destroy_node()
        rclpy.shutdown()
    assert "1500 ticks" in out and "stopped" not in out, out
    ages = [round((t - c) / 1e6) for t, c in ctl.applied if c is not None]
    assert len(ages) > 1300 and set(ages) == {0}, (len(ages), set(ages))


@pytest.mark.skipif(os.cpu_count() is None, reason="needs the real-time loop")
def test_external_mode_real_time_applies_commands_from_the_next_tick(ros_env):
    """Real time, controller external, a controller in this process: the driver applies the
    outside commands, each from a tick after the joint state it was computed from. How many ticks
    old they are depends on the machine's scheduling (median 1 on a quiet day, 5 on a jittery VM
    with every tick late): a timing figure, measured by bench/driver_realtime.py, not asserted
    here — and so is whether a loop closed that late keeps the robot in its stroke: when it does
    not, the driver must stop the robot at the stroke and say so (safety), which the test accepts.
    The lockstep test above checks, deterministically, that each command is applied at its own
    tick."""
    import rclpy  # noqa: F401
    from driver_realtime import external_run


    rclpy.init()
    node = rclpy.create_node("test_external_realtime")
    try:
        # a gentle outside loop (20 rad/s): the test is about how the driver applies commands, and
        # a 40 rad/s loop closed over DDS on a loaded 2-core test machine can lose the robot
        # (seen once in a clean-clone run: the driver stopped it at the stroke, as it should)
        ext = external_run(node, 3.0, omega=20.0)
    finally:
        node.destroy_node()
        rclpy.shutdown()
    ages = ext["ages"]
    # how many commands arrive in time is the machine's (60 of 3000 with the load average at 7
    # on 2 cores, > 2000 when quiet): only that some did, and how the driver applied them
    assert len(ages) >= 10, ext["log_tail"]
    print(
        f"ages: median {np.median(ages)}, {np.mean(ages <= 1) * 100:.1f} % <= 1; late {ext['late']}"
    )
    assert ages.min() >= 1, ext["log_tail"]
    stopped = [line for line in ext["log_tail"] if "stopped" in line]
    if stopped:  # a loop closed too late lost the robot: stopped at the stroke, with the reason
        assert all("left the actuator stroke" in line for line in stopped), stopped
    else:
        assert ext["ticks"] >= 2900, ext["log_tail"]


def test_a_missing_feed_forward_is_held_a_few_ticks_then_the_pid_runs_alone():
    """ctc: a tick's own feed-forward when it came (even long ahead, in a batch), else the last
    one for FF_HOLD_TICKS ticks at most, then none (PID + velocity feed-forward alone), each
    case counted; never the model current of a tick long past."""
    from orthoglide_sim.orthoglide.session import FF_HOLD_TICKS

    s = DriverSession(trajectory="test1", controller="ctc", noise=False)
    s.pid.current = lambda *args: np.zeros(3)  # the PID's share out: control() is the model's
    ff = {k: np.array([0.001, 0.002, 0.003]) * (1 + k) for k in range(2 * FF_HOLD_TICKS + 20)}
    for k in range(10):  # one batch of 10 ticks, all ahead of their tick
        s.offer_feedforward(k, ff[k])
    n = 10 + FF_HOLD_TICKS + 3
    got = []
    for _ in range(n):
        got.append(s.control(s.measure()))
        s.advance()
    want = [ff[k] for k in range(10)] + [ff[9]] * FF_HOLD_TICKS + [np.zeros(3)] * 3
    np.testing.assert_array_equal(np.array(got), np.array(want))
    assert (s.stats.ff_used, s.stats.ff_missing, s.stats.ff_expired) == (10, FF_HOLD_TICKS + 3, 3)
    s.offer_feedforward(n - 5, ff[0])  # for a tick already past: never used
    s.offer_feedforward(n, ff[n])  # a fresh one: used at its tick
    np.testing.assert_array_equal(s.control(s.measure()), ff[n])
    assert (s.stats.ff_used, s.stats.ff_missing) == (11, FF_HOLD_TICKS + 3)


def test_real_time_fault_then_reset_then_on_again(ros_env):
    """Real time, ctc, ticks computed ahead: a NaN feed-forward stops the robot (said once; the
    ticks published are those /diagnostics counts at the stop, none after), reset puts it back and
    the ticks go on with later stamps; a second reset with no fault says so. Every wait is for an
    event (a bound only against a hang): the machine's speed changes how long, not what. The
    checks are on stamps, not on list positions: under load the subscription may match after the
    driver's first ticks, so the first stamp heard need not be tick 0."""
    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState
    from std_srvs.srv import Trigger

    from orthoglide_msgs.msg import CurrentReference

    rclpy.init()
    node = rclpy.create_node("test_driver_fault")
    js: list[int] = []
    faults: list[dict] = []  # the driver's /diagnostics values while it is stopped
    qos = QoSProfile(depth=5000, reliability=ReliabilityPolicy.RELIABLE)
    node.create_subscription(
        JointState, "/orthoglide/joint_states", lambda m: js.append(_stamp(m)), qos
    )
    node.create_subscription(DiagnosticArray, "/diagnostics", lambda m: faults.extend(
        v for v in ({kv.key: kv.value for kv in st.values} for st in m.status
                    if st.hardware_id == "orthoglide_sim") if v["fault"]), 10)
    pub = node.create_publisher(CurrentReference, "/orthoglide/feedforward", qos)
    reset = node.create_client(Trigger, "/orthoglide_driver/reset")
    proc = _start_driver(children, ros_env, controller="ctc", trajectory="test1", rt_priority="0")

    def spin_until(ready, timeout=HANG_S):
        t_end = time.monotonic() + timeout
        while not ready() and time.monotonic() < t_end and proc.poll() is None:
            rclpy.spin_once(node, timeout_sec=0.01)
        return ready()

    def call_reset():
        future = reset.call_async(Trigger.Request())
        assert spin_until(future.done)
        return future.result()

    try:
        assert spin_until(lambda: len(js) > 300)
        # a message sent before the driver's subscription is matched is lost (volatile QoS): the
        # loaded machine's slow discovery, not the driver, was why no fault came
        assert spin_until(lambda: pub.get_subscription_count() > 0)
        msg = CurrentReference(name=["q11", "q12", "q13"], current=[float("nan"), 0.0, 0.0])
        t_nan = js[-1] + 100 * TICK_NS
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(t_nan, 1_000_000_000)
        pub.publish(msg)
        assert spin_until(lambda: faults)  # stopped on receipt: its counters with the fault
        assert reset.wait_for_service(timeout_sec=HANG_S)
        first = call_reset()
        assert first.success and "was stopped: refused feed-forward" in first.message, first.message
        n_stopped = int(faults[0]["ticks"])
        # the driver's tick of a stamp: the fault names the tick the NaN was stamped for
        k_nan = int(re.search(r"for tick (-?\d+)", faults[0]["fault"]).group(1))
        start_ns = t_nan - k_nan * TICK_NS
        t_stop = start_ns + (n_stopped - 1) * TICK_NS  # its last tick published before the stop
        assert spin_until(lambda: sum(t > t_stop for t in js[-301:]) > 300)
        again = call_reset()
        assert again.success and again.message == "no fault to clear"
    finally:
        proc.terminate()
        out = proc.communicate(timeout=HANG_S)[0]
        node.destroy_node()
        rclpy.shutdown()
    stamps = np.array(js)
    assert np.all(np.diff(stamps) > 0)  # the stamps go on after the stop: later, never repeated
    before, after = stamps[stamps <= t_stop], stamps[stamps > t_stop]
    # every tick heard before the stop on the 1 kHz grid up to the driver's count at the stop,
    # tick n_stopped - 1; nothing published between it and the reset
    assert np.all(np.diff(before) == TICK_NS) and before[-1] == t_stop, (before[-3:], t_stop)
    assert after[0] - t_stop > TICK_NS and np.all(np.diff(after) == TICK_NS)
    assert out.count("]: stopped: refused feed-forward") == 1, out
