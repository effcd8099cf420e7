"""The life cycle every node shares (ros2/examples style): init, build, spin, clean exit."""
from __future__ import annotations

import signal
import sys
from collections.abc import Callable
from typing import Any

from orthoglide_ident.errors import OrthoglideError


def _interrupt(signum: int, frame: Any) -> None:
    raise KeyboardInterrupt


def spin(make_node: Callable[[], Any], args: list[str], prog: str, threads: int = 1) -> int:
    """Run ``make_node()`` until Ctrl-C or an external shutdown; return the exit code.

    A node whose construction fails with an OrthoglideError (bad parameter, unknown trajectory)
    prints one line and exits 2. On the way out the node's ``close()`` runs if it has one (the
    recorder closes its bag), then the node and rclpy are shut down.
    """
    import rclpy
    from rclpy.executors import ExternalShutdownException, MultiThreadedExecutor, SingleThreadedExecutor

    rclpy.init(args=args)
    # SIGTERM (ros2 launch, systemd, kill) must end the node as cleanly as Ctrl-C. rclpy's own
    # SIGTERM handling did not always wake a waiting executor here (tests/test_ctc_node.py hung in
    # about one full test run in two), so SIGTERM raises KeyboardInterrupt in the main thread and
    # the executor waits with a timeout, which lets the Python handler run.
    signal.signal(signal.SIGTERM, _interrupt)
    node = None
    try:
        node = make_node()
        executor = MultiThreadedExecutor(num_threads=threads) if threads > 1 else SingleThreadedExecutor()
        executor.add_node(node)
        while rclpy.ok():
            executor.spin_once(timeout_sec=0.1)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except OrthoglideError as e:
        print(f"{prog}: {e}", file=sys.stderr)
        return 2
    finally:
        if node is not None:
            if hasattr(node, "close"):
                node.close()
            node.destroy_node()
        if rclpy.ok():
            rclpy.shutdown()
    return 0
