"""Child processes that end with their parent, whatever signal ends the parent; a parent that a
signal ends with one line.

A node set started by a script (``make demo``, a benchmark, a test) must not outlive it: a
benchmark killed by ``timeout`` once left the simulator's driver publishing at 1 kHz for 35
minutes. Cleaning up in ``finally`` covers exceptions and SIGINT/SIGTERM, not SIGKILL; so every
child also gets Linux's parent-death signal (``prctl(PR_SET_PDEATHSIG, SIGTERM)``, set between fork
and exec and kept across exec): when the parent dies, the kernel sends the child SIGTERM, which
our nodes take as a clean stop (the recorder closes its bag).

    proc = popen([sys.executable, "-m", "orthoglide_ident.nodes.recorder"], env=env)

The signal is tied to the *thread* that started the child: start children from the main thread
(or one that lives as long as they should). Elsewhere than Linux ``popen`` is plain Popen.

A script that runs a node set (the demo, a benchmark) calls ``interrupt_on_signals()`` and gives
rclpy no signal handlers of its own (``rclpy.init(signal_handler_options=SignalHandlerOptions.NO)``):
SIGTERM and SIGHUP then raise ``Interrupted`` in the main thread like Ctrl-C, its ``with``/``finally``
blocks stop the children, and the script prints one line (rclpy's own SIGTERM handler shut the
context down under the running code instead: chained RCLError tracebacks).
"""
from __future__ import annotations

import ctypes
import ctypes.util
import os
import signal
import subprocess
import sys
from typing import Any

PR_SET_PDEATHSIG = 1  # <linux/prctl.h>

_prctl = None
if sys.platform.startswith("linux"):
    try:
        _prctl = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True).prctl
        _prctl.argtypes = [ctypes.c_int, ctypes.c_ulong, ctypes.c_ulong, ctypes.c_ulong, ctypes.c_ulong]
    except (OSError, AttributeError):
        _prctl = None


def _die_with(parent: int, then: Any = None) -> Any:
    """The child's side, run between fork and exec."""

    def child() -> None:  # as little as possible between fork and exec: one system call, getppid
        if _prctl is not None:
            _prctl(PR_SET_PDEATHSIG, signal.SIGTERM, 0, 0, 0)
        if os.getppid() != parent:  # the parent died before the line above: do not start at all
            os._exit(1)
        if then is not None:
            then()

    return child


def popen(args: Any, **kwargs: Any) -> subprocess.Popen:
    """``subprocess.Popen(args, **kwargs)`` whose process gets SIGTERM when this one dies."""
    kwargs["preexec_fn"] = _die_with(os.getpid(), kwargs.get("preexec_fn"))
    return subprocess.Popen(args, **kwargs)


def run(args: Any, **kwargs: Any) -> subprocess.CompletedProcess:
    """``subprocess.run(args, **kwargs)`` whose process gets SIGTERM when this one dies."""
    kwargs["preexec_fn"] = _die_with(os.getpid(), kwargs.get("preexec_fn"))
    return subprocess.run(args, **kwargs)


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
