"""W's smooth columns at the decimated rows only (``regressor_at: rows``, stream.py).

The paper's parallel decimation (eqs. 19-20) filters Y and every column of W by the same
low-pass, then keeps one sample in n_d. A column that is a smooth function of the filtered
states q̂, q̂̇, q̂̈ — every rigid-body and payload column, ia q̈, fv q̇, tauoff — commutes with that
filter to second order: the states' content above the filter's pass band is small (noise), so
the filtered column is the column of the filtered states, w(h * x) ≈ h * w(x). What differs is
the spread of the states over the filter's window (second order, the FIR's droop in its pass
band: :func:`smooth_columns_at_rows` restores it with two points) and products of the content
above the pass band. Such columns are therefore built at the kept instants only, from the
states passed through the same FIR: n_d / 2 times fewer regressor evaluations and none of W's
columns filtered. Measured on the UR5's 2 x 60 s bags: gains within 0.016 σ, base parameters
within 0.035 σ of the sample-rate path (0.054 σ and 0.097 σ from one point, x̃; eq. 39's σ);
the Panda record 0.028 σ (0.040 σ). The rough columns, which jump where a velocity
reverses — sign(q̂̇) Coulomb friction, the lag instrument, the ripple — and v_τ stay on the
sample-rate path (the model names them: ``rough_columns``, ``rough_block``).

A reversal bridge (reversals.py) replaces joint j's whole equation on states s..e-1 by the line
between the means of its anchors [lo, s) and [e, hi). :class:`BridgeCorrections` builds the
smooth columns at the sample rate on [lo, hi) only, keeps the line's difference to them on
s..e-1 and filters it into the rows whose window meets it: the rows equal the sample-rate path's
bridged ones, to the approximation above.
"""
from __future__ import annotations

from functools import lru_cache
from typing import Callable

import numpy as np

from orthoglide_ident.identify.decimation import fir_decimate_last, fir_taps
from orthoglide_ident.identify.reversals import bridge_weights


@lru_cache(maxsize=16)
def spread_taps(n_d: int) -> tuple[float, np.ndarray]:
    """√M2 of the decimation FIR (its taps' second moment about the centre, in samples) and
    the taps of its output's time derivative (× the period: per sample), the same length."""
    h = fir_taps(n_d)
    lag = np.arange(h.shape[0]) - 0.5 * (h.shape[0] - 1)
    g = np.zeros_like(h)
    g[1:-1] = 0.5 * (h[:-2] - h[2:])  # d/dt Σ h_l x(t + l) by a central difference of h
    g[0], g[-1] = -0.5 * h[1], 0.5 * h[-2]
    return float(np.sqrt(np.sum(h * lag ** 2))), g


def smooth_columns_at_rows(model_block: Callable, x: np.ndarray, n_d: int, r: int,
                           period_s: float, out: np.ndarray) -> None:
    """The filtered smooth columns at r decimated rows into ``out`` (n_cols, n_j, r), from the
    states ``x`` (3 n_j, m): q̂, q̂̇, q̂̈ of the rows' windows.

    The filter h averages W(x(t + l)) over its window; W of the averaged states misses the
    spread of the states over it, to second order ½ M2 T² ẋᵀ ∇²W ẋ (M2 = Σ h_l l², 2.3 samples²
    at n_d = 10: the FIR's droop in its pass band, 1.8e-4 at 2 Hz). Two points x̃ ± √M2 T ẋ
    (x̃ the filtered states, ẋ their derivative: q̂̇, q̂̈, and the jerk through the derivative's
    taps) averaged restore that term (the unscented transform of the window)."""
    n_j = x.shape[0] // 3
    s, g = spread_taps(n_d)
    xt = fir_decimate_last(x, n_d, r)  # x̃: (3 n_j, r)
    jerk = fir_decimate_last(x[2 * n_j:], n_d, r, g) / period_s
    d = s * period_s * np.concatenate([xt[n_j:], jerk])  # √M2 T ẋ
    both = np.concatenate([xt - d, xt + d], axis=1)  # (3 n_j, 2 r): one model call
    W = np.empty((out.shape[0], out.shape[1], 2 * r))
    model_block(both[:n_j].T, both[n_j:2 * n_j].T, both[2 * n_j:].T, W)
    np.add(W[:, :, :r], W[:, :, r:], out=out)
    out *= 0.5


MAX_BRIDGE_SAMPLES = 8192  # states per model call around bridges (its W: ~30 MB for 6 joints)

Bridge = tuple[int, int, int, int, int]  # joint j, s, e, lo, hi (state indices)
States = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray, np.ndarray]]


class BridgeCorrections:
    """The bridges' changes to the smooth columns of each joint's rows, kept until filtered.

    ``model_block(q, qd, qdd, out)`` writes [W | W_kl] (n_cols, n_j, m); ``rough``: the columns
    the stream keeps at the sample rate (the others are the smooth ones corrected here).
    """

    def __init__(self, model_block: Callable, n_cols: int, rough: np.ndarray, n_j: int):
        self.model_block, self.n_cols, self.n_j = model_block, n_cols, n_j
        self.smooth = np.setdiff1d(np.arange(n_cols), rough)
        self.entries: list[list[tuple[int, int, np.ndarray]]] = [[] for _ in range(n_j)]

    def bridge(self, bridges: list[Bridge], states: States) -> None:
        """Record ``bridges`` (in order per joint); ``states(idx)``: q̂, q̂̇, q̂̈ of states idx."""
        group: list[Bridge] = []
        size = 0
        for b in bridges:
            if group and size + b[4] - b[3] > MAX_BRIDGE_SAMPLES:
                self._group(group, states)
                group, size = [], 0
            group.append(b)
            size += b[4] - b[3]
        if group:
            self._group(group, states)

    def _group(self, bridges: list[Bridge], states: States) -> None:
        """One model call for the anchors and runs of ``bridges``, then each line in order."""
        # the windows overlap (neighbouring reversals, other joints): each state once
        at, where = np.unique(np.concatenate([np.arange(lo, hi) for *_, lo, hi in bridges]),
                              return_inverse=True)
        q, qd, qdd = states(at)
        W = np.empty((self.n_cols, self.n_j, at.shape[0]))
        self.model_block(q, qd, qdd, W)
        off = 0
        for j, s, e, lo, hi in bridges:
            # a copy: what the sample-rate buffer would hold
            vals = W[:, j][np.ix_(self.smooth, where[off:off + hi - lo])]
            off += hi - lo
            for s0, e0, d in self.entries[j]:  # earlier bridges met by these anchors
                a, b = max(s0, lo), min(e0, hi)
                if a < b:
                    vals[:, a - lo:b - lo] += d[:, a - s0:b - s0]
            lo_mean = vals[:, :s - lo].mean(axis=1)
            hi_mean = vals[:, e - lo:].mean(axis=1)
            line = lo_mean[:, None] + bridge_weights(s, e, lo, hi)[None, :] * \
                (hi_mean - lo_mean)[:, None]
            self.entries[j].append((s, e, line - vals[:, s - lo:e - lo]))

    def add_to(self, out: np.ndarray, i0: int, n_d: int, taps: np.ndarray) -> None:
        """Filter the changes into decimated rows i0.. of ``out`` (n_cols + 1, n_j, r); row i's
        FIR window is states i n_d .. i n_d + len(taps) - 1."""
        L, r = taps.shape[0], out.shape[2]
        for j, entries in enumerate(self.entries):
            for s, e, d in entries:
                first = max(i0, -(-(s - L + 1) // n_d))
                last = min(i0 + r - 1, (e - 1) // n_d)
                if first > last:
                    continue
                rows = np.arange(first, last + 1)
                k = np.arange(s, e)[:, None] - rows[None, :] * n_d  # tap of each state, row
                T = np.where((k >= 0) & (k < L), taps[np.clip(k, 0, L - 1)], 0.0)
                out[:, j][np.ix_(self.smooth, rows - i0)] += d @ T

    def forget(self, below: int) -> None:
        """Drop the changes to states below ``below`` only (filtered, and no anchor any more)."""
        self.entries = [[x for x in ent if x[1] > below] for ent in self.entries]
