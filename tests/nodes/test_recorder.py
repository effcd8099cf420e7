"""Recorder node, across processes: services and misuse, recording that loses nothing, split,
SIGINT/SIGTERM close the bag, SIGKILL leaves a readable bag, a write error keeps what was written.
The faults a user meets (a failed stop, a callback that raises, a vanished source, a file-size
limit, kill -9 and a restart) are in test_recorder_faults.py.

No test waits "long enough" before a stop: a publisher that ends waits until the recorder's
reader has every tick (DDS acknowledgements), and the stop writes everything the recorder's
subscriptions hold, so what was published is in the bag whatever the machine's speed.
"""

from __future__ import annotations

import errno
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from conftest import stop_processes

from orthoglide_ident import bags
from orthoglide_ident.bags import Recording
from orthoglide_ident.bags.encoding import encode_messages
from orthoglide_ident.bags.info import find_gaps
from orthoglide_ident.bags.topics import (
    CURRENT_REFERENCE_TOPIC,
    JOINT_STATE_TYPE,
    JOINT_STATES_TOPIC,
    default_qos,
)
from orthoglide_ident.ros import processes as children  # children end with this process

ROOT = Path(__file__).resolve().parents[2]
PUBLISHER = ROOT / "bench" / "recorder_publisher.py"


# -- a write error, without ROS ------------------------------------------------------------------
class _Log:
    def __init__(self) -> None:
        self.errors: list[str] = []

    def error(self, m: str) -> None:
        self.errors.append(m)

    warning = info = error


def mcap_messages(files, condition: str, mass: str, channels: list | None = None) -> int:
    """Read every .mcap with the mcap library, CRCs validated (indexed and streamed), check the
    `orthoglide` tag record of each, collect the channels; return the number of messages."""
    from mcap.reader import make_reader
    from mcap.stream_reader import StreamReader

    total = 0
    for f in files:
        with f.open("rb") as fh:
            reader = make_reader(fh, validate_crcs=True)
            meta = {m.name: m.metadata for m in reader.iter_metadata()}
            assert meta["orthoglide"] == {
                "orthoglide.condition": condition,
                "orthoglide.payload_mass": mass,
            }
            total += sum(1 for _ in reader.iter_messages())
            if channels is not None:
                channels.extend(reader.get_summary().channels.values())
        with f.open("rb") as fh:
            list(StreamReader(fh, validate_crcs=True).records)
    return total


def test_disk_full_ends_recording_and_keeps_data(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    writer = bags.BagWriter(
        tmp_path / "full", bags.BagTags("unloaded", 0.0), chunk_duration_s=0.1
    ).open()
    log = _Log()
    rec = Recording(writer, {JOINT_STATES_TOPIC}, 1000.0, log)
    rec.add_topic(JOINT_STATES_TOPIC, JOINT_STATE_TYPE, default_qos())
    stamps = 10**18 + np.arange(2000, dtype=np.int64) * 1_000_000
    msgs = encode_messages(
        JOINT_STATE_TYPE, ("q11", "q12", "q13"), stamps, np.zeros((2000, 3))
    )
    for i in range(1000):
        rec.queue.append(
            (JOINT_STATES_TOPIC, msgs[i].tobytes(), int(stamps[i]), int(stamps[i]))
        )
    deadline = time.monotonic() + 60
    while rec.queue or writer.counts.get(JOINT_STATES_TOPIC, 0) < 1000:  # all 1000 written
        assert time.monotonic() < deadline, "the writer thread did not write 1000 messages in 60 s"
        time.sleep(0.01)
    f = writer._file
    assert f is not None

    def full(data: bytes) -> None:
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(f, "_out", full)
    for i in range(1000, 2000):
        rec.queue.append(
            (JOINT_STATES_TOPIC, msgs[i].tobytes(), int(stamps[i]), int(stamps[i]))
        )
    message = rec.stop()
    assert "write error" in message and "No space left" in message and "kept" in message
    assert log.errors and not rec.alive
    info = bags.bag_info(tmp_path / "full")
    assert not info.closed
    js = info.topics[0]
    assert 900 <= js.count <= 1000 and js.gaps is not None and js.gaps.missing == 0


# -- across processes ----------------------------------------------------------------------------
import rclpy


@pytest.fixture(scope="module")
def client():
    from rcl_interfaces.srv import SetParameters
    from std_srvs.srv import Trigger

    from orthoglide_msgs.srv import StartRecording

    rclpy.init()
    node = rclpy.create_node("recorder_test_client")

    class Client:
        ros_node = node
        start_cli = node.create_client(StartRecording, "/orthoglide/recorder/start")
        stop_cli = node.create_client(Trigger, "/orthoglide/recorder/stop")
        param_cli = node.create_client(SetParameters, "/orthoglide_recorder/set_parameters")

        def _call(self, cli, req):
            for _ in range(3):  # a request sent before the server is matched gets no answer: retry
                fut = cli.call_async(req)
                rclpy.spin_until_future_complete(node, fut, timeout_sec=10.0)
                if fut.done():
                    return fut.result()
                cli.remove_pending_request(fut)
            raise AssertionError("recorder service did not answer")

        def start(self, condition: str, mass: float, name: str = ""):
            return self._call(
                self.start_cli,
                StartRecording.Request(condition=condition, payload_mass=mass, name=name),
            )

        def stop(self):
            return self._call(self.stop_cli, Trigger.Request())

        def set_output_dir(self, path: str) -> None:
            from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue

            value = ParameterValue(type=ParameterType.PARAMETER_STRING, string_value=path)
            res = self._call(
                self.param_cli,
                SetParameters.Request(parameters=[Parameter(name="output_dir", value=value)]),
            )
            assert res.results[0].successful

        def wait_ready(self) -> None:
            assert self.start_cli.wait_for_service(
                timeout_sec=20
            ) and self.stop_cli.wait_for_service(timeout_sec=20)
            time.sleep(0.5)

    yield Client()
    node.destroy_node()
    rclpy.shutdown()


# = ros2 run orthoglide_ident recorder
LAUNCHER = Path(sys.prefix) / "lib" / "orthoglide_ident" / "recorder"


@pytest.fixture
def spawn_recorder(ros_env, tmp_path: Path):
    """``spawn(*params)``: the recorder as users start it (its ros2 run launcher), logging to
    ``tmp_path/recorder<i>.log``; returns once it is ready."""
    procs: list[subprocess.Popen] = []

    def spawn(*params: str) -> subprocess.Popen:
        args = [str(LAUNCHER), "--ros-args", "-p", f"output_dir:={tmp_path / 'bags'}"]
        for p in params:
            args += ["-p", p]
        log = (tmp_path / f"recorder{len(procs)}.log").open("w")
        proc = children.popen(
            args, env=ros_env, stdout=log, stderr=subprocess.STDOUT, cwd=tmp_path
        )
        procs.append(proc)
        deadline = time.monotonic() + 30
        while "recorder ready" not in (tmp_path / f"recorder{len(procs) - 1}.log").read_text():
            assert proc.poll() is None and time.monotonic() < deadline, "recorder did not start"
            time.sleep(0.1)
        return proc

    yield spawn
    stop_processes(procs)


def _publish(ros_env, seconds: float, rate: float = 1000.0) -> subprocess.Popen:
    return children.popen(
        [sys.executable, str(PUBLISHER), "--rate", str(rate), "--duration", str(seconds)],
        env=ros_env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def _sent(pub: subprocess.Popen) -> int:
    out, err = pub.communicate(timeout=60)
    assert pub.returncode == 0, err
    return int(out.split("sent ")[1].split()[0])


def test_misuse_record_split_and_read_back(client, spawn_recorder, ros_env, tmp_path: Path) -> None:
    spawn_recorder("split_duration:=1.0", "chunk_duration:=0.25")
    client.wait_ready()
    # every misuse gets success false and a reason
    res = client.stop()
    assert not res.success and "not recording" in res.message
    for cond, mass, reason in [
        ("heavy", 1.0, "unknown condition"),
        ("loaded", 0.0, "positive payload_mass"),
        ("loaded", -1.0, "positive payload_mass"),
        ("unloaded", 0.5, "takes no payload_mass"),
    ]:
        res = client.start(cond, mass)
        assert not res.success and reason in res.message, res.message
    res = client.start("unloaded", 0.0, "../escape")
    assert not res.success and "bad bag name" in res.message
    blocker = tmp_path / "a_file"
    blocker.write_text("")
    client.set_output_dir(str(blocker / "sub"))
    res = client.start("unloaded", 0.0)
    assert not res.success and "not writable" in res.message
    client.set_output_dir(str(tmp_path / "bags"))

    res = client.start("loaded", 1.136, "run1")
    assert res.success, res.message
    bag = Path(res.bag_path)
    again = client.start("loaded", 1.136, "run2")
    assert not again.success and "already recording" in again.message
    pub = _publish(ros_env, 3.0)
    n = _sent(pub)
    res = client.stop()
    assert (
        res.success
        and f"wrote {n} /orthoglide/current_reference, {n} /orthoglide/joint_states" in res.message
    )
    assert "0 missing on /orthoglide/joint_states" in res.message
    res = client.start("loaded", 1.136, "run1")
    assert not res.success and "exists" in res.message

    # split at 1 s without losing a message: our reader, rosbags and the mcap library agree
    files = sorted(bag.glob("*.mcap"))
    assert len(files) >= 3
    data = bags.read_bag(bag)
    assert data.tags == bags.BagTags("loaded", 1.136) and data.warnings == []
    assert len(data.joint_states.stamps_ns) == n == len(data.current_reference.stamps_ns)
    assert find_gaps(data.joint_states.stamps_ns).missing == 0
    np.testing.assert_array_equal(data.joint_states.stamps_ns, data.current_reference.stamps_ns)

    channels = []
    assert mcap_messages(files, "loaded", "1.136", channels) == 2 * n
    assert all("reliability: reliable" in c.metadata["offered_qos_profiles"] for c in channels)
    from rosbags.highlevel import AnyReader
    from rosbags.rosbag2 import Reader

    with AnyReader([bag]) as reader:
        assert sum(1 for _ in reader.messages()) == 2 * n
    with Reader(bag) as reader:
        assert reader.storage.metadata.custom["orthoglide.payload_mass"] == "1.136"


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_signal_closes_bag(client, spawn_recorder, ros_env, sig: signal.Signals) -> None:
    proc = spawn_recorder()
    client.wait_ready()
    res = client.start("unloaded", 0.0, f"sig{int(sig)}")
    assert res.success, res.message
    n = _sent(_publish(ros_env, 1.0))
    proc.send_signal(sig)
    assert proc.wait(15) == 0
    info = bags.bag_info(res.bag_path)
    assert info.closed and info.tags == bags.BagTags("unloaded", 0.0)
    assert {t.topic: t.count for t in info.topics}[JOINT_STATES_TOPIC] == n


def test_sigkill_leaves_readable_bag(client, spawn_recorder, ros_env) -> None:
    proc = spawn_recorder()
    client.wait_ready()
    res = client.start("loaded", 2.5, "killed")
    assert res.success, res.message
    pub = _publish(ros_env, 4.0)
    assert pub.stdout is not None and pub.stdout.readline().startswith("publishing")
    from rclpy.qos import DurabilityPolicy, QoSProfile

    from orthoglide_msgs.msg import RecorderStatus  # ~2 s written (a status about once a second)
    seen = []
    sub = client.ros_node.create_subscription(
        RecorderStatus,
        "/orthoglide/recorder/status",
        seen.append,
        QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL),
    )
    deadline = time.monotonic() + 60  # a bound on a hang
    while (
        not (seen and seen[-1].ticks_written >= 2000)
        and time.monotonic() < deadline
        and pub.poll() is None
    ):
        rclpy.spin_once(client.ros_node, timeout_sec=0.1)
    client.ros_node.destroy_subscription(sub)
    proc.kill()
    proc.wait(10)
    pub.communicate(timeout=30)
    data = bags.read_bag(res.bag_path)
    assert data.tags == bags.BagTags("loaded", 2.5)
    assert (
        len(data.warnings) == 1
        and "killed_0.mcap" in data.warnings[0]
        and "not closed" in data.warnings[0]
    )
    n = len(data.joint_states.stamps_ns)
    assert n >= 1000  # ~2 s recorded, at most one 0.5 s chunk lost
    assert find_gaps(data.joint_states.stamps_ns).missing == 0
    info = bags.bag_info(res.bag_path)
    assert not info.closed and "NOT CLOSED" in info.to_text()


# -- from the real simulator driver ---------------------------------------------------------------
DRIVER_SECONDS = 6.0


def _wait_for(proc: subprocess.Popen, log: Path, text: str, timeout: float, spin=None) -> None:
    deadline = time.monotonic() + timeout
    while text not in log.read_text():
        assert proc.poll() is None, f"exited before {text!r}:\n{log.read_text()}"
        assert time.monotonic() < deadline, f"no {text!r} after {timeout} s:\n{log.read_text()}"
        spin() if spin else time.sleep(0.1)


@pytest.fixture(scope="module")
def driver_bag(client, tmp_path_factory, request):
    """Record the real driver (realtime, exciting trajectory, unloaded): start recording about 1 s
    after its first tick, freeze the recorder (SIGSTOP) for 0.3 s 1.5 s later; the driver stops
    after DRIVER_SECONDS, then the recording is stopped at once. Deterministic (issue 26: the last
    360 ms were once missing): the driver leaves only when the recorder's reader has every tick
    (acknowledged), and the stop writes everything the recorder's subscriptions hold.

    Returns (bag path, stop message, ticks the driver says it published, the stamp of its first
    tick, stamps an independent listener received)."""
    from conftest import ros_environment
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState

    tmp = tmp_path_factory.mktemp("driver_bag")
    env = ros_environment()
    procs = []
    try:
        rec_log = tmp / "recorder.log"
        procs.append(children.popen(
            [sys.executable, "-m", "orthoglide_ident.nodes.recorder", "--ros-args",
             "-p", f"output_dir:={tmp / 'bags'}"],
            env=env, stdout=rec_log.open("w"), stderr=subprocess.STDOUT, cwd=tmp))
        _wait_for(procs[0], rec_log, "recorder ready", 30)
        client.wait_ready()

        # an independent listener: the stamps of every tick the driver published
        heard: list[int] = []
        node = client.ros_node
        qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10000,
                         reliability=ReliabilityPolicy.RELIABLE)
        sub = node.create_subscription(
            JointState, JOINT_STATES_TOPIC,
            lambda m: heard.append(m.header.stamp.sec * 10**9 + m.header.stamp.nanosec), qos)

        def spin() -> None:
            rclpy.spin_once(node, timeout_sec=0.05)

        drv_log = tmp / "driver.log"
        driver = children.popen(
            [sys.executable, "-m", "orthoglide_sim.nodes.driver", "--ros-args",
             "-p", "realtime:=true", "-p", f"duration:={DRIVER_SECONDS}",
             "-p", "trajectory:=exciting", "-p", "controller:=pid", "-p", "payload:=none"],
            env=env, stdout=drv_log.open("w"), stderr=subprocess.STDOUT, cwd=tmp)
        procs.append(driver)
        # wait for the first tick (the driver publishes within a second or two)
        deadline = time.monotonic() + 240
        while not heard:
            assert driver.poll() is None, f"driver exited:\n{drv_log.read_text()}"
            assert time.monotonic() < deadline, f"driver never published:\n{drv_log.read_text()}"
            spin()
        end = time.monotonic() + 1.0  # start mid-stream, about 1 s into the run
        while time.monotonic() < end:
            spin()
        res = client.start("unloaded", 0.0, "driver")
        assert res.success, res.message
        end = time.monotonic() + 1.5
        while time.monotonic() < end:
            spin()
        # a recorder starved of CPU for 0.3 s: the driver's reliable history (5 s) must cover it
        # (with the former depth of 100 a 0.5 s stall lost ~280 ticks per topic)
        procs[0].send_signal(signal.SIGSTOP)
        time.sleep(0.3)
        procs[0].send_signal(signal.SIGCONT)
        deadline = time.monotonic() + DRIVER_SECONDS + 60
        while driver.poll() is None:
            assert time.monotonic() < deadline, f"driver did not end:\n{drv_log.read_text()}"
            spin()
        stop = client.stop()  # at once: no "long enough" wait
        # the driver left once every subscriber had every tick in its DDS queue; this listener
        # (one callback per spin) may still have some queued: take them until none came for 1 s
        # of spinning (the queue is local now: nothing is on its way)
        n, quiet_since = len(heard), time.monotonic()
        while time.monotonic() - quiet_since < 1.0:
            rclpy.spin_once(node, timeout_sec=0.1)
            if len(heard) != n:
                n, quiet_since = len(heard), time.monotonic()
        assert stop.success, stop.message
        node.destroy_subscription(sub)
        out = drv_log.read_text()
        assert driver.returncode == 0, out
        published = int(out.split("driver: ")[-1].split(" ticks")[0])
        yield Path(res.bag_path), stop.message, published, np.array(heard, dtype=np.int64)
    finally:
        stop_processes(procs)


@pytest.mark.slow
def test_record_from_driver_loses_nothing(driver_bag) -> None:
    bag, stop_message, published, heard = driver_bag
    assert published == int(round(DRIVER_SECONDS * 1000))
    last = int(heard[-1])
    first = last - (published - 1) * 1_000_000  # realtime: tick k is stamped first + k ms
    assert np.all(np.diff(heard) == 1_000_000), "listener lost ticks"

    # our reader: every tick from the first recorded to the last, on both topics. The recording
    # starts at an arbitrary instant, possibly between the two messages of one tick: the recorder
    # then starts both topics on the first tick both delivered (bags.recording.TickAligner).
    data = bags.read_bag(bag)
    assert data.tags == bags.BagTags("unloaded", 0.0) and data.warnings == []
    stamps = {JOINT_STATES_TOPIC: data.joint_states.stamps_ns,
              CURRENT_REFERENCE_TOPIC: data.current_reference.stamps_ns}
    for topic, st in stamps.items():
        assert st[-1] == last, f"the driver's last ticks are not in the bag ({topic})"
        assert (st[0] - first) % 1_000_000 == 0 and st[0] > first  # started mid-stream
        assert np.all(np.diff(st) == 1_000_000) and find_gaps(st).missing == 0, topic
        np.testing.assert_array_equal(st, heard[heard >= st[0]])
    js_all, cr_all = stamps.values()
    np.testing.assert_array_equal(js_all, cr_all)  # the same ticks on both topics, first to last
    start = js_all[0]
    js = js_all[js_all >= start]
    np.testing.assert_array_equal(js, cr_all[cr_all >= start])  # identical stamps after the start
    assert len(js) >= 2000  # >= 2 of the 6 s recorded
    assert "0 missing on /orthoglide/joint_states" in stop_message
    assert (f"wrote {len(cr_all)} /orthoglide/current_reference, {len(js_all)} "
            "/orthoglide/joint_states" in stop_message)
    assert data.joint_states.names == ("q11", "q12", "q13")
    q_all, cur_all = data.joint_states.position, data.current_reference.current
    assert q_all.shape == (len(js_all), 3) and cur_all.shape == (len(cr_all), 3)
    q, cur = q_all[js_all >= start], cur_all[cr_all >= start]
    assert np.all(np.isfinite(q)) and np.ptp(q, axis=0).min() > 1e-3  # it moved (exciting)
    assert np.ptp(cur, axis=0).min() > 0

    # rosbags: deserialises every message to the same stamps and values
    from rosbags.highlevel import AnyReader

    got: dict[str, list] = {JOINT_STATES_TOPIC: [], CURRENT_REFERENCE_TOPIC: []}
    with AnyReader([bag]) as reader:
        assert {c.topic for c in reader.connections} >= set(got)
        for conn, _, raw in reader.messages(
            connections=[c for c in reader.connections if c.topic in got]
        ):
            msg = reader.deserialize(raw, conn.msgtype)
            vals = msg.position if conn.topic == JOINT_STATES_TOPIC else msg.current
            got[conn.topic].append(
                (msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec, np.array(vals)))
    for topic, values in (
        (JOINT_STATES_TOPIC, q_all),
        (CURRENT_REFERENCE_TOPIC, cur_all),
    ):
        np.testing.assert_array_equal(
            np.array([s for s, _ in got[topic]], dtype=np.int64), stamps[topic]
        )
        np.testing.assert_array_equal(np.stack([v for _, v in got[topic]]), values)

    # the mcap library, CRCs validated: the tag record in each file, every message
    files = sorted(bag.glob("*.mcap"))
    assert files
    with AnyReader([bag]) as reader:  # the driver's setpoints are recorded too (an optional topic)
        n_setpoints = sum(1 for _ in reader.messages(
            connections=[c for c in reader.connections if c.topic.endswith("/setpoints")]))
    assert mcap_messages(files, "unloaded", "0") == len(js_all) + len(cr_all) + n_setpoints

    # metadata.yaml: rosbag2 version 9, custom_data tags, counts
    import yaml

    info = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert info["version"] == 9 and info["storage_identifier"] == "mcap"
    assert info["custom_data"].items() >= {
        "orthoglide.condition": "unloaded",
        "orthoglide.payload_mass": "0",
    }.items()
    assert info["message_count"] == len(js_all) + len(cr_all) + n_setpoints


@pytest.mark.slow
def test_info_cli_on_driver_bag(driver_bag) -> None:
    exe = Path(sys.executable).parent / "orthoglide-ident"
    cmd = [str(exe)] if exe.exists() else [sys.executable, "-m", "orthoglide_ident.cli"]
    bag = driver_bag[0]
    data = bags.read_bag(bag)
    counts = {JOINT_STATES_TOPIC: len(data.joint_states.stamps_ns),
              CURRENT_REFERENCE_TOPIC: len(data.current_reference.stamps_ns)}
    out = children.run([*cmd, "info", str(bag)], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    text = out.stdout
    assert "unloaded, payload 0 kg" in text and "NOT CLOSED" not in text and "closed" in text
    for topic in (JOINT_STATES_TOPIC, CURRENT_REFERENCE_TOPIC):
        line = next(ln for ln in text.splitlines() if ln.strip().startswith(topic))
        assert f" {counts[topic]} msgs" in line and "1000.0 Hz" in line, line
    assert text.count("no missing ticks (period 1.000 ms)") == 2
    duration = float(text.split("duration:")[1].split()[0])
    assert duration == pytest.approx((max(counts.values()) - 1) / 1000, abs=1e-6)
