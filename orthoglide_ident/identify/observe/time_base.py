"""The time base of a record: q̂, q̂̇, q̂̈ on uneven stamps (the step distribution: ticks.py).

Real controllers log on their own clock: 10/12 ms alternation (~91 Hz), a 2 ms grid, jitter.
Taking the median step as the period makes every derivative wrong by the ratio of the median to
the mean step (10 % on a 10/12 ms record with one more 10 ms step), silently. Here the stamps
themselves are the time base; no sample is resampled or invented.

**Choice of filter on an uneven grid.** The zero-phase Butterworth of filtering.py, designed for
the segment's *mean* step T̄, is applied in sample index, over a smooth time base:

1. t̂_k: the stamps low-passed in the index at TIME_BASE_FRACTION of the cut-off (smooth, so
   that the low-pass of q commutes with it); e_k = t_k − t̂_k then holds the whole jitter.
2. Each sample is moved from its own stamp to t̂_k by its Taylor series,
   q̃_k = q_k − q̂̇(t_k) e_k + ½ q̂̈(t_k) e_k², with the derivatives of the previous pass
   (RETIME_PASSES passes, the first on the raw samples; each cuts the error ~10-100x).
3. q̂ = the Butterworth of q̃ in the index; q̂̇, q̂̈ by the chain rule from five-point
   differences in the index: q̂̇ = q̂_k / t̂_k, q̂̈ = (q̂_kk − q̂̇ t̂_kk) / t̂_k².
4. The states are interpolated (four-point Lagrange in the index, the index found by Newton on
   t̂) at the middle (t_k + t_{k+1}) / 2 of each held interval — the zero-order hold of v_τ[k],
   its half-step for each step — or at the stamps t_k.

Measured on a 0.3-3 Hz multisine (tests/identify/observe/test_time_base.py), rms velocity error,
relative: 10/12 ms 5e-5, ±1 ms random jitter on 10 ms 3e-5, a random 8/10/12 ms grid 5e-5,
where the median step as the period gave 6-10 % (the filter of the stamps alone, without the
re-timing, left 1 % on the random grid: the in-band part of a random walk of the stamps). A
local polynomial (Savitzky-Golay) fit on the stamps was the alternative: exact for polynomials
on any grid, but its frequency response is not the Butterworth's, so a uniform record would not
give today's answer; here an exactly uniform segment takes the uniform path unchanged.
"""
from __future__ import annotations

import numpy as np

from orthoglide_ident.errors import DataError
from orthoglide_ident.identify.observe.filtering import filtered_states, zero_phase_butterworth
from orthoglide_ident.ticks import OFF_GRID_TOL, UNEVEN_SHARE, StepStats, step_stats

TIME_BASE_FRACTION = 0.2  # the time base's cut-off, a fraction of the derivative filter's
RETIME_PASSES = 4  # Taylor re-timing passes onto the time base


def is_uniform(stamps_ns: np.ndarray) -> bool:
    """Every step exactly equal (a simulator's or a hardware-timed record): the uniform path."""
    dt = np.diff(np.asarray(stamps_ns, np.int64))
    return bool(dt.size == 0 or np.all(dt == dt[0]))


def mean_step_s(stamps_ns: np.ndarray) -> float:
    """T̄ of a continuous run: (t_last - t_first) / (n - 1), s."""
    s = np.asarray(stamps_ns, np.int64)
    return float(s[-1] - s[0]) * 1e-9 / max(s.shape[0] - 1, 1)


def _d1(x: np.ndarray) -> np.ndarray:
    """d/dk, five-point central differences (ends: copies of the nearest interior value)."""
    d = np.empty_like(x)
    d[2:-2] = (-x[4:] + 8.0 * x[3:-1] - 8.0 * x[1:-3] + x[:-4]) / 12.0
    d[[0, 1]], d[[-1, -2]] = d[2], d[-3]
    return d


def _d2(x: np.ndarray) -> np.ndarray:
    """d²/dk², five-point central differences (ends as :func:`_d1`)."""
    d = np.empty_like(x)
    d[2:-2] = (-x[4:] + 16.0 * x[3:-1] - 30.0 * x[2:-2] + 16.0 * x[1:-3] - x[:-4]) / 12.0
    d[[0, 1]], d[[-1, -2]] = d[2], d[-3]
    return d


def _lagrange_at(x: np.ndarray, s: np.ndarray) -> np.ndarray:
    """x (n, ...) interpolated at fractional indices s (m,), four-point Lagrange (two-point
    next to the ends)."""
    n = x.shape[0]
    k = np.clip(np.floor(s).astype(np.int64), 1, n - 3)
    u = (s - k).reshape((-1,) + (1,) * (x.ndim - 1))
    w = (-u * (u - 1) * (u - 2) / 6, (u + 1) * (u - 1) * (u - 2) / 2,
         -(u + 1) * u * (u - 2) / 2, (u + 1) * u * (u - 1) / 6)
    return w[0] * x[k - 1] + w[1] * x[k] + w[2] * x[k + 1] + w[3] * x[k + 2]


def states_on_stamps(q: np.ndarray, stamps_ns: np.ndarray, cutoff_hz: float, order: int = 4,
                     zoh_shift: bool = True, qd_recorded: np.ndarray | None = None,
                     shift_s: float = 0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """q̂, q̂̇, q̂̈ of a continuous run ``q: (n, n_j)`` sampled at ``stamps_ns`` (n,), untrimmed.

    Row k is the state at (t_k + t_{k+1}) / 2 (``zoh_shift``, n - 1 rows) or at t_k (n rows).
    An exactly uniform run goes through filtering.derivative_filter / half_tick unchanged.
    ``qd_recorded`` (n, n_j): a recorded joint velocity, low-passed like q and used for q̂̇
    (and differentiated for q̂̈) instead of differentiating q. ``shift_s`` (without
    ``zoh_shift``): row k at t_k + shift_s (a sampled current held over its faster loop's
    tick acts at the middle of that tick: observe/sampling.py).
    """
    st = np.asarray(stamps_ns, np.int64)
    q = np.asarray(q, float)
    T = mean_step_s(st)
    if is_uniform(st) and qd_recorded is None and (zoh_shift or shift_s == 0.0):
        return filtered_states(q, float(st[1] - st[0]) * 1e-9, cutoff_hz, order, zoh_shift)
    n = st.shape[0]
    k = np.arange(n)
    t = (st - st[0]).astype(float) * 1e-9
    # time base: the stamps low-passed well below the cut-off (TIME_BASE_FRACTION): smooth, so
    # that it commutes with the low-pass of q; e_k = t_k - t̂_k holds the whole jitter (small)
    t_hat = k * T + zero_phase_butterworth(t - k * T, T, TIME_BASE_FRACTION * cutoff_hz, order)
    e = t - t_hat
    tk = _d1(t_hat)
    q_hat, qd_hat, qdd_hat = _on_index(q, t_hat, T, cutoff_hz, order, qd_recorded)
    for _ in range(RETIME_PASSES):  # each sample moved from t_k to t̂_k by its Taylor series
        at = k + e / tk  # fractional index of t_k
        qd_k, qdd_k = _lagrange_at(qd_hat, at), _lagrange_at(qdd_hat, at)
        q_tau = q - qd_k * e[:, None] + 0.5 * qdd_k * (e * e)[:, None]
        qd_tau = None if qd_recorded is None else qd_recorded - qdd_k * e[:, None]
        q_hat, qd_hat, qdd_hat = _on_index(q_tau, t_hat, T, cutoff_hz, order, qd_tau)
    # the instants wanted: the middle of each held interval [t_k, t_k+1) (zero-order hold of
    # v_τ[k]) or the stamps; their fractional indices on t̂ by two Newton steps
    want = 0.5 * (t[:-1] + t[1:]) if zoh_shift else t + shift_s
    s = want / T
    for _ in range(2):
        s = np.clip(s, 0.0, n - 1.0)
        s = s + (want - _lagrange_at(t_hat, s)) / _lagrange_at(tk, s)
    s = np.clip(s, 0.0, n - 1.0)
    return _lagrange_at(q_hat, s), _lagrange_at(qd_hat, s), _lagrange_at(qdd_hat, s)


def _on_index(q: np.ndarray, t_hat: np.ndarray, T: float, cutoff_hz: float, order: int,
              qd_recorded: np.ndarray | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """q̂, q̂̇, q̂̈ at the instants t̂_k: the low-pass in the index, the chain rule for time."""
    q_hat = zero_phase_butterworth(q, T, cutoff_hz, order)
    tk, tkk = _d1(t_hat)[:, None], _d2(t_hat)[:, None]
    if qd_recorded is None:
        qd_hat = _d1(q_hat) / tk
        qdd_hat = (_d2(q_hat) - qd_hat * tkk) / (tk * tk)
    else:
        qd_hat = zero_phase_butterworth(np.asarray(qd_recorded, float), T, cutoff_hz, order)
        qdd_hat = _d1(qd_hat) / tk
    return q_hat, qd_hat, qdd_hat

def choose_velocity(segments: list, opts, period_s: float, source: str) -> tuple[list, str]:
    """The segments with or without their recorded velocity, by ``opts.velocity_source``, and
    one line saying which and why. ``recorded``: DataError when the record has none or a
    non-finite one. ``auto``: the recorded velocity when every sample has a finite one that
    agrees with the derivative of q within ``opts.velocity_agreement`` (rms of the difference
    over rms of the derivative, each joint, on the longest segment, both low-passed alike)."""
    import dataclasses

    from orthoglide_ident.errors import DataError

    mode = opts.input.velocity_source
    have = bool(segments) and all(s.qd is not None for s in segments)
    derived = [dataclasses.replace(s, qd=None) for s in segments]
    if mode == "derived":
        return derived, "derived from q (velocity_source: derived)"
    finite = have and all(np.isfinite(s.qd).all() for s in segments)
    if mode == "recorded" and not finite:
        raise DataError(f"{source}: velocity_source is recorded but the record has "
                        f"{'non-finite' if have else 'no'} JointState.velocity values; use "
                        "velocity_source: derived")
    if mode == "recorded":
        return segments, "recorded (JointState.velocity, velocity_source: recorded)"
    if not finite:
        return derived, ("derived from q (velocity_source: auto: the record has "
                         f"{'non-finite' if have else 'no'} JointState.velocity)")
    seg = max(segments, key=len)
    trim = int(round(opts.observe.edge_trim_s / period_s))
    f_q, order = opts.observe.filter_cutoff_hz, opts.observe.filter_order
    _, qd_d, _ = states_on_stamps(seg.q, seg.stamps_ns, f_q, order)
    _, qd_r, _ = states_on_stamps(seg.q, seg.stamps_ns, f_q, order, qd_recorded=seg.qd)
    sl = slice(trim, max(trim + 1, qd_d.shape[0] - trim))
    rms = np.sqrt(np.mean(qd_d[sl] ** 2, axis=0))
    gap = np.sqrt(np.mean((qd_r[sl] - qd_d[sl]) ** 2, axis=0)) / np.maximum(rms, 1e-12)
    worst = float(np.max(gap))
    rule = (f"velocity_source: auto, recorded when it agrees with the derivative of q within "
            f"{100 * opts.input.velocity_agreement:g} % rms; worst joint {100 * worst:.2f} %")
    if worst <= opts.input.velocity_agreement:
        return segments, f"recorded (JointState.velocity; {rule})"
    return derived, f"derived from q ({rule})"


__all__ = ["OFF_GRID_TOL", "StepStats", "UNEVEN_SHARE", "is_uniform",
           "mean_step_s", "states_on_stamps", "step_stats", "choose_velocity"]


def states_at_half_tick(
    q: np.ndarray,
    v_tau: np.ndarray,
    period_s: float,
    cutoff_hz: float = 25.0,
    order: int = 4,
    trim: int = 0,
    zoh_shift: bool = True,
    filter_currents: bool = False,
    stamps_ns: np.ndarray | None = None,
    qd_recorded: np.ndarray | None = None,
    shift_s: float = 0.0,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Filtered states paired with the current references they act with.

    Returns ``(q̂, q̂̇, q̂̈, v_tau)`` with the states at t_k + T/2 (``zoh_shift``) or at t_k, and
    ``trim`` samples dropped at each end (filter edge transients). All ``(m, n_j)``. With
    ``filter_currents`` v_tau goes through the same zero-phase low-pass as q (parallel filtering).
    ``stamps_ns`` (n,): the samples' stamps, the time base when they are uneven (time_base.py;
    ``period_s`` is then their mean step); ``qd_recorded``: a recorded velocity used for q̂̇;
    ``shift_s``: without ``zoh_shift``, the states at t_k + shift_s (states_on_stamps).
    """
    if stamps_ns is not None:
        qf, qd, qdd = states_on_stamps(q, stamps_ns, cutoff_hz, order, zoh_shift, qd_recorded,
                                       shift_s)
    else:
        qf, qd, qdd = filtered_states(q, period_s, cutoff_hz, order, zoh_shift)
    if filter_currents:
        v_tau = zero_phase_butterworth(np.asarray(v_tau, dtype=float), period_s, cutoff_hz, order)
    v = v_tau[:-1] if zoh_shift else v_tau
    n = qf.shape[0]
    if n - 2 * trim < 1:
        raise DataError(f"segment of {q.shape[0]} samples is too short to trim {trim} at each end")
    sl = slice(trim, n - trim)
    return qf[sl], qd[sl], qdd[sl], v[sl]
