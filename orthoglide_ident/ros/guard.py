"""No deaf node: a callback that raises is one log line, a service that raises still answers.

rclpy's executor lets a callback's exception out of ``spin()``: the executor thread dies, the
process stays up and nothing is served any more (issue 26: a logging call that raised in the
recorder's stop service left it so). ``CallbackGuard.wrap_all()`` wraps the callback of every
service, subscription and timer of a node, so that an exception

- is logged on one line with its reason (``<what> failed: <Type>: <reason>``; the traceback at
  debug level), at most once per ``REPEAT_LOG_S`` per callback with the count of repeats;
- answers a service call with ``success: false`` and the reason (a fresh response, as the
  callback may have half-filled the one it got);
- lets the node go on serving.

A failure the node cannot go on from (a thread it needs has died) is ``cannot_go_on(node, reason)``:
the spin helper (ros.spin) sees it, logs the reason and exits non-zero, so that ``ros2 launch``
(``respawn``) or a supervisor starts the node again.

Each logging call below keeps one severity: rclpy refuses another severity from the same call site
(ValueError "Logger severity cannot be changed between calls"), the very bug of issue 26.
"""
from __future__ import annotations

import functools
import time
import traceback
from collections.abc import Callable
from typing import Any

REPEAT_LOG_S = 5.0  # a callback failing at 1 kHz logs once per this many seconds
FATAL_ATTRIBUTE = "cannot_go_on_reason"


def cannot_go_on(node: Any, reason: str) -> None:
    """Mark ``node`` as unable to go on: the spin helper ends it with exit code 1 and ``reason``."""
    if not getattr(node, FATAL_ATTRIBUTE, ""):
        setattr(node, FATAL_ATTRIBUTE, reason)


def fatal_reason(node: Any) -> str:
    """Why ``node`` cannot go on ('' while it can)."""
    return getattr(node, FATAL_ATTRIBUTE, "") or ""


class FailureLog:
    """One error line per failing callback (then one per REPEAT_LOG_S with the count), the
    traceback at debug level."""

    def __init__(self, logger: Any) -> None:
        self.logger = logger
        self.count: dict[str, int] = {}
        self._logged: dict[str, tuple[float, int]] = {}  # what -> (time logged, count then)

    def failed(self, what: str, exc: BaseException, consequence: str = "the node goes on") -> str:
        """Log the failure of ``what``; returns the reason (``<Type>: <message>``)."""
        reason = f"{type(exc).__name__}: {exc}"
        n = self.count[what] = self.count.get(what, 0) + 1
        t_last, n_last = self._logged.get(what, (float("-inf"), 0))
        now = time.monotonic()
        if now - t_last >= REPEAT_LOG_S:
            again = (
                f" ({n - n_last - 1} more failure(s) since the last line)" if n - n_last > 1 else ""
            )
            self.logger.error(f"{what} failed: {reason}; {consequence}{again}")
            self.logger.debug("".join(traceback.format_exception(exc)))
            self._logged[what] = (now, n)
        return reason


class CallbackGuard:
    """Wraps the callbacks of a node's services, subscriptions and timers (see the module)."""

    def __init__(self, node: Any) -> None:
        self.node = node
        self.log = FailureLog(node.get_logger())
        self._seen = -1  # number of entities at the last wrap_all

    def wrap_all(self) -> None:
        """Wrap every entity's callback not wrapped yet (cheap when nothing was created since)."""
        node = self.node
        entities = [*node.services, *node.subscriptions, *node.timers]
        if len(entities) == self._seen:
            return
        self._seen = len(entities)
        for e in node.services:
            self._wrap(e, f"service {e.srv_name}", self._service_wrapper)
        for e in node.subscriptions:
            self._wrap(e, f"subscription {e.topic_name}", self._plain_wrapper)
        for e in node.timers:
            self._wrap(
                e, f"timer {getattr(e.callback, '__qualname__', 'callback')}", self._plain_wrapper
            )

    @staticmethod
    def _wrap(entity: Any, what: str, make: Callable[[Callable, str, Any], Callable]) -> None:
        fn = getattr(entity, "callback", None)
        if fn is None or getattr(fn, "_guarded", False):
            return
        wrapped = make(fn, what, entity)
        wrapped._guarded = True
        entity.callback = wrapped

    def _plain_wrapper(self, fn: Callable, what: str, entity: Any) -> Callable:
        @functools.wraps(fn)
        def guarded(*args: Any) -> Any:
            try:
                return fn(*args)
            except Exception as exc:  # noqa: BLE001 - any bug in a callback: logged, the node goes on
                self.log.failed(what, exc)
                return None

        return guarded

    def _service_wrapper(self, fn: Callable, what: str, srv: Any) -> Callable:
        @functools.wraps(fn)
        def guarded(request: Any, response: Any) -> Any:
            try:
                return fn(request, response)
            except Exception as exc:  # noqa: BLE001 - answered with the reason, the node goes on
                reason = self.log.failed(what, exc, "answered success: false, the node goes on")
                return failure_response(srv.srv_type, f"internal error: {reason}")

        return guarded


def failure_response(srv_type: Any, message: str) -> Any:
    """A fresh response of ``srv_type`` with ``success: false`` and ``message`` (when it has
    them)."""
    response = srv_type.Response()
    if hasattr(response, "success"):
        response.success = False
    if hasattr(response, "message"):
        response.message = message
    return response
