"""Missing controller ticks: the one rule used by the pipeline, the live identification, the
recorder's loss count and ``orthoglide-ident info`` (docs/design/method.md).

Consecutive stamps of a 1 kHz controller are one period apart. A step outside (0.5, 1.5) periods
is a break; a step of about k periods (k = round(step / period) ≥ 2) means k - 1 ticks are missing.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# a 1 kHz controller's period (the Orthoglide's, a controller manager's update rate)
TICK_NS = 1_000_000
BREAK_LOW = 0.5  # periods: a shorter step is a break (a jump back, a duplicated clock)
BREAK_HIGH = 1.5  # periods: a longer step is a break with round(step / period) - 1 ticks missing


def find_breaks(dt_ns: np.ndarray, period_ns: float) -> tuple[np.ndarray, int]:
    """Breaks between consecutive stamps and the number of ticks missing in them.

    ``dt_ns``: stamp differences (ns); returns ``(bool mask like dt_ns, ticks missing)``.
    """
    ratio = np.asarray(dt_ns, float) / period_ns
    brk = (ratio < BREAK_LOW) | (ratio > BREAK_HIGH)
    return brk, int(np.sum(np.maximum(np.rint(ratio[brk]) - 1, 0)))


LOCAL_STEPS = 31  # steps in the window of the local step distribution (uneven clocks)
ON_GRID = 0.02  # a step within 2 % of the period is on the grid


def find_breaks_local(dt_ns: np.ndarray, period_ns: float) -> tuple[np.ndarray, int]:
    """Breaks against the *local* step: a step outside (0.5, 1.5) x the median of the
    LOCAL_STEPS steps around it, round(step / local median) - 1 ticks missing. A controller
    that logs on its own clock (10/12 ms alternation, a 2 ms grid, jitter) is not a missing tick
    at every long step. On a steady clock (every non-break step within ON_GRID of ``period_ns``)
    it is :func:`find_breaks` itself."""
    dt = np.asarray(dt_ns, float)
    ratio = dt / period_ns
    steady = (np.abs(ratio - 1.0) <= ON_GRID) | (ratio < BREAK_LOW) | (ratio > BREAK_HIGH)
    if dt.size < LOCAL_STEPS or np.all(steady):
        return find_breaks(dt, period_ns)
    half = LOCAL_STEPS // 2
    padded = np.concatenate([dt[half:0:-1], dt, dt[-2:-half - 2:-1]])
    local = np.median(np.lib.stride_tricks.sliding_window_view(padded, LOCAL_STEPS), axis=1)
    ratio = dt / local
    brk = (ratio < BREAK_LOW) | (ratio > BREAK_HIGH)
    return brk, int(np.sum(np.maximum(np.rint(ratio[brk]) - 1, 0)))


def missing_in_step(dt_ns: int, period_ns: float) -> int:
    """Ticks missing in one step between consecutive stamps (the scalar form of find_breaks, for
    a callback that sees one message at a time)."""
    ratio = dt_ns / period_ns
    return max(round(ratio) - 1, 0) if ratio > BREAK_HIGH else 0


OFF_GRID_TOL = 0.02  # a step more than 2 % away from the median is "off the grid"
UNEVEN_SHARE = 0.01  # a record with more than 1 % off-grid steps has uneven steps


@dataclass(frozen=True)
class StepStats:
    """Distribution of a record's stamp steps (gaps included), in s."""

    n_steps: int
    median_s: float
    mean_s: float
    p05_s: float
    p95_s: float
    off_grid: float  # share of steps more than OFF_GRID_TOL from the median

    @property
    def uneven(self) -> bool:
        return self.off_grid > UNEVEN_SHARE

    def describe(self) -> str:
        """One line: 'steps: median 11.000 ms, 5-95 % 10.000-12.000 ms, 50.0 % off the median
        grid (mean 91.0 Hz)'."""
        return (f"steps: median {self.median_s * 1e3:.3f} ms, 5-95 % {self.p05_s * 1e3:.3f}-"
                f"{self.p95_s * 1e3:.3f} ms, {100 * self.off_grid:.1f} % off the median grid "
                f"(mean {1.0 / self.mean_s:.1f} Hz)")


def step_stats(stamps_ns: np.ndarray, mean_over: np.ndarray | None = None) -> StepStats:
    """Step distribution of sorted stamps (ns). ``mean_over``: steps to take the mean over
    (e.g. without the gaps); default all."""
    dt = np.diff(np.asarray(stamps_ns, np.int64)).astype(float) * 1e-9
    if dt.size == 0:
        return StepStats(0, 0.0, 0.0, 0.0, 0.0, 0.0)
    med = float(np.median(dt))
    sel = dt if mean_over is None else dt[mean_over]
    mean = float(np.mean(sel)) if sel.size else med
    p05, p95 = (float(x) for x in np.percentile(dt, [5, 95]))
    off = float(np.mean(np.abs(dt - med) > OFF_GRID_TOL * med)) if med > 0 else 1.0
    return StepStats(int(dt.size), med, mean, p05, p95, off)
