"""A node ends with the ``ros2 launch``/``ros2 run`` that started it, whatever ends the launcher.

launch answers SIGTERM by cancelling itself without stopping its processes (launch_service.py,
"using SIGTERM can result in orphaned processes"); the real ros2 CLI is not a dependency, so a
stand-in launcher named ``ros2`` starts the real recorder and is then killed outright (what
launch's SIGTERM amounts to for its children).
"""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest

from orthoglide_ident.ros import processes as children
from orthoglide_ident.ros.processes import _ros2_launcher


def test_a_ros2_launcher_is_recognised_and_nothing_else():
    assert _ros2_launcher(
        ["/venv/bin/python3.11", "/venv/bin/ros2", "launch", "orthoglide_ident", "x.py"]
    )
    assert _ros2_launcher(["ros2", "run", "orthoglide_ident", "recorder"])
    assert not _ros2_launcher(["/bin/bash"])
    assert not _ros2_launcher(["python", "-m", "pytest", "tests/ros2"])
    assert not _ros2_launcher(["/usr/bin/ros2", "topic", "echo", "run"])


LAUNCHER = """\
import subprocess, sys, time
node = subprocess.Popen([sys.executable, "-m", "orthoglide_ident.nodes.recorder", "--ros-args",
                         "-p", "output_dir:=" + sys.argv[2]], stderr=open(sys.argv[3], "w"))
print(node.pid, flush=True)
time.sleep(600)
"""


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    with open(f"/proc/{pid}/stat") as fh:
        return fh.read().split(") ")[1][0] != "Z"  # a zombie has ended


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="parent-death signal: Linux")
def test_a_node_ends_when_its_ros2_launcher_is_killed(tmp_path, ros_env):
    ros2 = tmp_path / "ros2"  # argv: python .../ros2 run ..., as the real CLI's entry point
    ros2.write_text(LAUNCHER)
    log = tmp_path / "recorder.log"
    launcher = children.popen([sys.executable, str(ros2), "run", str(tmp_path / "bags"), str(log)],
                              env=ros_env, stdout=subprocess.PIPE, text=True)
    node = int(launcher.stdout.readline())
    try:
        deadline = time.monotonic() + 60
        while not (log.exists() and "recorder ready" in log.read_text()):
            assert time.monotonic() < deadline and _alive(node), "the recorder did not start"
            time.sleep(0.1)
        launcher.send_signal(signal.SIGKILL)
        launcher.wait(10)
        deadline = time.monotonic() + 20
        while _alive(node) and time.monotonic() < deadline:
            time.sleep(0.1)
        assert not _alive(node), "the recorder outlived its launcher"
        assert "stopping on SIGTERM" in log.read_text()  # a clean stop, not a kill
    finally:
        if _alive(node):
            os.kill(node, signal.SIGKILL)


def test_a_burst_of_stop_signals_ends_a_node_cleanly(tmp_path, ros_env):
    """SIGINT, SIGTERM and SIGHUP back to back (launch's escalation, a parent-death signal, a user
    who presses Ctrl-C twice): one clean stop, exit 0. The handler once set the stop event itself
    and a signal arriving inside it waited for its lock forever: a node up and deaf."""
    log = tmp_path / "recorder.log"
    with open(log, "w") as err:
        node = children.popen(
            [
                sys.executable,
                "-m",
                "orthoglide_ident.nodes.recorder",
                "--ros-args",
                "-p",
                f"output_dir:={tmp_path / 'bags'}",
            ],
            env=ros_env,
            stderr=err,
        )
    try:
        deadline = time.monotonic() + 60
        while "recorder ready" not in log.read_text():
            assert time.monotonic() < deadline and node.poll() is None, log.read_text()
            time.sleep(0.1)
        t_end = time.monotonic() + 2.0  # signals spread over the handler's run (2 cores): nested
        while (
            time.monotonic() < t_end
            and node.poll() is None
            and "stopping on" not in log.read_text()
        ):
            for sig in (signal.SIGTERM, signal.SIGINT, signal.SIGHUP):
                try:
                    os.kill(node.pid, sig)
                except ProcessLookupError:
                    break
        assert node.wait(20) == 0, log.read_text()
    finally:
        if node.poll() is None:
            node.kill()
    text = log.read_text()
    assert "stopping on SIG" in text and "Traceback" not in text, text  # pending signals merge
