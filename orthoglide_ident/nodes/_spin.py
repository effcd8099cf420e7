"""The life cycle every node shares (ros2/examples style): init, build, spin, clean exit."""
from __future__ import annotations

import signal
import sys
import threading
from collections.abc import Callable
from typing import Any

from orthoglide_ident.errors import OrthoglideError


def _spin_quietly(executor: Any, stop: threading.Event) -> None:
    from rclpy.executors import ExternalShutdownException

    try:
        executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass  # Ctrl-C or shutdown: the main thread cleans up
    except Exception:
        if not stop.is_set():
            raise
        # rclpy's executor can trip over entities destroyed while it shuts down: not an error


def spin(make_node: Callable[[], Any], args: list[str], prog: str, threads: int = 1) -> int:
    """Run ``make_node()`` until Ctrl-C, SIGTERM or an external shutdown; return the exit code.

    A node whose construction fails with an OrthoglideError (bad parameter, unknown trajectory)
    prints one line and exits 2. A node with a ``main_loop(stop: threading.Event)`` method runs it on the
    main thread while the executor serves its callbacks (the driver's tick loop); the node ends
    when ``main_loop`` returns with ``node.finished`` set, or on a stop request. On the way out the
    node's ``close()`` runs if it has one (the recorder closes its bag), then the node and rclpy
    are shut down.
    """
    import rclpy
    from rclpy.executors import MultiThreadedExecutor, SingleThreadedExecutor

    rclpy.init(args=args)
    # Ctrl-C and SIGTERM (ros2 launch, systemd, kill) end the node the same clean way. rclpy's own
    # SIGTERM handling did not always wake a waiting executor here (tests/test_ctc_node.py hung in
    # about one full test run in two), so the executor spins on its own thread while the main
    # thread stays in Python, where these handlers only raise a flag (no exception mid-join).
    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda signum, frame: stop.set())
    node = executor = spinner = None
    try:
        node = make_node()
        executor = MultiThreadedExecutor(num_threads=threads) if threads > 1 else SingleThreadedExecutor()
        executor.add_node(node)
        spinner = threading.Thread(target=_spin_quietly, args=(executor, stop), name="executor", daemon=True)
        spinner.start()
        if hasattr(node, "main_loop"):  # a node with its own main loop (the driver's ticks) returns on stop
            node.main_loop(stop)
        while spinner.is_alive() and not stop.is_set() and not getattr(node, "finished", False):
            spinner.join(0.1)
    except KeyboardInterrupt:
        pass
    except OrthoglideError as e:
        print(f"{prog}: {e}", file=sys.stderr)
        return 2
    finally:
        stop.set()
        if executor is not None:
            executor.shutdown(timeout_sec=5.0)
        if spinner is not None:
            spinner.join(5.0)
        if node is not None:
            if hasattr(node, "close"):
                node.close()
            node.destroy_node()
        if rclpy.ok():
            rclpy.shutdown()
    return 0
