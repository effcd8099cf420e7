"""Bad and unusual inputs to the nodes over real ROS 2: a reason, never a traceback or a dead node.

A best-effort publisher is recorded (the recorder follows the offered QoS, as rosbag2 does); an
integer where a float parameter is expected is fine; an impossible value is a one-line error; the
identification answers with the essential model when asked, and a WLS call does not replace the
latched TLS result a running CTC uses.
"""
from __future__ import annotations

import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
import rclpy

from orthoglide_ident.ros import processes as children  # children end with this process

ROOT = Path(__file__).resolve().parents[2]
RECORDER = "from orthoglide_ident.nodes.recorder import main; import sys; sys.exit(main())"
IDENTIFICATION = (
    "from orthoglide_ident.nodes.identification import main; import sys; sys.exit(main())"
)


def _call(node, cli, request, timeout=60.0):
    assert cli.wait_for_service(timeout_sec=60), f"no service {cli.srv_name}"
    fut = cli.call_async(request)
    rclpy.spin_until_future_complete(node, fut, timeout_sec=timeout)
    assert fut.done(), f"{cli.srv_name} did not answer"
    return fut.result()


def _spin_until(node, done, what: str, timeout: float = 60.0) -> None:
    """Spin ``node`` until ``done()``; the deadline only bounds a hang."""
    t_end = time.monotonic() + timeout
    while not done():
        assert time.monotonic() < t_end, f"not within {timeout:.0f} s: {what}"
        rclpy.spin_once(node, timeout_sec=0.05)


@pytest.fixture
def node():
    rclpy.init()
    n = rclpy.create_node("test_node_inputs")
    yield n
    n.destroy_node()
    rclpy.shutdown()


def test_best_effort_publisher_is_recorded(spawn_python, node, tmp_path):
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState
    from std_srvs.srv import Trigger

    from orthoglide_ident import bags
    from orthoglide_msgs.msg import CurrentReference, RecorderStatus
    from orthoglide_msgs.srv import StartRecording

    best_effort = QoSProfile(depth=100, reliability=ReliabilityPolicy.BEST_EFFORT)
    pub_js = node.create_publisher(JointState, "/orthoglide/joint_states", best_effort)
    pub_cr = node.create_publisher(CurrentReference, "/orthoglide/current_reference", best_effort)
    rec = spawn_python(RECORDER, "--ros-args", "-p", f"output_dir:={tmp_path}")
    start = node.create_client(StartRecording, "/orthoglide/recorder/start")
    stop = node.create_client(Trigger, "/orthoglide/recorder/stop")
    # the recorder's discovery (every second) subscribes as the publishers offer: best effort
    _spin_until(node, lambda: pub_js.get_subscription_count() and pub_cr.get_subscription_count(),
                "the recorder matched with the best-effort publishers")
    res = _call(node, start, StartRecording.Request(condition="unloaded", name="be"))
    assert res.success, res.message
    names = ["q11", "q12", "q13"]
    for k in range(300):
        js = JointState(name=names, position=[0.01 * k, 0.0, 0.0])
        js.header.stamp.sec, js.header.stamp.nanosec = 5, k * 1_000_000
        pub_js.publish(js)
        pub_cr.publish(CurrentReference(header=js.header, name=names, current=[0.1, 0.0, 0.0]))
        time.sleep(0.002)
    # best effort on loopback: nearly everything arrives; stop once the recorder wrote that much
    status = []
    latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)
    node.create_subscription(RecorderStatus, "/orthoglide/recorder/status", status.append, latched)
    _spin_until(node, lambda: status and status[-1].ticks_written >= 250,
                "the recorder's status counts 250 ticks written")
    res = _call(node, stop, Trigger.Request())
    assert res.success, res.message
    data = bags.read_bag(tmp_path / "be")
    assert len(data.joint_states.stamps_ns) >= 250  # best effort on loopback: nearly everything
    assert rec.poll() is None


def test_parameter_types_are_lenient_and_bad_values_are_one_line(ros_env):
    def run(module, *params):
        args = [sys.executable, "-m", module, "--ros-args"]
        for p in params:
            args += ["-p", p]
        return children.run(args, env=ros_env, capture_output=True, text=True, timeout=60)

    # ints for floats
    ok = run("orthoglide_sim.nodes.driver", "duration:=1", "realtime:=false", "payload:=2")
    assert ok.returncode == 0 and "1000 ticks" in ok.stderr, ok.stderr
    bad = run("orthoglide_ident.nodes.recorder", "queue_depth:=-5")
    assert bad.returncode == 2 and "queue_depth" in bad.stderr and "Traceback" not in bad.stderr
    bad = run("orthoglide_sim.nodes.driver", "duration:=soon")
    assert bad.returncode == 2 and "parameter duration: expected float" in bad.stderr
    bad = run("orthoglide_sim.nodes.driver", "controller:=turbo")
    assert bad.returncode == 2 and "controller must be one of" in bad.stderr


def test_essential_answer_and_wls_keeps_the_latched_tls(spawn_python, node):
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

    from orthoglide_msgs.msg import IdentifiedParameters
    from orthoglide_msgs.srv import Identify

    spawn_python(
        IDENTIFICATION, "--ros-args", "-p", f"bag_dir:={ROOT / 'bags'}", "-p", "live:=false"
    )
    cli = node.create_client(Identify, "/orthoglide/identify")
    bags = [str(ROOT / "bags/unloaded"), str(ROOT / "bags/loaded")]
    tls = _call(node, cli, Identify.Request(bags=bags), timeout=120)
    assert tls.success and len(tls.parameters.names) == 61, tls.message
    ess = _call(node, cli, Identify.Request(bags=bags, essential=True), timeout=300)
    assert ess.success and 0 < len(ess.parameters.names) < 61, ess.message
    wls = _call(node, cli, Identify.Request(bags=bags, method="wls"), timeout=120)
    assert wls.success and wls.parameters.method == "wls", wls.message
    got: dict[str, list] = {"tls": [], "wls": []}
    latched = QoSProfile(
        depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL, reliability=ReliabilityPolicy.RELIABLE
    )
    node.create_subscription(
        IdentifiedParameters, "/orthoglide/identified_parameters", got["tls"].append, latched
    )
    node.create_subscription(
        IdentifiedParameters, "/orthoglide/identified_parameters/wls", got["wls"].append, latched
    )
    t_end = time.time() + 20
    while not (got["tls"] and got["wls"]) and time.time() < t_end:
        rclpy.spin_once(node, timeout_sec=0.1)
    # the essential TLS, last TLS call
    assert got["tls"][-1].method == "tls" and len(got["tls"][-1].names) < 61
    assert got["wls"][-1].method == "wls"


def test_namespace_moves_the_recorder_and_empty_or_refused_recordings_fail(spawn_python, node,
                                                                            tmp_path):
    """``-r __ns:=/robot2`` moves every name; a refused start leaves no folder behind; a stop with
    nothing written answers success false (rosbag2 would leave an empty bag and say nothing)."""
    from std_srvs.srv import Trigger

    from orthoglide_msgs.srv import StartRecording

    rec = spawn_python(
        RECORDER, "--ros-args", "-r", "__ns:=/robot2", "-p", f"output_dir:={tmp_path}"
    )
    start = node.create_client(StartRecording, "/robot2/orthoglide/recorder/start")
    stop = node.create_client(Trigger, "/robot2/orthoglide/recorder/stop")
    res = _call(node, start, StartRecording.Request(condition="loaded", payload_mass=0.0, name="x"))
    assert not res.success and "payload_mass" in res.message
    assert list(tmp_path.iterdir()) == []  # the refused start created nothing
    res = _call(node, start, StartRecording.Request(condition="unloaded", name="quiet"))
    assert res.success, res.message
    topics = dict(node.get_topic_names_and_types())
    assert "/robot2/orthoglide/recorder/status" in topics
    assert "/orthoglide/recorder/status" not in topics
    deadline = time.monotonic() + 10.0  # discovery of the new subscription takes a moment
    while not (subs := node.get_subscriptions_info_by_topic("/robot2/orthoglide/joint_states")) \
            and time.monotonic() < deadline:
        rclpy.spin_once(node, timeout_sec=0.1)
    assert subs, "the recorder does not subscribe to the namespaced joint states"
    time.sleep(0.5)
    res = _call(node, stop, Trigger.Request())
    assert not res.success and "nothing recorded on /robot2/orthoglide/joint_states" in res.message
    assert rec.poll() is None


BAD_PARAMETER_FILES = [
    ("/**:\n  ros__parameters:\n    decimation: [1, 2\n", "is not valid YAML (line 4)"),
    ("just a line of text\n", "is not a ROS 2 parameter file"),
    ("orthoglide_ctc:\n  decimation: 5\n", "is not a ROS 2 parameter file"),
    (None, "cannot read parameter file"),
]


@pytest.mark.parametrize(
    "module", ["orthoglide_ident.nodes.identification", "orthoglide_ident.nodes.ctc"]
)
@pytest.mark.parametrize("text, reason", BAD_PARAMETER_FILES)
def test_a_bad_parameter_file_is_one_line_and_exit_2(ros_env, tmp_path, module, text, reason):
    """What rcl refused with a traceback (broken YAML, a missing file) or ignored silently (not a
    parameter file at all): one line naming the file, exit 2."""
    f = tmp_path / "params.yaml"
    if text is not None:
        f.write_text(text)
    out = children.run(
        [sys.executable, "-m", module, "--ros-args", "--params-file", str(f)],
        env=ros_env,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert out.returncode == 2, out.stderr
    assert reason in out.stderr and str(f) in out.stderr, out.stderr
    assert len(out.stderr.strip().splitlines()) == 1 and "Traceback" not in out.stderr


def test_a_parameter_file_with_a_bad_value_or_a_typo(ros_env, tmp_path):
    """A bad value stops the node with the parameter's reason; a name the node does not have (a
    typo) is warned about and the node runs."""
    f = tmp_path / "identification.yaml"
    f.write_text("/**:\n  ros__parameters:\n    decimation: -3\n")
    out = children.run(
        [
            sys.executable,
            "-m",
            "orthoglide_ident.nodes.identification",
            "--ros-args",
            "--params-file",
            str(f),
        ],
        env=ros_env,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert out.returncode == 2 and "decimation" in out.stderr and "Traceback" not in out.stderr, (
        out.stderr
    )
    f.write_text("/**:\n  ros__parameters:\n    batch: 5\n    curent_limit: [0.5, 0.5, 0.5]\n")
    proc = children.popen(
        [sys.executable, "-m", "orthoglide_ident.nodes.ctc", "--ros-args", "--params-file", str(f)],
        env=ros_env,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    watchdog = threading.Timer(60, proc.terminate)  # the line never coming must not hang the test
    watchdog.start()
    try:
        lines = []
        for line in proc.stdout:
            lines.append(line)
            if "ignored parameter" in line:
                break
        assert "ignored parameter(s) this node does not have: curent_limit (a typo?" in lines[-1], (
            lines
        )
    finally:
        watchdog.cancel()
        proc.terminate()
        assert proc.wait(30) == 0
