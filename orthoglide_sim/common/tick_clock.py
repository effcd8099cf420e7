"""The 1 kHz clock of the simulated robots' nodes (the Orthoglide's driver and the ros2_control
stand-in): the tick period, when a tick counts as late, and how the loop keeps its deadlines."""
from __future__ import annotations

import time
from typing import Any

from orthoglide_ident.ros.batch import real_time_thread
from orthoglide_ident.ticks import TICK_NS  # noqa: F401  (the clock's period, for its users)

LATE_NS = 500_000  # a tick published more than 0.5 ms after its deadline is late
# time.sleep overshoots by ~0.04 ms (median) at SCHED_FIFO, ~0.1 ms without: wake this much before,
# then
# spin. Every microsecond of it is the node's CPU (0.1 ms spun was 6-8 % of a core at 1 kHz): a tick
# published up to a few tens of microseconds after its deadline costs nobody anything (late: 0.5 ms)
WAKE_EARLY_NS = 50_000


def sleep_until(deadline_ns: int) -> None:
    """Sleep to just before the deadline (time.monotonic_ns), then wait out the rest: the tick is
    published at its deadline, not a tenth of a tick after it."""
    delay = deadline_ns - WAKE_EARLY_NS - time.monotonic_ns()
    if delay > 0:
        time.sleep(delay * 1e-9)
    while time.monotonic_ns() < deadline_ns:
        pass


def real_time_priority(priority: int, logger: Any, loop: str) -> None:
    """SCHED_FIFO at ``priority`` for this thread, so that ``loop`` keeps its deadlines while other
    nodes run; without the privilege, a warning that says what it costs."""
    refused = real_time_thread(priority)
    if refused is None:
        logger.info(f"{loop} at real-time priority {priority} (SCHED_FIFO)")
    else:
        logger.warning(
            f"no real-time priority for the {loop} ({refused}); ticks may be late when the "
            "machine is busy (set rt_priority:=0 to silence this)"
        )
