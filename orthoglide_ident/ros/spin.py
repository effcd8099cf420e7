"""The life cycle every node shares (ros2/examples style): init, build, spin, clean exit.

Exit codes: 0 after Ctrl-C, SIGTERM, SIGHUP or an external shutdown (the node cleaned up: the
recorder closed its bag); 2 with one line when the node cannot start with what it was given (a bad
parameter or parameter file); 1 with one line when it cannot go on (a thread it needs died, its
main loop failed, a bug at construction), so that ``ros2 launch`` (``respawn``) or a supervisor
restarts it. Never a live process that serves nothing: a callback's exception is caught by
ros.guard and the node goes on serving.
"""
from __future__ import annotations

import os
import signal
import sys
import threading
import traceback
from collections.abc import Callable
from typing import Any

from orthoglide_ident.errors import ConfigError, OrthoglideError
from orthoglide_ident.ros.guard import CallbackGuard, cannot_go_on, fatal_reason
from orthoglide_ident.ros.processes import end_with_ros2_launcher

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
IDLE_WAIT_S = 0.1  # the executor thread checks for a stop request this often


def _serve(executor: Any, guard: CallbackGuard, stop: threading.Event) -> None:
    """The executor thread: spin until a stop request or a shutdown. Anything a callback lets
    out despite the guard (an entity created after the last wrap, rclpy itself) is logged and
    the executor goes on."""
    from rclpy.executors import ExternalShutdownException

    while not stop.is_set() and executor.context.ok():
        guard.wrap_all()  # callbacks of entities created since the last turn
        try:
            executor.spin_once(timeout_sec=IDLE_WAIT_S)
        except (KeyboardInterrupt, ExternalShutdownException):
            return
        except Exception as exc:  # noqa: BLE001 - the executor thread must not die
            if stop.is_set() or not executor.context.ok():
                return  # entities destroyed while shutting down: not an error
            guard.log.failed("executor", exc)


def _ros_args(args: list[str]) -> list[str]:
    """The arguments between ``--ros-args`` and ``--`` (or the end)."""
    out, inside = [], False
    for a in args:
        if a == "--ros-args":
            inside = True
        elif a == "--":
            inside = False
        elif inside:
            out.append(a)
    return out


def check_params_files(args: list[str]) -> None:
    """ConfigError with a one-line reason for a ``--params-file`` that rcl would refuse with a
    traceback (unreadable, not YAML) or silently ignore (not a ROS 2 parameter file)."""
    import yaml

    ros = _ros_args(args)
    files = [ros[i + 1] for i, a in enumerate(ros[:-1]) if a == "--params-file"]
    for f in files:
        try:
            with open(f, encoding="utf-8") as fh:
                doc = yaml.safe_load(fh)
        except OSError as exc:
            raise ConfigError(f"cannot read parameter file {f}: {exc.strerror or exc}") from None
        except yaml.YAMLError as exc:
            where = getattr(exc, "problem_mark", None)
            line = f" (line {where.line + 1})" if where is not None else ""
            raise ConfigError(f"parameter file {f} is not valid YAML{line}: "
                              f"{getattr(exc, 'problem', None) or exc}") from None
        ok = (
            isinstance(doc, dict)
            and doc
            and all(
                isinstance(v, dict) and isinstance(v.get("ros__parameters"), dict)
                for v in doc.values()
            )
        )
        if not ok:
            raise ConfigError(f"parameter file {f} is not a ROS 2 parameter file: expected "
                              "'<node name or /**>:' then 'ros__parameters:' and the parameters")


def _warn_unknown_parameters(node: Any) -> None:
    """A parameter set for this node (file or -p) that it does not have: most likely a typo."""
    given = set(getattr(node, "_parameter_overrides", {}))
    unknown = sorted(
        n
        for n in given - set(getattr(node, "_parameters", {}))
        if not n.startswith("qos_overrides.")
    )
    if unknown:
        node.get_logger().warning(
            f"ignored parameter(s) this node does not have: {', '.join(unknown)} "
            "(a typo? --help lists the parameters)"
        )


def _init_ros(args: list[str], prog: str) -> int | None:
    """rclpy.init with the checked arguments; the exit code (2, one line said) if they are bad."""
    import rclpy

    # a file-size limit (RLIMIT_FSIZE) makes a write fail with EFBIG, which the recorder reports,
    # instead of killing the process with SIGXFSZ and leaving its bag open
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    try:
        check_params_files(args)
        rclpy.init(args=args)
    except ConfigError as e:
        print(f"{prog}: {e}", file=sys.stderr)
        return 2
    except Exception as e:  # rcl refused the arguments (RCLError): its first line is the reason
        print(f"{prog}: cannot start: {str(e).splitlines()[0]}", file=sys.stderr)
        return 2
    return None


def _stop_on_signals() -> tuple[threading.Event, list[int]]:
    """Ctrl-C, SIGTERM (ros2 launch, systemd, kill, a dying parent) and SIGHUP set the returned
    event (and say which signal). rclpy's own SIGTERM handling did not always wake a waiting
    executor here, so the executor spins on its own thread while the main thread stays in Python.

    The handler itself takes no lock: it runs on the main thread between two bytecodes, possibly
    inside Event.set or Event.wait, which hold the event's lock — a handler calling stop.set()
    there waited for itself forever (seen: the ros2_control stand-in, SIGTERM'd by its dying
    launcher and again by hand, hung in six nested handlers). Python's C-level handler writes
    each signal's number to a wakeup pipe; a thread of its own reads it and sets the event."""
    stop = threading.Event()
    stopped_by: list[int] = []
    read_fd, write_fd = os.pipe()
    os.set_blocking(write_fd, False)

    def on_signal(signum: int, frame: Any) -> None:
        stopped_by.append(signum)  # atomic, lock-free; the watcher sets the event

    def watch() -> None:
        numbers = {int(s) for s in STOP_SIGNALS}
        while not stop.is_set():
            data = os.read(read_fd, 64)  # the numbers of the signals caught, one byte each
            if not data or numbers.intersection(data):
                stop.set()

    for sig in STOP_SIGNALS:
        signal.signal(sig, on_signal)
    signal.set_wakeup_fd(write_fd, warn_on_full_buffer=False)
    threading.Thread(target=watch, name="signals", daemon=True).start()
    return stop, stopped_by


def _run(node: Any, executor: Any, guard: CallbackGuard, stop: threading.Event) -> int:
    """Serve ``node`` until a stop request, the end of its main loop, an external shutdown, or a
    reason it cannot go on (exit code 1, logged)."""
    spinner = threading.Thread(
        target=_serve, args=(executor, guard, stop), name="executor", daemon=True
    )
    spinner.start()
    try:
        # a node with its own main loop (the driver's ticks) returns on stop
        if hasattr(node, "main_loop"):
            node.main_loop(stop)
        while not stop.is_set() and not getattr(node, "finished", False):
            if not spinner.is_alive():
                if not executor.context.ok():
                    break  # an external shutdown
                cannot_go_on(node, "its executor thread ended")
            if fatal_reason(node):
                break
            spinner.join(IDLE_WAIT_S)
        if fatal_reason(node) and not stop.is_set():
            node.get_logger().error(
                f"cannot go on: {fatal_reason(node)}; exiting with code 1 (ros2 launch "
                "respawn or a supervisor restarts the node)"
            )
            return 1
        return 0
    finally:
        stop.set()
        executor.shutdown(timeout_sec=5.0)
        spinner.join(5.0)


def spin(make_node: Callable[[], Any], args: list[str], prog: str, threads: int = 1) -> int:
    """Run ``make_node()`` until Ctrl-C, SIGTERM, SIGHUP or an external shutdown; return the exit
    code (see the module).

    A node with a ``main_loop(stop: threading.Event)`` method runs it on the main thread while the
    executor serves its callbacks (the driver's tick loop); the node ends when ``main_loop`` returns
    with ``node.finished`` set, or on a stop request. On the way out the node's ``close()`` runs if
    it has one (the recorder closes its bag), then the node and rclpy are shut down.
    """
    import rclpy
    from rclpy.executors import MultiThreadedExecutor, SingleThreadedExecutor

    code = _init_ros(args, prog)
    if code is not None:
        return code
    stop, stopped_by = _stop_on_signals()
    end_with_ros2_launcher()  # a SIGTERM'd ros2 launch/run leaves its processes running
    node = None
    try:
        node = make_node()
        guard = CallbackGuard(node)
        guard.wrap_all()
        _warn_unknown_parameters(node)
        executor = (
            MultiThreadedExecutor(num_threads=threads) if threads > 1 else SingleThreadedExecutor()
        )
        executor.add_node(node)
        code = _run(node, executor, guard, stop)
    except KeyboardInterrupt:
        code = 0
    except OrthoglideError as e:
        print(f"{prog}: {e}", file=sys.stderr)
        code = 2
    except Exception as e:  # noqa: BLE001 - a bug: one line, the traceback at debug level, exit 1
        print(f"{prog}: cannot go on: internal error {type(e).__name__}: {e}; exiting with code 1",
              file=sys.stderr)
        from rclpy.logging import get_logger

        get_logger(prog).debug("".join(traceback.format_exception(e)))
        code = 1
    finally:
        if node is not None:
            if stopped_by:
                node.get_logger().info(f"stopping on {signal.Signals(stopped_by[0]).name}")
            if hasattr(node, "close"):
                node.close()
            node.destroy_node()
        rclpy.try_shutdown()
    return code
