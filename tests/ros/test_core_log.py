"""The core's log lines of an identify call reach the node's log (ros/core_log.py)."""
from __future__ import annotations

import logging
import threading

from orthoglide_ident.ros.core_log import CoreLog


class Lines:
    """A stand-in for rclpy's logger: keeps what it is given."""

    def __init__(self) -> None:
        self.lines: list[tuple[str, str]] = []

    def info(self, text: str) -> None:
        self.lines.append(("info", text))

    def warning(self, text: str) -> None:
        self.lines.append(("warning", text))


def test_only_this_threads_core_lines_while_inside():
    core = logging.getLogger("orthoglide_ident.identify")
    ros = Lines()
    level = logging.getLogger("orthoglide_ident").level
    handlers = list(logging.getLogger("orthoglide_ident").handlers)
    with CoreLog(ros):
        core.info("current-loop lag (lag_model: auto): q11 %.3f ms", 0.1)
        core.warning("a warning")
        core.debug("not this")
        other = threading.Thread(target=core.info, args=("the live estimate's solve",))
        other.start()
        other.join()
        logging.getLogger("elsewhere").warning("not the core's")
    core.info("after the call")
    assert ros.lines == [("info", "current-loop lag (lag_model: auto): q11 0.100 ms"),
                         ("warning", "a warning")]
    assert logging.getLogger("orthoglide_ident").level == level
    assert logging.getLogger("orthoglide_ident").handlers == handlers
