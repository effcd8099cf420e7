"""Shared pytest fixtures.

ROS 2 isolation: every pytest run talks on its own ROS domain (derived from the process id) with
discovery limited to this machine, so parallel runs and other ROS graphs on the network do not
see each other. The variables are set in this process at start-up (in-process rclpy nodes use
them) and handed to subprocesses by ``ros_env`` / ``spawn_python``.

    def test_something(spawn_python):
        talker = spawn_python("import rclpy; ...", "arg1")   # same interpreter, same ROS domain
        out, err = talker.communicate(timeout=30)
"""
from __future__ import annotations

import os
import subprocess
import sys

# One BLAS thread before numpy is imported (as the CLI and the nodes): narrow matrices, and
# OpenBLAS's spinning threads slow small LAPACK calls 10-30x on a loaded 2-core machine
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
from collections.abc import Callable, Iterator

import pytest

from orthoglide_ident.ros import processes as children  # children end with this process

ROS_ISOLATION = {
    # 1..100: domains above 101 can collide with ephemeral ports on Linux.
    "ROS_DOMAIN_ID": str(1 + os.getpid() % 100),
    "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST",
    "RMW_IMPLEMENTATION": "rmw_fastrtps_cpp",
}


def pytest_configure(config: pytest.Config) -> None:
    os.environ.update(ROS_ISOLATION)
    # Deprecated in Jazzy in favour of ROS_AUTOMATIC_DISCOVERY_RANGE; both set gives a warning.
    os.environ.pop("ROS_LOCALHOST_ONLY", None)


def ros_environment() -> dict[str, str]:
    """A copy of this process's environment with the test run's ROS isolation applied."""
    env = dict(os.environ)
    env.update(ROS_ISOLATION)
    env.pop("ROS_LOCALHOST_ONLY", None)
    env["PYTHONUNBUFFERED"] = "1"
    return env


@pytest.fixture
def ros_env() -> dict[str, str]:
    """Environment for a subprocess that must join this test run's ROS graph."""
    return ros_environment()


SpawnPython = Callable[..., "subprocess.Popen[str]"]


@pytest.fixture
def spawn_python() -> Iterator[SpawnPython]:
    """Start ``python -c CODE ARGS...`` with this interpreter and the test run's ROS environment.

    Returns a ``subprocess.Popen`` (text mode, stdout and stderr piped). Processes still running
    when the test ends are terminated, then killed.
    """
    processes: list[subprocess.Popen[str]] = []

    def spawn(code: str, *args: str, env: dict[str, str] | None = None) -> subprocess.Popen[str]:
        process = children.popen(
            [sys.executable, "-c", code, *args],
            env=env if env is not None else ros_environment(),
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        processes.append(process)
        return process

    yield spawn
    stop_processes(processes)


def stop_processes(processes: list[subprocess.Popen]) -> None:
    """Terminate what still runs (10 s to exit cleanly, then kill), draining any pipes."""
    for process in processes:
        if process.poll() is None:
            process.terminate()
            try:
                process.communicate(timeout=10)
            except subprocess.TimeoutExpired:
                process.kill()
                process.communicate()
