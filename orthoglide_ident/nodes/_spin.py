"""The life cycle every node shares (ros2/examples style): init, build, spin, clean exit."""
from __future__ import annotations

import sys
from collections.abc import Callable
from typing import Any

from orthoglide_ident.errors import OrthoglideError


def spin(make_node: Callable[[], Any], args: list[str], prog: str, threads: int = 1) -> int:
    """Run ``make_node()`` until Ctrl-C or an external shutdown; return the exit code.

    A node whose construction fails with an OrthoglideError (bad parameter, unknown trajectory)
    prints one line and exits 2. On the way out the node's ``close()`` runs if it has one (the
    recorder closes its bag), then the node and rclpy are shut down.
    """
    import rclpy
    from rclpy.executors import ExternalShutdownException, MultiThreadedExecutor, SingleThreadedExecutor

    rclpy.init(args=args)
    node = None
    try:
        node = make_node()
        executor = MultiThreadedExecutor(num_threads=threads) if threads > 1 else SingleThreadedExecutor()
        executor.add_node(node)
        executor.spin()
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
