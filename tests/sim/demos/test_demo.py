"""`make demo` interrupted as timeout, a CI runner or a supervisor interrupts it: SIGTERM prints one
line and stops the node processes; SIGKILL (no clean-up possible) leaves none running either (they
get a parent-death signal)."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from orthoglide_ident.ros import processes as children  # children end with this process


def _children_of(pid: int) -> set[int]:
    out: set[int] = set()
    for task in Path(f"/proc/{pid}/task").iterdir():
        text = (task / "children").read_text().split()
        out.update(int(c) for c in text)
    return out


def _alive(pids: set[int]) -> set[int]:
    alive = set()
    for p in pids:
        try:
            state = Path(f"/proc/{p}/stat").read_text().rsplit(")", 1)[1].split()[0]
        except OSError:
            continue
        if state != "Z":
            alive.add(p)
    return alive


def _start_demo(ros_env: dict[str, str], out: Path) -> tuple[subprocess.Popen, list[str], set[int]]:
    """The demo, until its node set is up; (process, its stdout lines so far, the node
    processes)."""
    demo = children.popen(
        [sys.executable, "-m", "orthoglide_sim.demos.node_set", "--out", str(out)],
        env=ros_env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    lines: list[str] = []
    watchdog = threading.Timer(120, demo.kill)  # never hang the run on a demo that does not start
    watchdog.start()
    try:
        for line in demo.stdout:
            lines.append(line)
            if "driver publishing" in line:
                break
    finally:
        watchdog.cancel()
    assert any("driver publishing" in ln for ln in lines), "".join(lines) + demo.stderr.read()
    nodes = _children_of(demo.pid)
    assert len(nodes) == 4, nodes  # driver, recorder, identification, ctc
    return demo, lines, nodes


def _wait_gone(pids: set[int], timeout: float) -> set[int]:
    t_end = time.monotonic() + timeout
    while _alive(pids) and time.monotonic() < t_end:
        time.sleep(0.1)
    return _alive(pids)


@pytest.mark.slow
def test_sigterm_stops_the_demo_and_its_nodes_with_one_line(ros_env, tmp_path):
    demo, _, nodes = _start_demo(ros_env, tmp_path / "out")
    demo.send_signal(signal.SIGTERM)
    _, err = demo.communicate(timeout=60)
    assert demo.returncode == 128 + signal.SIGTERM, err
    assert err.strip().splitlines() == [
        "demo: interrupted by SIGTERM: the nodes were stopped; what was done so far is in "
        f"{tmp_path / 'out'}/"
    ]
    assert not _wait_gone(nodes, 10)
    for log in (tmp_path / "out" / "logs").glob("*.log"):
        assert "Traceback" not in log.read_text(), log


@pytest.mark.slow
def test_sigkill_of_the_demo_leaves_no_node_running(ros_env, tmp_path):
    demo, _, nodes = _start_demo(ros_env, tmp_path / "out")
    os.kill(demo.pid, signal.SIGKILL)
    demo.communicate(timeout=30)
    left = _wait_gone(nodes, 20)
    for p in left:  # do not leave them to the next tests
        os.kill(p, signal.SIGKILL)
    assert not left, "node processes outlived the killed demo"
