"""The identification node over real ROS 2: service answers, latched result, bad input, busy."""
from __future__ import annotations

import os
import sys
import time
from pathlib import Path

import pytest

from orthoglide_ident.ros import processes as children  # children end with this process

ROOT = Path(__file__).resolve().parents[2]
BAGS = ROOT / "bags"

NODE = "from orthoglide_ident.nodes.identification import main; import sys; sys.exit(main())"


@pytest.fixture
def node(spawn_python):
    proc = spawn_python(NODE, "--ros-args", "-p", f"bag_dir:={BAGS}")
    yield proc
    assert proc.poll() is None, "the node died: " + (
        proc.communicate()[1] if proc.poll() is not None else ""
    )


@pytest.fixture
def client():
    import rclpy
    from rclpy.node import Node

    from orthoglide_msgs.srv import Identify

    rclpy.init()
    n = Node("test_identify_client")
    cli = n.create_client(Identify, "/orthoglide/identify")
    assert cli.wait_for_service(timeout_sec=60), "service /orthoglide/identify did not appear"
    yield n, cli
    n.destroy_node()
    rclpy.shutdown()


def call(n, cli, timeout=120.0, **fields):
    import rclpy

    from orthoglide_msgs.srv import Identify

    req = Identify.Request()
    for k, v in fields.items():
        setattr(req, k, v)
    fut = cli.call_async(req)
    rclpy.spin_until_future_complete(n, fut, timeout_sec=timeout)
    assert fut.done(), "no answer"
    return fut.result()


def read_available(pipe, until: str, timeout: float = 10.0) -> str:
    """What a running process has written to ``pipe`` so far, waiting for ``until`` to appear."""
    fd, text, t0 = pipe.fileno(), "", time.time()
    os.set_blocking(fd, False)
    try:
        while until not in text and time.time() - t0 < timeout:
            try:
                text += os.read(fd, 1 << 16).decode(errors="replace")
            except BlockingIOError:
                time.sleep(0.1)
    finally:
        os.set_blocking(fd, True)
    return text


def test_identify_service_answers_and_latches_the_result(node, client):
    import rclpy
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

    from orthoglide_msgs.msg import IdentifiedParameters

    n, cli = client
    res = call(n, cli)  # no bags named: every bag under bag_dir (the sample pair)
    assert res.success, res.message
    gains = list(res.parameters.drive_gains)
    # the sample bags' plant has g_tau = 2170, 2100, 2070 N/A; 10 s records: within 1 %
    for g, true in zip(gains, (2170.0, 2100.0, 2070.0)):
        assert abs(g / true - 1) < 0.01, gains
    assert res.parameters.method == "tls" and len(res.parameters.names) == 61
    assert "; current-loop lag q11 " in res.message  # lag_model: auto, the bags repeat a trajectory
    assert abs(res.parameters.payload_mass - 1.983) < 1e-9
    # the core's lines of the call are in the node's log (ros/core_log.py)
    log = read_available(node.stderr, until="current-loop lag (lag_model: auto)")
    assert "IDIM-TLS on" in log and "current-loop lag (lag_model: auto)" in log, log[-2000:]

    # a late subscriber still gets the result (transient local, depth 1)
    got = []
    qos = QoSProfile(
        depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL, reliability=ReliabilityPolicy.RELIABLE
    )
    n.create_subscription(
        IdentifiedParameters, "/orthoglide/identified_parameters", got.append, qos
    )
    t0 = time.time()
    while not got and time.time() - t0 < 20:
        rclpy.spin_once(n, timeout_sec=0.2)
    assert got and list(got[0].drive_gains) == gains

    # bad input: a one-line reason and success false, and the node keeps serving
    bad = call(n, cli, bags=[str(BAGS / "unloaded")])
    assert not bad.success and "loaded" in bad.message and "\n" not in bad.message
    missing = call(n, cli, bags=["/nonexistent/bag"])
    assert not missing.success and "\n" not in missing.message and missing.message
    wrong_mass = call(
        n, cli, bags=[str(BAGS / "unloaded"), str(BAGS / "loaded")], payload_mass=1.136
    )
    assert not wrong_mass.success and "1.136" in wrong_mass.message


@pytest.fixture
def consistent_node(spawn_python):
    proc = spawn_python(NODE, "--ros-args", "-p", f"bag_dir:={BAGS}", "-p", "consistent:=true",
                        "-p", "live:=false")
    yield proc
    assert proc.poll() is None, "the node died: " + (
        proc.communicate()[1] if proc.poll() is not None else ""
    )


def test_option_consistent_answers_with_real_bodies_and_latches_them(consistent_node, client):
    import rclpy
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

    from orthoglide_msgs.msg import IdentifiedParameters

    n, cli = client
    res = call(n, cli)
    assert res.success, res.message
    assert "; physical consistency: the unconstrained answer is" in res.message
    got = []
    qos = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                     reliability=ReliabilityPolicy.RELIABLE)
    n.create_subscription(IdentifiedParameters, "/orthoglide/identified_parameters/consistent",
                          got.append, qos)
    t0 = time.time()
    while not got and time.time() - t0 < 20:
        rclpy.spin_once(n, timeout_sec=0.2)
    assert got and got[0].method == "tls consistent"
    assert list(got[0].names) == list(res.parameters.names)
    assert list(got[0].drive_gains) == list(res.parameters.drive_gains)  # held
    assert list(got[0].values) != list(res.parameters.values)


def test_a_call_while_busy_is_refused_at_once(node, client):
    n, cli = client
    import rclpy

    from orthoglide_msgs.srv import Identify

    futures = []
    for _ in range(2):
        req = Identify.Request()
        futures.append(cli.call_async(req))
    t0 = time.time()
    while not all(f.done() for f in futures) and time.time() - t0 < 120:
        rclpy.spin_once(n, timeout_sec=0.1)
    answers = [f.result() for f in futures]
    assert sorted(a.success for a in answers) == [False, True], [a.message for a in answers]
    assert any(a.message.startswith("busy") for a in answers)


def test_help_needs_no_ros():
    out = children.run(
        [sys.executable, "-c", NODE, "--help"], capture_output=True, text=True, timeout=30
    )
    assert (
        out.returncode == 0
        and out.stdout.startswith("usage:")
        and "orthoglide/identify" in out.stdout
        and "orthoglide/identification/live" in out.stdout
    )


def test_live_identification_warns_and_survives_nan_and_wrong_names(spawn_python, tmp_path):
    """A recording fed with NaN positions, a burst with other joint names and lost ticks: the live
    estimate goes on, says what happened in its warnings, and the node keeps answering."""
    import rclpy
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState
    from std_srvs.srv import Trigger

    from orthoglide_msgs.msg import CurrentReference, LiveIdentification, RecorderStatus
    from orthoglide_msgs.srv import Identify, StartRecording
    from orthoglide_sim.orthoglide.record import simulate

    rec = simulate(5.0, payload="none", trajectory="exciting", seed=3)
    spawn_python(NODE, "--ros-args", "-p", f"bag_dir:={tmp_path}")
    spawn_python("from orthoglide_ident.nodes.recorder import main; import sys; sys.exit(main())",
                 "--ros-args", "-p", f"output_dir:={tmp_path}")
    rclpy.init()
    n = rclpy.create_node("test_live_feeder")
    try:
        live: list = []
        n.create_subscription(
            LiveIdentification, "/orthoglide/identification/live", live.append, 10
        )
        status: list = []
        latched = QoSProfile(
            depth=1,
            durability=DurabilityPolicy.TRANSIENT_LOCAL,
            reliability=ReliabilityPolicy.RELIABLE,
        )
        n.create_subscription(RecorderStatus, "/orthoglide/recorder/status", status.append, latched)
        pub_js = n.create_publisher(JointState, "/orthoglide/joint_states", 1000)
        pub_cr = n.create_publisher(CurrentReference, "/orthoglide/current_reference", 1000)
        start = n.create_client(StartRecording, "/orthoglide/recorder/start")
        stop = n.create_client(Trigger, "/orthoglide/recorder/stop")
        ident = n.create_client(Identify, "/orthoglide/identify")
        for cli in (start, stop, ident):
            assert cli.wait_for_service(timeout_sec=60)
        t_end = time.time() + 30
        while (
            n.count_subscribers("/orthoglide/joint_states") < 2 or not status
        ) and time.time() < t_end:
            rclpy.spin_once(n, timeout_sec=0.1)
        fut = start.call_async(StartRecording.Request(condition="unloaded", name="bad_data"))
        rclpy.spin_until_future_complete(n, fut, timeout_sec=30)
        assert fut.result().success, fut.result().message
        names = ["q11", "q12", "q13"]
        for k in range(len(rec.stamps_ns)):
            if 1500 <= k < 1520:
                continue  # lost ticks
            q = rec.q[k].copy()
            if 1000 <= k < 1005:
                q[1] = float("nan")
            js = JointState(
                name=["a", "b", "c"] if 2000 <= k < 2010 else names, position=[float(x) for x in q]
            )
            js.header.stamp.sec, js.header.stamp.nanosec = divmod(
                int(rec.stamps_ns[k]) + 10**9, 10**9
            )
            pub_js.publish(js)
            pub_cr.publish(
                CurrentReference(
                    header=js.header, name=names, current=[float(x) for x in rec.v_tau[k]]
                )
            )
            if k % 50 == 0:
                rclpy.spin_once(n, timeout_sec=0.0)
                time.sleep(0.04)  # paces the publisher (about 1.25 kHz), within the queue depths
        fut = stop.call_async(Trigger.Request())
        rclpy.spin_until_future_complete(n, fut, timeout_sec=30)
        t_end = time.monotonic() + 60  # until the live feed said all three (a bound on a hang)
        while time.monotonic() < t_end and not (
                all(w in " | ".join(w for m in live for w in m.warnings) for w in ("lost", "names"))
                and live[-1].unloaded_seconds > 1.5):
            rclpy.spin_once(n, timeout_sec=0.1)
        warnings = " | ".join(w for m in live for w in m.warnings)
        assert "lost" in warnings and ("NaN" in warnings or "non-finite" in warnings), warnings
        assert "names" in warnings, warnings
        assert live[-1].unloaded_seconds > 1.5 and live[-1].status.startswith("unloaded only"), (
            live[-1]
        )
        # the live data: no payload yet, refused with the reason
        fut = ident.call_async(Identify.Request())
        rclpy.spin_until_future_complete(n, fut, timeout_sec=60)
        res = fut.result()
        assert not res.success and "loaded" in res.message and "\n" not in res.message
    finally:
        n.destroy_node()
        rclpy.shutdown()


def test_option_changes_with_a_wrong_type_or_value_are_refused_with_a_reason(node, client):
    import rclpy
    from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
    from rcl_interfaces.srv import SetParameters

    n, _ = client
    cli = n.create_client(SetParameters, "/orthoglide_identification/set_parameters")
    assert cli.wait_for_service(timeout_sec=30)

    def set_one(name, **value):
        fut = cli.call_async(
            SetParameters.Request(parameters=[Parameter(name=name, value=ParameterValue(**value))])
        )
        rclpy.spin_until_future_complete(n, fut, timeout_sec=30)
        return fut.result().results[0]

    bad_type = set_one("filter_currents", type=ParameterType.PARAMETER_STRING, string_value="maybe")
    assert (
        not bad_type.successful
        and "filter_currents" in bad_type.reason
        and "bool" in bad_type.reason
    )
    bad_value = set_one("r_sigma", type=ParameterType.PARAMETER_DOUBLE, double_value=0.5)
    assert not bad_value.successful and "r_sigma" in bad_value.reason
    assert set_one(
        "filter_currents", type=ParameterType.PARAMETER_BOOL, bool_value=False
    ).successful
    # `ros2 param set /orthoglide_identification lag_model off`: YAML's false, meant as the word
    assert set_one("lag_model", type=ParameterType.PARAMETER_BOOL, bool_value=False).successful
    on = set_one("lag_model", type=ParameterType.PARAMETER_BOOL, bool_value=True)
    assert not on.successful and "lag_model must be 'auto' or 'off'" in on.reason
    assert set_one("lag_model", type=ParameterType.PARAMETER_STRING, string_value="auto").successful


def test_a_bag_deleted_before_it_is_read_and_a_restart_without_live_data(node, client, tmp_path):
    """A bag removed between the user's listing and the read (its folder, or its .mcap files): a
    one-line reason, success false, and the node serves the next call. A node restarted (its live
    data gone) asked with no bag identifies from the recordings in bag_dir and says so."""
    import shutil

    n, cli = client
    for name in ("unloaded", "loaded"):
        shutil.copytree(BAGS / name, tmp_path / name)
    pair = [str(tmp_path / "unloaded"), str(tmp_path / "loaded")]
    for f in (tmp_path / "loaded").glob("*.mcap"):
        f.unlink()
    res = call(n, cli, bags=pair)
    assert (
        not res.success
        and res.message == f"{pair[1]}: files listed in metadata.yaml are missing: loaded_0.mcap"
    )
    shutil.rmtree(tmp_path / "loaded")
    res = call(n, cli, bags=pair)
    assert not res.success and res.message.startswith(f"{pair[1]}: no such bag")
    res = call(n, cli)  # no bag named, no live data since this node started: bag_dir's recordings
    assert res.success and res.message.endswith("; from 2 bag(s) of bag_dir (no live data)"), (
        res.message
    )
    assert node.poll() is None


def test_a_partial_answer_succeeds_says_which_and_is_not_latched(spawn_python, tmp_path):
    """UR5 records whose payload does not load wrist_3 (tests/axial_payload.py): success, the
    reply names the gain not determined and why, the message carries the flags, and the
    latched topic (what the ctc takes) stays empty."""
    import rclpy
    from axial_payload import write_axial_bags
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

    from orthoglide_msgs.msg import IdentifiedParameters
    from orthoglide_msgs.srv import Identify

    write_axial_bags(tmp_path, 20.0)
    proc = spawn_python(NODE, "--ros-args", "-p", f"bag_dir:={tmp_path}", "-p", "robot:=ur5",
                        "-p", "live:=false")
    rclpy.init()
    try:
        n = rclpy.create_node("test_partial_client")
        cli = n.create_client(Identify, "/orthoglide/identify")
        assert cli.wait_for_service(timeout_sec=60), "service /orthoglide/identify did not appear"
        res = call(n, cli)
        assert res.success, res.message
        p = res.parameters
        assert list(p.drive_gains_determined) == [True] * 5 + [False]
        assert p.drive_gains_reason[5].startswith("the payload adds almost no torque")
        assert "not determined" in res.message and "partial answer, not latched" in res.message
        assert "\n" not in res.message
        got = []
        qos = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                         reliability=ReliabilityPolicy.RELIABLE)
        n.create_subscription(IdentifiedParameters, "/orthoglide/identified_parameters",
                              got.append, qos)
        sub = list(n.subscriptions)[-1]  # the one just made
        t_end = time.monotonic() + 30  # matched with the node's latched publisher (a hang bound)
        while sub.get_publisher_count() < 1 and time.monotonic() < t_end:
            rclpy.spin_once(n, timeout_sec=0.05)
        assert sub.get_publisher_count() >= 1
        t_end = time.monotonic() + 1.0  # a latched sample comes with the match: a second after it
        while time.monotonic() < t_end:
            rclpy.spin_once(n, timeout_sec=0.1)
        assert not got  # a late subscriber of the latched topic gets nothing: no full answer yet
        n.destroy_node()
    finally:
        rclpy.shutdown()
    assert proc.poll() is None, "the node died"
