"""A bound on the derivative filter's bias, in the σ of the drive gains of a slow log.

The IDIM rows (paper eqs. 17-20) take q̂̇, q̂̈ from q low-passed at the derivative filter's
cut-off f_q (0: f_m / 5) and v_τ filtered in parallel. That is exact for the columns linear in
q, not for the products (M(q) q̈, q̇², sign(q̇)): W of the filtered q is not the filtered W. At
1 kHz f_q = 100 Hz lies far above a robot's motion; on a slow log (f_m / 5 = 16.7 Hz at 83 Hz)
it cuts into what a faster controller's loop makes the arm do, and the gains move with f_q.
Measured (bench/logger_sampling.py, ~83 Hz point-sampled from a 1 kHz loop, smooth, sampled
1 kHz): wrist_3 -0.62 / -0.42 / -0.24 / -0.04 / +0.08 % at f_q 12 / 16.7 / 20 / 25 / 30 Hz
(the decimation's band fixed), shoulder_pan -0.28 % at 16.7 Hz, -0.13 % at 25 Hz, against a
σ of 0.092 % for both: a bias, not noise. The residual-based σ of uncertainty.py does not miss a
correlation: the lag-window and the 1 s block sandwich (120 blocks) give no more than eq. (39)'s
white σ (inflation 1.00 on both gains); the bias sits in the rows themselves.

So on a log slower than SLOW_STEP_S the identification is solved again with f_q moved up by
FILTER_BOUND_RATIO (the decimation's band kept) and each gain's σ becomes
√(σ² + Δ²), Δ the relative change of the gain between the two: a stated bias bound. A gain
whose σ then exceeds ``max_gain_rel_std`` is not determined, with that reason.
"""
from __future__ import annotations

import math
from collections.abc import Callable, Sequence

from orthoglide_ident.results import RecordReport

FILTER_BOUND_RATIO = 1.5  # the second solve's derivative-filter cut-off, x the first's
NYQUIST_SHARE = 0.4  # of the slowest record's rate: the highest cut-off the second solve takes


def second_cutoff(bags: Sequence[RecordReport]) -> tuple[float, float] | None:
    """(derivative filter Hz, decimation cut-off Hz) of the second solve for the records'
    ``diagnostics.bags``, or None when the filter cannot move up below the Nyquist
    frequency."""
    f_q = min(float(b.filter_cutoff_hz) for b in bags)
    rate = min(1.0 / float(b.period_s) for b in bags)
    f2 = min(FILTER_BOUND_RATIO * f_q, NYQUIST_SHARE * rate)
    if f2 < 1.2 * f_q:
        return None
    return f2, min(float(b.decimation_cutoff_hz) for b in bags)


def second_options(bags: Sequence[RecordReport], opts, f_q: float, f_d: float):
    """The options of the second solve of the records whose ``diagnostics.bags`` are
    ``bags``: the cut-offs (f_q, f_d), the records read as the first solve read them (its
    reading and half tick when one for all, else ``opts``'), no IV cross-check. Offline and
    live (live/session.py, which observes each slow recording at stop with these) call it."""
    readings = {b.current_sampling for b in bags}
    shifts = {float(b.current_shift_ms) for b in bags}
    reading = readings.pop() if len(readings) == 1 else opts.input.current_sampling
    shift = shifts.pop() if len(shifts) == 1 else 0.0
    return opts.replace(filter_cutoff_hz=f_q, decimation_cutoff_hz=f_d, cross_check="none",
                        current_sampling=reading,
                        current_loop_hz=0.5e3 / shift if shift > 0 else opts.input.current_loop_hz)


def widen(result, other, f_q: float, f2: float, max_rel_std: float) -> str | None:
    """Each determined gain of ``result`` with its σ widened by its change in ``other`` (the
    same records at the derivative filter's cut-off ``f2`` instead of ``f_q``); beyond
    ``max_rel_std`` it is not determined. Returns the warning line, None when no gain moved
    by more than its σ (a gain ``other`` leaves not determined is named: no bound)."""
    moved = []
    for g, h in zip(result.drive_gains, other.drive_gains):
        if g.determined and not (h.determined and math.isfinite(h.value)):
            moved.append(f"{g.name} not determined at {f2:.3g} Hz (no bound)")
            continue
        if not (g.determined and g.value):
            continue
        delta = abs(h.value / g.value - 1.0)
        sigma = math.hypot(g.rel_std, delta)
        if delta > g.rel_std:
            moved.append(f"{g.name} {100 * delta:.2g} % (σ {100 * g.rel_std:.2g} -> "
                         f"{100 * sigma:.2g} %)")
        g.rel_std = sigma
        if sigma > max_rel_std:
            g.determined, g.value, g.rel_std = False, float("nan"), float("nan")
            g.reason = (f"it moves {100 * delta:.2g} % when the derivative filter's cut-off goes "
                        f"from {f_q:.3g} to {f2:.3g} Hz (a log this slow: the filter's bias is "
                        f"beyond max_gain_rel_std {100 * max_rel_std:g} %); log faster")
    if not moved:
        return None
    return (f"slow log: the gains' σ include how far they move when the derivative filter's "
            f"cut-off goes from {f_q:.3g} to {f2:.3g} Hz (its bias on the products of the IDIM "
            "columns, which no residual shows): " + ", ".join(moved))


def bound_filter_bias(result, solve_again: Callable, slow_s: float, max_rel_std: float
                      ) -> None:
    """``result`` (an identification of records whose ``diagnostics.bags`` say their rates)
    with the filter's bias bound in its gains' σ when a record's step is above ``slow_s``:
    ``solve_again(filter_cutoff_hz, decimation_cutoff_hz)`` is the same identification at
    those cut-offs (None when it is refused: then nothing is widened, said)."""
    bags = result.record_reports
    if (result.drive_gains_given or not bags
            or max(float(b.period_s) for b in bags) <= slow_s):
        return
    cut = second_cutoff(bags)
    if cut is None:
        return
    f_q = min(float(b.filter_cutoff_hz) for b in bags)
    other = solve_again(*cut)
    if other is None:
        result.warnings.append(f"slow log: the gains could not be solved again at a derivative "
                               f"filter's cut-off of {cut[0]:.3g} Hz: their σ hold no bound of "
                               "the filter's bias")
        return
    line = widen(result, other, f_q, cut[0], max_rel_std)
    if line:
        result.warnings.append(line)
