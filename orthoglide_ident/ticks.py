"""Missing controller ticks: the one rule used by the pipeline, the live identification, the
recorder's loss count and ``orthoglide-ident info`` (docs/architecture.md §6.1).

Consecutive stamps of a 1 kHz controller are one period apart. A step outside (0.5, 1.5) periods
is a break; a step of about k periods (k = round(step / period) ≥ 2) means k - 1 ticks are missing.
"""
from __future__ import annotations

import numpy as np

TICK_NS = 1_000_000  # a 1 kHz controller's period (the Orthoglide's, a controller manager's update rate)
BREAK_LOW = 0.5  # periods: a shorter step is a break (a jump back, a duplicated clock)
BREAK_HIGH = 1.5  # periods: a longer step is a break with round(step / period) - 1 ticks missing


def find_breaks(dt_ns: np.ndarray, period_ns: float) -> tuple[np.ndarray, int]:
    """Breaks between consecutive stamps and the number of ticks missing in them.

    ``dt_ns``: stamp differences (ns); returns ``(bool mask like dt_ns, ticks missing)``.
    """
    ratio = np.asarray(dt_ns, float) / period_ns
    brk = (ratio < BREAK_LOW) | (ratio > BREAK_HIGH)
    return brk, int(np.sum(np.maximum(np.rint(ratio[brk]) - 1, 0)))


def missing_in_step(dt_ns: int, period_ns: float) -> int:
    """Ticks missing in one step between consecutive stamps (the scalar form of find_breaks, for
    a callback that sees one message at a time)."""
    ratio = dt_ns / period_ns
    return max(round(ratio) - 1, 0) if ratio > BREAK_HIGH else 0
