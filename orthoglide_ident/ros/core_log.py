"""The core's log lines of one identification, in the node's ROS log.

The numerical core logs with Python's ``logging`` (``orthoglide_ident.*``: records read, equations,
ripple found, current-loop lags, segments that do not repeat); a node's log is rclpy's. During an
identify call the node forwards those lines, and only the calling thread's: the live estimate
re-solves about once a second on another thread and would repeat the same lines every second.

    with CoreLog(node.get_logger()):
        result = identify(bags)
"""
from __future__ import annotations

import logging
import threading

CORE_LOGGER = "orthoglide_ident"


class CoreLog(logging.Handler):
    """Context manager: INFO and above of ``orthoglide_ident.*`` from this thread to ``ros_logger``
    (anything with ``info`` and ``warning``, e.g. ``Node.get_logger()``)."""

    def __init__(self, ros_logger) -> None:
        super().__init__(logging.INFO)
        self.ros = ros_logger
        self.thread = threading.get_ident()
        self._level = logging.NOTSET

    def emit(self, record: logging.LogRecord) -> None:
        if record.thread != self.thread:
            return
        try:
            text = record.getMessage()
            if record.levelno >= logging.WARNING:
                self.ros.warning(text)
            else:
                self.ros.info(text)
        except Exception:  # a log line must never break an identification
            self.handleError(record)

    def __enter__(self) -> CoreLog:
        core = logging.getLogger(CORE_LOGGER)
        self._level = core.level
        if core.getEffectiveLevel() > logging.INFO:
            core.setLevel(logging.INFO)
        core.addHandler(self)
        return self

    def __exit__(self, *exc) -> None:
        core = logging.getLogger(CORE_LOGGER)
        core.removeHandler(self)
        core.setLevel(self._level)
