"""Child processes that end with their parent, whatever signal ends the parent; a parent that a
signal ends with one line.

A node set started by a script (``make demo``, a benchmark, a test) must not outlive it: a
benchmark killed by ``timeout`` once left the simulator's driver publishing at 1 kHz for 35
minutes. Cleaning up in ``finally`` covers exceptions and SIGINT/SIGTERM, not SIGKILL; so every
child also gets Linux's parent-death signal (``prctl(PR_SET_PDEATHSIG, SIGTERM)``, set by a tiny
wrapper the child runs before it execs the program, and kept across exec): when the parent dies,
the kernel sends the child SIGTERM, which our nodes take as a clean stop (the recorder closes its
bag). The wrapper costs the child ~20 ms of start-up.

    proc = popen([sys.executable, "-m", "orthoglide_ident.nodes.recorder"], env=env)

The signal is tied to the *thread* that started the child: start children from the main thread
(or one that lives as long as they should). Elsewhere than Linux ``popen`` is plain Popen.

A script that runs a node set (the demo, a benchmark) calls ``interrupt_on_signals()`` and gives
rclpy no signal handlers of its own
(``rclpy.init(signal_handler_options=SignalHandlerOptions.NO)``):
SIGTERM and SIGHUP then raise ``Interrupted`` in the main thread like Ctrl-C, its
``with``/``finally``
blocks stop the children, and the script prints one line (rclpy's own SIGTERM handler shut the
context down under the running code instead: chained RCLError tracebacks).
"""
from __future__ import annotations

import os
import signal
import subprocess
import sys
from typing import Any

# Run by the child itself, before it becomes the program: set the parent-death signal, check that
# the parent is still the one that started it (it may have died already), then exec the program.
# A wrapper rather than Popen's preexec_fn: that forks the whole (multi-threaded) parent and runs
# Python in the child before exec, which can deadlock; this one starts with posix_spawn/vfork.
_WRAPPER = """\
import ctypes, os, signal, sys
parent, argv = int(sys.argv[1]), sys.argv[2:]
try:
    ctypes.CDLL("libc.so.6").prctl(1, signal.SIGTERM, 0, 0, 0)  # PR_SET_PDEATHSIG
except (OSError, AttributeError):
    pass  # not glibc: no parent-death signal (the parent's clean-up still stops the child)
if os.getppid() != parent:
    sys.exit(1)
os.execvp(argv[0], argv)
"""


def _wrapped(args: Any) -> list[str]:
    if isinstance(args, (str, bytes, os.PathLike)):
        args = [args]
    if not sys.platform.startswith("linux"):
        return [os.fspath(a) for a in args]
    return [sys.executable, "-S", "-c", _WRAPPER, str(os.getpid()), *(os.fspath(a) for a in args)]


def popen(args: Any, **kwargs: Any) -> subprocess.Popen:
    """``subprocess.Popen(args, **kwargs)`` whose process gets SIGTERM when this one dies."""
    if kwargs.get("shell"):
        raise ValueError("popen: shell=True is not supported; pass the argument list")
    return subprocess.Popen(_wrapped(args), **kwargs)


def run(args: Any, **kwargs: Any) -> subprocess.CompletedProcess:
    """``subprocess.run(args, **kwargs)`` whose process gets SIGTERM when this one dies."""
    if kwargs.get("shell"):
        raise ValueError("run: shell=True is not supported; pass the argument list")
    return subprocess.run(_wrapped(args), **kwargs)


class Interrupted(KeyboardInterrupt):
    """A stop signal (SIGINT, SIGTERM, SIGHUP) in the main thread; ``signum`` says which."""

    def __init__(self, signum: int) -> None:
        super().__init__(signal.Signals(signum).name)
        self.signum = signum

    @property
    def exit_code(self) -> int:
        return 128 + self.signum  # the shell's convention for a process ended by a signal


def interrupt_on_signals() -> None:
    """SIGINT, SIGTERM and SIGHUP raise ``Interrupted`` in the main thread (call it from there);
    once: a second signal during the clean-up does not cut it short (it is bounded in time)."""
    raised = []

    def handler(signum: int, frame: Any) -> None:
        if not raised:
            raised.append(signum)
            raise Interrupted(signum)

    for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        signal.signal(sig, handler)


def _ros2_launcher(cmdline: list[str]) -> bool:
    """Whether a process's argv is ``ros2 launch ...`` or ``ros2 run ...`` (any interpreter)."""
    for a, b in zip(cmdline, cmdline[1:]):
        if os.path.basename(a) == "ros2" and b in ("launch", "run"):
            return True
    return False


def end_with_ros2_launcher() -> bool:
    """A node started by ``ros2 launch`` or ``ros2 run`` gets the parent-death signal (SIGTERM,
    our nodes' clean stop): launch answers SIGTERM by cancelling itself without stopping its
    processes ("using SIGTERM can result in orphaned processes", launch_service.py), and ``ros2
    run`` dies on it the same way, so a ``timeout``, a CI runner or a supervisor that stops the
    launcher left every node running. Started otherwise (a shell, ``nohup``, systemd) nothing
    changes: a node may outlive a shell on purpose. Returns whether the signal was set."""
    if not sys.platform.startswith("linux"):
        return False
    parent = os.getppid()
    try:
        with open(f"/proc/{parent}/cmdline", "rb") as fh:
            cmdline = [a.decode(errors="replace") for a in fh.read().split(b"\0") if a]
    except OSError:
        return False
    if not _ros2_launcher(cmdline):
        return False
    try:
        import ctypes

        ctypes.CDLL("libc.so.6").prctl(1, signal.SIGTERM, 0, 0, 0)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        return False
    if os.getppid() != parent:  # the launcher died before the signal was set
        os.kill(os.getpid(), signal.SIGTERM)
    return True
