"""W's smooth columns at the decimated rows only (``regressor_at: rows``, stream.py).

The paper's parallel decimation (eqs. 19-20) filters Y and every column of W by the same
low-pass, then keeps one sample in n_d. A column that is a smooth function of the filtered
states q̂, q̂̇, q̂̈ — every rigid-body and payload column, ia q̈, fv q̇, tauoff — commutes with that
filter to second order: the filtered column is the column of the filtered states,
w(h * x) ≈ h * w(x), plus the spread of the states over the filter's window, which
:func:`smooth_columns_at_rows` restores with two points (q's and q̇'s slopes, q̈'s first moment
over the window: a closed loop's 20-50 Hz in q̈ are not a slope), and products of the content
above the pass band. Such columns are therefore built at the kept instants only, from the
states passed through the same FIR: n_d / 2 times fewer regressor evaluations and none of W's
columns filtered. Measured 2026-12-05 against the sample-rate path (bench/rows_vs_samples.py,
in the reported σ; eqs. 38-39's where it differs): the UR5's 2 x 60 s bags, gains within
0.0022 σ, base parameters within 0.0028 σ; the MuJoCo coupled-wrist plant's 2 x 60 s records
0.0042 σ and 0.0071 σ (0.0081 σ), through simple transmissions 0.0032 σ and 0.0079 σ; the
Panda record 0.0088 σ (0.0115 σ). With q̈'s spread taken as √M2 T times its jerk (2026-12-04):
0.016 σ and 0.035 σ, 0.090 σ and 0.137 σ (yz_3R: over issue 35's 0.1 σ; the plant's records
are ~3 times quieter than the UR5's for the same error of the rows), 0.074 σ and 0.117 σ,
0.015 σ (0.029 σ); from one point, x̃, 0.054 σ and 0.097 σ on the UR5. The rough columns,
which jump where a velocity reverses — sign(q̂̇) Coulomb friction, the lag instrument, the
ripple — and v_τ stay on the sample-rate path (the model names them: ``rough_columns``,
``rough_block``).

A reversal bridge (reversals.py) replaces joint j's whole equation on states s..e-1 by the line
between the means of its anchors [lo, s) and [e, hi). :class:`BridgeCorrections` builds the
smooth columns at the sample rate on s..e-1 only and each anchor's mean of them from two points
(:func:`anchor_points`, the same unscented transform over the anchor's 30 states: 22 200 states
through the regressor instead of 48 600 on the UR5's bags, the answer within 0.0004 σ of exact
means), keeps the line's difference to them on s..e-1 and filters it into the rows whose window
meets it: the rows equal the sample-rate path's bridged ones, to the approximations above.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from orthoglide_ident.identify.observe.decimation import fir_decimate_last, fir_taps
from orthoglide_ident.identify.observe.reversals import bridge_weights


@lru_cache(maxsize=16)
def spread_taps(n_d: int) -> tuple[float, np.ndarray]:
    """√M2 of the decimation FIR h (its taps' second moment about the centre, in samples) and
    the taps l h_l / √M2 of its first moment (l from the centre), the same length."""
    h = fir_taps(n_d)
    lag = np.arange(h.shape[0]) - 0.5 * (h.shape[0] - 1)
    root_m2 = float(np.sqrt(np.sum(h * lag ** 2)))
    return root_m2, h * lag / root_m2


def smooth_columns_at_rows(model_block: Callable, x: np.ndarray, n_d: int, r: int,
                           period_s: float, out: np.ndarray) -> None:
    """The filtered smooth columns at r decimated rows into ``out`` (n_cols, n_j, r), from the
    states ``x`` (3 n_j, m): q̂, q̂̇, q̂̈ of the rows' windows.

    The filter h averages W(x(t + l)) over its window; W of the averaged states x̃ misses the
    spread of the states over it, to second order ½ tr(∇²W C), C = Σ h_l (x_l - x̃)(x_l - x̃)ᵀ.
    Two points x̃ ± d averaged add ½ dᵀ∇²W d (the unscented transform of the window):
    d_q = √M2 T q̂̇ and d_q̇ = √M2 T q̂̈, the states' slopes over the window (M2 = Σ h_l l²,
    2.3 samples² at n_d = 10). W is linear in q̈ with coefficients in q, so q̈'s only
    second-order term is C_qq̈ = T q̂̇ Σ h_l l q̈_l (q a straight line over the window):
    d_q̈ = Σ h_l l q̈_l / √M2, q̈'s first moment, gives it whatever q̈'s spectrum. Its slope
    √M2 T q⃛ (the moment of a Gaussian filter) did not: this FIR's pass band is flat, and at
    20-50 Hz, where a closed loop puts a few % of q̈'s power, the first moment is 2-40 times
    the slope's (0.137 σ on the coupled-wrist plant's yz_3R). q̇'s slope is kept: W is
    quadratic in q̇, whose content above the pass band counts in C_q̇q̇; the slope gives
    C_q̇q̇'s mean within 20 % on the MuJoCo records, the first moment 1.2-3.4 times it."""
    n_j = x.shape[0] // 3
    s, k = spread_taps(n_d)
    xt = fir_decimate_last(x, n_d, r)  # x̃: (3 n_j, r)
    moment = fir_decimate_last(x[2 * n_j:], n_d, r, k)  # Σ h_l l q̈_l / √M2
    d = np.concatenate([s * period_s * xt[n_j:], moment])
    both = np.concatenate([xt - d, xt + d], axis=1)  # (3 n_j, 2 r): one model call
    W = np.empty((out.shape[0], out.shape[1], 2 * r))
    model_block(both[:n_j].T, both[n_j:2 * n_j].T, both[2 * n_j:].T, W)
    np.add(W[:, :, :r], W[:, :, r:], out=out)
    out *= 0.5


MAX_BRIDGE_SAMPLES = 8192  # states per model call around bridges (its W: ~30 MB for 6 joints)

Bridge = tuple[int, int, int, int, int]  # joint j, s, e, lo, hi (state indices)
States = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray, np.ndarray]]


def _spans(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The indices a_i..b_i - 1 of every span, concatenated."""
    n = b - a
    return np.arange(n.sum()) - np.repeat(np.cumsum(n) - n - a, n)


def anchor_points(states: States, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Two states per anchor [a_i, b_i) whose W's mean is the anchor's mean of W to second
    order: x̄ ± √M2 β (x̄ the anchor's mean state, β its least-squares slope per sample,
    M2 = (n² - 1) / 12 the anchor's second moment), the unscented transform of the anchor as
    smooth_columns_at_rows does it for the decimation filter's window. (3 n_j, 2 k): the k
    anchors' lower points, then their upper ones."""
    n = b - a
    idx = _spans(a, b)
    x = np.hstack(states(idx))  # (Σ n, 3 n_j)
    at = np.cumsum(n) - n
    k = idx - np.repeat(a + 0.5 * (n - 1), n)  # position from the anchor's centre
    mean = np.add.reduceat(x, at, axis=0) / n[:, None]
    root_m2 = np.sqrt((n * n - 1) / 12.0)
    d = np.add.reduceat(x * k[:, None], at, axis=0) / np.maximum(n * root_m2, 1e-300)[:, None]
    return np.concatenate([mean - d, mean + d]).T


@dataclass
class _Changes:
    """One group's bridges: joint, run start and end (state indices) of bridge i, and the
    changes of the runs' smooth columns side by side, D (n_smooth, Σ runs), bridge i's at
    columns off[i]..off[i + 1] - 1."""

    j: np.ndarray
    s: np.ndarray
    e: np.ndarray
    off: np.ndarray
    D: np.ndarray

    def overlaps(self, j: int, a: int, b: int, upto: int | None = None):
        """(u, v, changes of states u..v-1) of this group's bridges of joint j (the first
        ``upto`` only) whose run meets states a..b-1."""
        n = self.j.shape[0] if upto is None else upto
        hit = (self.j[:n] == j) & (self.s[:n] < b) & (self.e[:n] > a)
        for i in np.flatnonzero(hit):
            u, v = max(self.s[i], a), min(self.e[i], b)
            yield u, v, self.D[:, self.off[i] + u - self.s[i]:self.off[i] + v - self.s[i]]


class BridgeCorrections:
    """The bridges' changes to the smooth columns of each joint's rows, kept until filtered.

    ``model_block(q, qd, qdd, out)`` writes [W | W_kl] (n_cols, n_j, m); ``rough``: the columns
    the stream keeps at the sample rate (the others are the smooth ones corrected here).
    An anchor's mean of W is taken at its two :func:`anchor_points` (60 states of a bridge's
    89 on the UR5 not built); ``exact_anchors``: at every state of it (the sample-rate path's
    means to round-off, the reference tests/identify/observe/test_smooth_rows.py compares with).
    """

    exact_anchors = False

    def __init__(self, model_block: Callable, n_cols: int, rough: np.ndarray, n_j: int):
        self.model_block, self.n_cols, self.n_j = model_block, n_cols, n_j
        self.smooth = np.setdiff1d(np.arange(n_cols), rough)
        self.groups: list[_Changes] = []
        self.last_e = np.full(n_j, -1, np.int64)  # end of each joint's latest run

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

    def _anchor_states(self, lo, s, e, hi, states: States) -> tuple[np.ndarray, np.ndarray]:
        """The states whose W each anchor averages (3 n_j, p) and where anchor i's begin
        (anchor i: points at[i]..at[i + 1] - 1); anchors [lo, s), [e, hi) of each bridge."""
        a, b = np.stack([lo, e], axis=1).ravel(), np.stack([s, hi], axis=1).ravel()
        if self.exact_anchors:
            return np.hstack(states(_spans(a, b))).T, np.concatenate([[0], np.cumsum(b - a)])
        pts = anchor_points(states, a, b)
        k = a.shape[0]  # anchor i: its two points i and k + i, put side by side
        order = np.arange(2 * k).reshape(2, k).T.ravel()
        return pts[:, order], np.arange(0, 2 * k + 1, 2)

    def _group(self, bridges: list[Bridge], states: States) -> None:
        """One model call for the runs and anchors of ``bridges``, then their lines."""
        j, s, e, lo, hi = (np.array(c, np.int64) for c in zip(*bridges))
        n_run = e - s
        # the runs may overlap (other joints' reversals at once): each state once
        at, where = np.unique(_spans(s, e), return_inverse=True)
        pts, p_at = self._anchor_states(lo, s, e, hi, states)
        x = np.concatenate([np.hstack(states(at)).T, pts], axis=1)
        n_j, sm = self.n_j, self.smooth[:, None]
        W = np.empty((self.n_cols, n_j, x.shape[1]))
        self.model_block(x[:n_j].T, x[n_j:2 * n_j].T, x[2 * n_j:].T, W)
        vals = W[sm, np.repeat(j, n_run), where]  # (n_smooth, Σ runs): a copy
        jp = np.repeat(np.repeat(j, 2), np.diff(p_at))  # the joint of each anchor point
        means = np.add.reduceat(W[sm, jp, at.shape[0] + np.arange(p_at[-1])], p_at[:-1],
                                axis=1) / np.diff(p_at)
        off = np.concatenate([[0], np.cumsum(n_run)])
        g = _Changes(j, s, e, off, np.empty_like(vals))
        g.D[:] = self._lines(means[:, 0::2], means[:, 1::2], s, e, lo, hi, n_run) - vals
        self._earlier(g, vals, means, lo, hi)
        self.groups.append(g)
        np.maximum.at(self.last_e, j, e)

    @staticmethod
    def _lines(m_lo, m_hi, s, e, lo, hi, n_run) -> np.ndarray:
        """The straight lines of reversals.bridge across every run, side by side."""
        k = _spans(s, e)
        t_lo = np.repeat(0.5 * (lo + s - 1), n_run)  # bridge_weights, all runs at once
        t_hi = np.repeat(0.5 * (e + hi - 1), n_run)
        alpha = (k - t_lo) / (t_hi - t_lo)
        b = np.repeat(np.arange(s.shape[0]), n_run)
        return m_lo[:, b] + alpha * (m_hi[:, b] - m_lo[:, b])

    def _earlier(self, g: _Changes, vals, means, lo, hi) -> None:
        """Bridges whose anchors or run meet an earlier bridge of their joint (a run ending
        after its lo): their lines again, in order, from what the sample-rate buffer would
        hold there (the earlier lines)."""
        prev = self.last_e[g.j].copy()  # the latest earlier run of the joint: enough to tell
        for i in range(1, g.j.shape[0]):
            same = np.flatnonzero(g.j[:i] == g.j[i])
            if same.size:
                prev[i] = g.e[same[-1]]
        for i in np.flatnonzero(prev > lo):
            j, s, e = int(g.j[i]), int(g.s[i]), int(g.e[i])
            cols = slice(g.off[i], g.off[i + 1])
            v, m = vals[:, cols].copy(), means[:, 2 * i:2 * i + 2].copy()
            found = [c.overlaps(j, lo[i], hi[i]) for c in self.groups] + \
                [g.overlaps(j, lo[i], hi[i], upto=i)]
            for u, w, d in (x for f in found for x in f):
                for k, (a, b) in enumerate(((lo[i], s), (e, hi[i]))):
                    uu, ww = max(u, a), min(w, b)
                    if uu < ww:
                        m[:, k] += d[:, uu - u:ww - u].sum(axis=1) / (b - a)
                if max(u, s) < min(w, e):
                    v[:, max(u, s) - s:min(w, e) - s] += d[:, max(u, s) - u:min(w, e) - u]
            line = m[:, :1] + bridge_weights(s, e, lo[i], hi[i])[None, :] * (m[:, 1:] - m[:, :1])
            g.D[:, cols] = line - v

    def add_to(self, out: np.ndarray, i0: int, n_d: int, taps: np.ndarray) -> None:
        """Filter the changes into decimated rows i0.. of ``out`` (n_cols + 1, n_j, r); row i's
        FIR window is states i n_d .. i n_d + len(taps) - 1."""
        L, r = taps.shape[0], out.shape[2]
        for g in self.groups:
            for i in range(g.j.shape[0]):
                s, e = int(g.s[i]), int(g.e[i])
                first = max(i0, -(-(s - L + 1) // n_d))
                last = min(i0 + r - 1, (e - 1) // n_d)
                if first > last:
                    continue
                rows = np.arange(first, last + 1)
                k = np.arange(s, e)[:, None] - rows[None, :] * n_d  # tap of each state, row
                T = np.where((k >= 0) & (k < L), taps[np.clip(k, 0, L - 1)], 0.0)
                out[:, int(g.j[i])][np.ix_(self.smooth, rows - i0)] += \
                    g.D[:, g.off[i]:g.off[i + 1]] @ T

    def forget(self, below: int) -> None:
        """Drop the changes to states below ``below`` only (filtered, and no anchor any more)."""
        self.groups = [g for g in self.groups if g.e.max() > below]
