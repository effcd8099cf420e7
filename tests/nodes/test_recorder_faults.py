"""The recorder under the faults a user meets, across processes: what the user sees (the service's
answer, the status topic, the log) and that nothing that reached the recorder is lost.

- a failed stop, then a good one (issue 26: the second stop never answered, the node was deaf);
- a second stop, a stop with nothing recording, two starts at once;
- a callback that raises (injected): answered with the reason, the node goes on;
- a thread the node needs dies (injected): the node exits 1 instead of staying up deaf;
- the source vanishing mid-recording (kill -9): the status says so, the data are kept;
- a file-size limit (RLIMIT_FSIZE): the recording stops with the reason, the bag is readable up to
it;
- kill -9 of the recorder and a restart: the bag it left open is reindexed, with a log line.
"""
from __future__ import annotations

import resource
import signal
import time
from pathlib import Path

import numpy as np
import rclpy
from test_recorder import _publish, _sent, client, spawn_recorder  # noqa: E402,F401  (fixtures)

from orthoglide_ident import bags
from orthoglide_ident.bags.info import find_gaps

JS = bags.topics.JOINT_STATES_TOPIC


def _stamps(bag) -> np.ndarray:
    data = bags.read_bag(bag)
    js, cr = data.joint_states.stamps_ns, data.current_reference.stamps_ns
    np.testing.assert_array_equal(js, cr)  # the same ticks on both topics
    assert find_gaps(js).missing == 0  # none missing in between
    return js


def _log(tmp_path: Path, i: int = 0) -> str:
    return (tmp_path / f"recorder{i}.log").read_text()


def test_a_failed_stop_then_a_good_one_both_answer(client, spawn_recorder, ros_env, tmp_path):
    """Issue 26's order: a recording with no publisher stopped (success false), then one with a
    publisher: the second stop answers with every tick, and the node still serves."""
    proc = spawn_recorder()
    client.wait_ready()
    assert client.start("unloaded", 0.0, "empty").success
    res = client.stop()
    assert not res.success and "nothing recorded on /orthoglide/joint_states" in res.message
    res = client.start("unloaded", 0.0, "full")
    assert res.success, res.message
    n = _sent(_publish(ros_env, 1.5))
    res = client.stop()
    assert res.success, res.message
    assert f"wrote {n} /orthoglide/current_reference, {n} /orthoglide/joint_states" in res.message
    assert len(_stamps(tmp_path / "bags" / "full")) == n
    assert client.start("unloaded", 0.0, "third").success  # still serving
    assert proc.poll() is None and "Traceback" not in _log(tmp_path)


def test_second_stop_stop_without_recording_and_two_starts_at_once(
    client, spawn_recorder, tmp_path
):
    from orthoglide_msgs.srv import StartRecording

    spawn_recorder()
    client.wait_ready()
    res = client.stop()
    assert not res.success and res.message == "not recording"
    # two starts sent together: the services are served one at a time, one wins, the other is told
    # why
    futs = [
        client.start_cli.call_async(StartRecording.Request(condition="unloaded", name=f"twin{i}"))
        for i in (0, 1)
    ]
    deadline = time.monotonic() + 30
    while not all(f.done() for f in futs):
        assert time.monotonic() < deadline, "the starts were not answered"
        rclpy.spin_once(client.ros_node, timeout_sec=0.1)
    answers = sorted((f.result() for f in futs), key=lambda r: not r.success)
    assert answers[0].success and not answers[1].success
    assert f"already recording to {answers[0].bag_path}; call stop first" == answers[1].message
    assert not client.stop().success  # nothing published: a stop that says so
    res = client.stop()
    assert not res.success and res.message == "not recording"
    assert "Traceback" not in _log(tmp_path)


INJECTED = """
import functools
import sys
from orthoglide_ident.nodes import recorder

faults = {"start": 1, "status": 2}  # the call of each callback that raises
count = dict.fromkeys(faults, 0)

def inject(name, method, exc):
    orig = getattr(recorder.RecorderNode, method)
    @functools.wraps(orig)
    def faulty(self, *args):
        count[name] += 1
        if count[name] == faults[name]:
            raise exc
        return orig(self, *args)
    setattr(recorder.RecorderNode, method, faulty)

inject("start", "on_start", RuntimeError("injected fault in on_start"))
inject("status", "status_tick", KeyError("injected fault in the status timer"))
sys.exit(recorder.main(["recorder", *sys.argv[1:]]))
"""


def test_a_callback_that_raises_is_answered_and_the_node_goes_on(
    client, spawn_python, ros_env, tmp_path
):
    """Faults injected in the start service (first call) and the status timer (second tick): the
    start is answered success false with the reason, one log line each without a traceback, and
    the next recording keeps every tick."""
    rec = spawn_python(INJECTED, "--ros-args", "-p", f"output_dir:={tmp_path / 'bags'}")
    client.wait_ready()
    res = client.start("unloaded", 0.0, "faulty")
    assert not res.success
    assert res.message == "internal error: RuntimeError: injected fault in on_start"
    res = client.start("unloaded", 0.0, "after")
    assert res.success, res.message
    n = _sent(_publish(ros_env, 2.5))  # the status timer's second tick raises meanwhile
    res = client.stop()
    assert (
        res.success
        and f"wrote {n} /orthoglide/current_reference, {n} /orthoglide/joint_states" in res.message
    )
    assert len(_stamps(res.message.split(":")[0])) == n
    rec.send_signal(signal.SIGINT)
    out, err = rec.communicate(timeout=30)
    assert rec.returncode == 0, err
    # in either order: the timer runs on its own
    lines = [ln for ln in err.splitlines() if "failed:" in ln]
    assert len(lines) == 2, err
    assert any(
        "service orthoglide/recorder/start failed: RuntimeError: injected fault in on_start; "
        "answered "
        "success: false, the node goes on" in ln
        for ln in lines
    ), lines
    assert any(
        "status_tick failed: KeyError: 'injected fault in the status timer'; the node goes on" in ln
        for ln in lines
    ), lines
    assert "Traceback" not in err


DEAF = """
import sys
from orthoglide_ident.nodes import recorder
from orthoglide_ident.ros import batch as _batch

def broken_wait(self, ctx):
    raise ValueError("injected: the wait set cannot be built")

_batch.BatchTaker._wait = broken_wait
sys.exit(recorder.main(["recorder", *sys.argv[1:]]))
"""


def test_a_node_whose_intake_died_exits_1_rather_than_stay_deaf(spawn_python, tmp_path):
    rec = spawn_python(DEAF, "--ros-args", "-p", f"output_dir:={tmp_path / 'bags'}")
    out, err = rec.communicate(timeout=60)
    assert rec.returncode == 1, err
    assert (
        "cannot go on: its intake of /orthoglide/joint_states, /orthoglide/current_reference "
        "failed: "
        "ValueError: injected: the wait set cannot be built; exiting with code 1" in err
    )
    assert "Traceback" not in err


def _status_listener(client):
    """Every orthoglide/recorder/status message from now on (latched: the current one first)."""
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

    from orthoglide_msgs.msg import RecorderStatus

    got: list = []
    qos = QoSProfile(
        depth=10,
        durability=DurabilityPolicy.TRANSIENT_LOCAL,
        reliability=ReliabilityPolicy.RELIABLE,
    )
    sub = client.ros_node.create_subscription(
        RecorderStatus, "/orthoglide/recorder/status", got.append, qos
    )
    return got, sub


def _spin_until(client, done, timeout: float, what: str) -> None:
    deadline = time.monotonic() + timeout
    while not done():
        assert time.monotonic() < deadline, what
        rclpy.spin_once(client.ros_node, timeout_sec=0.1)


def test_the_source_vanishing_is_in_the_status_and_the_data_are_kept(
    client, spawn_recorder, ros_env, tmp_path
):
    """The publisher killed (SIGKILL) mid-recording: the status says no message arrives (0.5 s
    after the last one, at its next tick); the stop keeps every tick that arrived, closed and
    without a gap."""
    spawn_recorder()
    client.wait_ready()
    got, sub = _status_listener(client)
    res = client.start("unloaded", 0.0, "vanished")
    assert res.success, res.message
    pub = _publish(ros_env, 30.0)
    assert pub.stdout.readline().startswith("publishing")
    _spin_until(client, lambda: got and got[-1].ticks_written > 500, 30, "nothing recorded")
    pub.kill()
    pub.wait(10)
    _spin_until(
        client,
        lambda: "no message on" in got[-1].message,
        30,
        "the status never said the source stopped",
    )
    silent = got[-1]
    assert silent.recording
    assert "no message on /orthoglide/current_reference for" in silent.message
    assert "(source stopped or gone?); what arrived is kept" in silent.message
    res = client.stop()
    assert res.success, res.message
    client.ros_node.destroy_subscription(sub)
    js = _stamps(tmp_path / "bags" / "vanished")
    assert (
        f"wrote {len(js)} /orthoglide/current_reference, {len(js)} /orthoglide/joint_states"
        in res.message
    )
    assert bags.bag_info(tmp_path / "bags" / "vanished").closed
    assert len(js) >= silent.ticks_written  # all the status had counted, and what came after


def test_a_file_size_limit_ends_the_recording_with_the_reason(
    client, spawn_recorder, ros_env, tmp_path
):
    """RLIMIT_FSIZE (what a full disk does to a write) set on the running recorder: the recording
    stops with the reason on the status and in the stop's answer, the node goes on, and the bag
    reads up to the failure without a gap."""
    proc = spawn_recorder("chunk_duration:=0.1")
    client.wait_ready()
    limit = 150_000  # bytes per file: ~1 s of the three 1 kHz topics, compressed
    soft, hard = resource.prlimit(proc.pid, resource.RLIMIT_FSIZE)
    resource.prlimit(proc.pid, resource.RLIMIT_FSIZE, (limit, hard))
    got, sub = _status_listener(client)
    res = client.start("unloaded", 0.0, "full")
    assert res.success, res.message
    pub = _publish(ros_env, 5.0)
    _spin_until(
        client,
        lambda: got and not got[-1].recording and got[-1].bag_path == res.bag_path,
        60,
        "the recording did not end at the file-size limit",
    )
    ended = got[-1].message
    assert (
        "ended by a write error" in ended
        and "File too large" in ended
        and "what was written is kept" in ended
    )
    res_stop = client.stop()
    assert (
        not res_stop.success
        and res_stop.message == f"not recording (the last recording ended: {ended})"
    )
    _sent(pub)
    client.ros_node.destroy_subscription(sub)
    # cut at the failure: read to its last complete chunk, with a warning
    data = bags.read_bag(res.bag_path)
    assert len(data.warnings) == 1 and "not closed" in data.warnings[0]
    assert len(data.joint_states.stamps_ns) > 100
    assert find_gaps(data.joint_states.stamps_ns).missing == 0
    assert sum(f.stat().st_size for f in Path(res.bag_path).glob("*.mcap")) <= limit
    resource.prlimit(proc.pid, resource.RLIMIT_FSIZE, (soft, hard))  # space again: recording works
    assert client.start("unloaded", 0.0, "after").success
    n = _sent(_publish(ros_env, 1.0))
    assert client.stop().success and len(_stamps(tmp_path / "bags" / "after")) == n
    assert proc.poll() is None and "Traceback" not in _log(tmp_path)


def test_kill_9_and_a_restart_reindex_the_bag_left_open(client, spawn_recorder, ros_env, tmp_path):
    """The recorder killed mid-recording leaves its bag open (at most the open chunk lost); the
    next recorder on the same folder reindexes it at start and says so: every tool then reads
    the same messages, whole."""
    proc = spawn_recorder()
    client.wait_ready()
    got, sub = _status_listener(client)
    res = client.start("loaded", 2.5, "killed")
    assert res.success, res.message
    pub = _publish(ros_env, 3.0)
    # 1500 ticks written: at least one 0.5 s chunk is on disk whatever the machine's speed
    _spin_until(client, lambda: got and got[-1].ticks_written > 1500, 60, "nothing recorded")
    client.ros_node.destroy_subscription(sub)
    proc.kill()
    proc.wait(10)
    _sent(pub)
    before = bags.read_bag(res.bag_path)
    assert len(before.warnings) == 1 and "not closed" in before.warnings[0]
    n = len(before.joint_states.stamps_ns)
    assert n > 0 and not bags.bag_info(res.bag_path).closed

    spawn_recorder()  # the supervisor's restart
    log = _log(tmp_path, 1)
    assert f"{res.bag_path} was left open (recorder killed?): reindexed: " in log, log
    info = bags.bag_info(res.bag_path)
    assert info.closed and info.tags == bags.BagTags("loaded", 2.5)
    after = bags.read_bag(res.bag_path)
    assert after.warnings == []
    np.testing.assert_array_equal(after.joint_states.stamps_ns, before.joint_states.stamps_ns)
    assert find_gaps(after.joint_states.stamps_ns).missing == 0
    from rosbags.highlevel import AnyReader

    with AnyReader([Path(res.bag_path)]) as reader:  # metadata.yaml rebuilt: rosbags counts them
        conns = [c for c in reader.connections if c.topic == JS]
        assert len(conns) == 1 and sum(1 for _ in reader.messages(connections=conns)) == n
