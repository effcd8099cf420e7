"""The simulated robots' tick clock: a deadline is never left early, and the real-time priority
says what it got (root may have it; an unprivileged user gets the warning with its cost)."""
from __future__ import annotations

import time

from orthoglide_ident.ticks import TICK_NS
from orthoglide_sim.common import broadcaster, tick_clock


def test_sleep_until_never_returns_before_the_deadline():
    for _ in range(20):
        deadline = time.monotonic_ns() + TICK_NS
        tick_clock.sleep_until(deadline)
        assert time.monotonic_ns() >= deadline
    tick_clock.sleep_until(time.monotonic_ns() - TICK_NS)  # a deadline already past: at once


def test_one_tick_period_for_every_node():
    assert tick_clock.TICK_NS == broadcaster.TICK_NS == TICK_NS == 1_000_000


class _Logger:
    def __init__(self):
        self.lines = []

    def info(self, text):
        self.lines.append(("info", text))

    def warning(self, text):
        self.lines.append(("warning", text))


def test_the_real_time_priority_is_logged_either_way():
    log = _Logger()
    tick_clock.real_time_priority(0, log, "update loop")  # priority 0 is refused by SCHED_FIFO
    assert len(log.lines) == 1
    level, text = log.lines[0]
    assert (
        level == "warning"
        and "no real-time priority for the update loop" in text
        and "rt_priority:=0" in text
    )
