"""One continuous segment processed block by block into decimated equations (docs/design/method.md).

The offline pipeline (a whole segment at once, pushed in chunks to bound memory) and the live
identification (1 kHz samples pushed about once a second) both run a segment through a
:class:`SegmentStream`, so that both give the same equations whatever the block boundaries:

- derivative filtering (filtering.py): the zero-phase low-pass depends on the future, so a state
  is computed only once :func:`~filtering.filter_horizon` samples after it have arrived (or the
  segment has ended), from a window with that much context on both sides; the segment-end edge
  trim happens only when the segment really ends;
- W and W_kl at the state instants, written once into a buffer ``X: (n_b + 2, n_j, samples)`` —
  columns [W | W_kl | v_tau], joints, time — that holds only what is still needed;
- velocity reversals (reversals.py): a :class:`~reversals.ReversalTracker` decides the same
  bridges and dropped runs as ``find_reversals`` on the whole segment; bridges are applied in
  order, each reading the anchors left by the previous one;
- parallel decimation (eqs. 19-20): FIR output i (state i n_d + 4 n_d) is computed once the
  8 n_d + 1 states of its window are final, from the kept samples only;
- ``regressor_at: rows`` with a robot that names its rough columns (a serial/tree robot): only
  those and v_tau are held at the sample rate; W's smooth columns are built at the decimated
  rows from the filtered states, the bridges' part on them added (smooth_rows.py).
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from orthoglide_ident.errors import DataError
from orthoglide_ident.identify.observe.decimation import fir_decimate_last, fir_taps
from orthoglide_ident.identify.observe.filtering import filter_horizon, zero_phase_butterworth
from orthoglide_ident.identify.observe.reversals import (
    ReversalTracker,
    anchor_samples,
    bridge_weights,
    velocity_deadband,
)
from orthoglide_ident.identify.observe.sampling import (
    at_sampling,
    record_sampling,
    robot_file_sampling,
    sampled_shift_s,
)
from orthoglide_ident.identify.observe.smooth_rows import BridgeCorrections, smooth_columns_at_rows
from orthoglide_ident.identify.observe.time_base import states_on_stamps
from orthoglide_ident.identify.options import IdentifyOptions


@dataclass
class DecimatedRows:
    """Decimated equations of a stretch of a segment, joint by joint (eq. 20).

    ``X: (n_b + 2, n_j, r)``: for joint j and decimated sample i, ``X[:n_b, j, i]`` is the row
    of W, ``X[n_b, j, i]`` the payload column W_kl (per kg) and ``X[n_b + 1, j, i]`` v_tau (A).
    ``keep: (n_j, r)`` bool (rows away from unbridged reversals) or None; ``t: (r,)`` s since the
    record's first stamp (state instants); ``q, qd: (r, n_j)`` the filtered positions (m or rad)
    and velocities at those instants (the residual's position spectrum and the ripple columns
    of identify/drive_terms.py), or None.
    """

    X: np.ndarray
    keep: np.ndarray | None
    t: np.ndarray
    q: np.ndarray | None = None
    qd: np.ndarray | None = None

    @property
    def r(self) -> int:
        return int(self.X.shape[2])

    def write(self, r0: int, rows: DecimatedRows) -> int:
        """Copy ``rows`` into this (preallocated) block at decimated sample r0; the next r0."""
        r1 = r0 + rows.r
        self.X[:, :, r0:r1] = rows.X
        self.t[r0:r1] = rows.t
        if self.keep is not None:
            self.keep[:, r0:r1] = rows.keep
        if self.q is not None and rows.q is not None:
            self.q[r0:r1] = rows.q
            self.qd[r0:r1] = rows.qd
        return r1

    @staticmethod
    def empty(n_cols: int, n_j: int, with_keep: bool) -> DecimatedRows:
        return DecimatedRows(np.zeros((n_cols, n_j, 0)), np.zeros((n_j, 0), bool) if with_keep
                             else None, np.zeros(0), np.zeros((0, n_j)), np.zeros((0, n_j)))


def lag_rows(layout, block: np.ndarray, currents: np.ndarray) -> np.ndarray:
    """v_τ of ``currents`` (m, n_j), or (m, 2 n_j) = [v_τ | lag instrument] for a layout with
    lag columns (columns/layout.py), whose instrument goes into ``block``'s
    (n_b + 1, n_j, m) lag rows, joint j's in its own rows; v_τ returned."""
    col = layout.lag_column
    n_j = block.shape[1]
    if col is not None and currents.shape[1] == 2 * n_j:
        for j in range(n_j):
            block[col + j, j] = currents[:, n_j + j]
    return currents[:, :n_j]


def _rough_columns(layout, opts: IdentifyOptions) -> np.ndarray | None:
    """The columns the stream builds at the sample rate when the others are built at the
    decimated rows (``regressor_at: rows``, a robot that names them, n_d > 1); else None."""
    if opts.observe.regressor_at != "rows" or opts.observe.decimation <= 1:
        return None
    rough = layout.rough_columns
    return None if rough is None else np.asarray(rough, int)


def _fir_nonzero_rows(x: np.ndarray, n_d: int, r: int) -> np.ndarray:
    """fir_decimate_last of ``x`` (k, n_j, m) computed on its rows that hold a non-zero value
    only: a serial robot's friction and lag columns fill their own joint's rows, the other
    five sixths of a 6-DOF arm's rough buffer are zero."""
    x2 = x.reshape(-1, x.shape[-1])
    nz = np.flatnonzero(np.any(x2 != 0.0, axis=1))
    out = np.zeros((x2.shape[0], r))
    out[nz] = fir_decimate_last(x2[nz], n_d, r)
    return out.reshape(x.shape[:-1] + (r,))


def _lag_rows_at(layout, rough: np.ndarray | None) -> list[int]:
    """Where joint j's lag instrument goes in the rough buffer (``rough``'s position of the
    layout's lag column j); none without the lag or the rough buffer."""
    col = layout.lag_column
    if col is None or rough is None:
        return []
    where = {int(c): i for i, c in enumerate(rough)}
    return [where[col + j] for j in range(len(layout.joint_names))]


class SegmentStream:
    """Samples of one continuous segment in, its decimated equations out, block by block.

    ``push(stamps_ns, q, v_tau)`` appends consecutive ticks (q m or rad, v_tau A, both (m, n_j);
    v_tau (m, 2 n_j) with the lag instrument beside it, :func:`lag_rows`) and returns the rows that
    became
    final; ``finish()`` ends the segment (edge trim, last rows).
    Offline, ``push_states`` takes the states of the whole segment filtered at once instead
    (one FFT per segment, as before block processing existed). Either way the concatenation of
    everything returned is the same to round-off (~1e-12 relative), whatever the block sizes.
    ``robot``: bound to the record's payload (columns/layout.bound_to); ``layout``: the columns
    beside W (columns/layout.ColumnLayout: W has ``layout.n_columns`` of them), ``payload`` the
    record's, whose unknown kinds fill W_ul; ``t0_ns``: the record's first stamp (for the rows'
    instants).
    """

    def __init__(self, robot, layout, opts: IdentifyOptions, period_s: float, t0_ns: int,
                 payload=None):
        if opts.observe.decimation_filter != "fir":
            raise DataError("block-by-block processing needs decimation_filter: fir (cheby1's "
                            "IIR depends on the whole segment)")
        opts = opts.at_rate(1.0 / period_s)  # Hz and s to samples (idempotent)
        # live, the option (or the robot file) says how the current relates to its stamps;
        # offline, observe() has resolved the record's already (idempotent)
        opts = at_sampling(opts, record_sampling(None, opts.input.current_sampling,
                                                 robot_file_sampling(robot))[0])
        self.shift = sampled_shift_s(opts)  # s, a sampled current's loop half tick
        self.robot, self.layout, self.payload = robot, layout, payload
        self.opts, self.T, self.t0_ns, self.n_b = opts, period_s, t0_ns, layout.n_columns
        n_b = self.n_b
        self.n_j = n_j = robot.n_joints
        self.zoh = 1 if opts.observe.zoh_shift else 0
        self.trim = int(round(opts.observe.edge_trim_s / period_s))
        self.M = filter_horizon(period_s, opts.observe.filter_cutoff_hz, opts.observe.filter_order)
        self.n_d = opts.observe.decimation
        self.L = 1 if self.n_d == 1 else fir_taps(self.n_d).shape[0]
        self.tracker = None
        self.anchor = anchor_samples(period_s)  # samples averaged each side of a bridge
        if opts.observe.velocity_deadband_mps > 0:
            self.tracker = ReversalTracker(
                velocity_deadband(robot, opts.observe.velocity_deadband_mps),
                max(1, int(round(opts.observe.reversal_max_bridge_s / period_s))),
                int(round(opts.observe.reversal_margin_s / period_s)), n_j)
        self.rough = _rough_columns(layout, opts)  # None: every column at every sample
        self._lag_at = _lag_rows_at(layout, self.rough)
        self._corr = None if self.rough is None else BridgeCorrections(
            self._block, n_b + 1, self.rough, n_j)
        self.pending: list[list] = [[] for _ in range(n_j)]  # decisions waiting for anchors
        self.n_raw = 0  # ticks received
        self.n_states: int | None = None  # known once the segment has ended
        self.n_bridged = self.n_unbridged = 0  # joint samples (SegmentReport)
        self.last_qd = np.zeros((0, n_j))  # q̂̇ of the states computed by the last call
        self._raw0 = 0  # tick index of the first raw sample held
        self._st = np.zeros(0, np.int64)
        self._q = np.zeros((0, n_j))
        self._v = np.zeros((0, n_j))
        self._b0 = 0  # state index of buffer column 0
        self._S = 0  # states computed
        # the sample-rate buffer: columns [W | W_kl | v_tau], or [rough columns | v_tau]
        self._X = np.zeros((n_b + 2 if self.rough is None else len(self.rough) + 1, n_j, 0))
        self._drop = np.zeros((n_j, 0), bool)
        self._ts = np.zeros(0, np.int64)
        self._qs = np.zeros((0, 3 * n_j))  # q̂, q̂̇, q̂̈ of the states
        self._i_out = 0  # next decimated output
        self.times = {"filtering": 0.0, "regressor": 0.0, "decimation": 0.0}  # s, wall clock

    def _block(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, out: np.ndarray) -> None:
        """[W | columns beside it | W_kl] of states (m, n_j) into ``out`` (n_b + 1, n_j, m)."""
        self.layout.observation_block(self.robot, q, qd, qdd, out, self.payload)

    # --- input --------------------------------------------------------------------------------
    def push(self, stamps_ns: np.ndarray, q: np.ndarray, v_tau: np.ndarray) -> DecimatedRows:
        """Append consecutive ticks (live); the rows that became final."""
        self._st = np.concatenate([self._st, np.asarray(stamps_ns, np.int64)])
        self._q = np.concatenate([self._q, np.asarray(q, float)])
        v = np.asarray(v_tau, float)
        self._v = np.concatenate([self._v.reshape(-1, v.shape[1]) if self._v.size == 0 else
                                  self._v, v])  # (m, n_j), or (m, 2 n_j) with the instrument
        self.n_raw += int(np.shape(stamps_ns)[0])
        return self._advance(self._filter_new())

    def push_states(self, stamps_ns: np.ndarray, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray,
                    v_tau: np.ndarray) -> DecimatedRows:
        """Append states filtered elsewhere (offline: the whole trimmed segment at once, as
        ``time_base.states_at_half_tick`` gives them, with the stamps of their ticks)."""
        self.n_raw = -1  # states mode: no raw samples
        self._add_states(np.asarray(stamps_ns, np.int64), q, qd, qdd, v_tau)
        return self._advance(qd)

    def finish(self) -> DecimatedRows:
        """End the segment: trim its end and return the last rows."""
        if self.n_raw < 0:
            self.n_states = self._S
            return self._advance(None)
        n = self.n_raw - self.zoh - 2 * self.trim
        if n < 1:
            raise DataError(f"segment of {self.n_raw} samples is too short to trim {self.trim} "
                            "at each end")
        self.n_states = n
        return self._advance(self._filter_new())

    # --- processing ---------------------------------------------------------------------------
    def _advance(self, qd: np.ndarray | None) -> DecimatedRows:
        """Reversals, bridges, decimation and buffer upkeep after new states (q̂̇ ``qd``)."""
        t0 = time.perf_counter()
        self.last_qd = np.zeros((0, self.n_j)) if qd is None else qd
        if self.tracker is not None:
            self.tracker.update(qd, self.n_states)
            self._apply_decisions()
        out = self._decimate(self._final_states())
        self._compact()
        if self.n_states is not None:
            self.n_unbridged += int(self._drop[:, :self._S - self._b0].sum())
            self._drop[:, :] = False
        self.times["decimation"] += time.perf_counter() - t0
        return out

    def _filter_new(self) -> np.ndarray | None:
        """Filter and differentiate every state whose filter context has arrived; its q̂̇."""
        if self.n_states is not None:
            s_new = self.n_states
        else:
            # context for the filter, and only states that exist whenever the segment ends
            s_new = self.n_raw - self.zoh - self.trim - max(self.M, self.trim)
        S, trim, r0 = self._S, self.trim, self._raw0
        if s_new <= S:
            return None
        t0 = time.perf_counter()
        w0 = max(0, trim + S - self.M)
        w1 = min(self.n_raw, trim + s_new + self.zoh + self.M)
        # on the window's own stamps: an uneven clock's time base (exactly uniform: unchanged)
        qh, qdh, qddh = states_on_stamps(self._q[w0 - r0:w1 - r0], self._st[w0 - r0:w1 - r0],
                                         self.opts.observe.filter_cutoff_hz,
                                         self.opts.observe.filter_order,
                                         self.opts.observe.zoh_shift, shift_s=self.shift)
        a, b = trim + S - w0, trim + s_new - w0
        v = self._v[w0 - r0:w1 - r0]
        if self.opts.observe.filter_currents:  # the same window and filter as q: rows as offline's
            v = zero_phase_butterworth(
                v, self.T, self.opts.observe.filter_cutoff_hz, self.opts.observe.filter_order
            )
        self.times["filtering"] += time.perf_counter() - t0
        self._add_states(self._st[trim + S - r0:trim + s_new - r0], qh[a:b], qdh[a:b], qddh[a:b],
                         v[a:b])
        keep_from = max(0, trim + s_new - self.M) - r0  # the next window's first tick
        if keep_from > 0:
            self._st, self._q, self._v = (x[keep_from:] for x in (self._st, self._q, self._v))
            self._raw0 += keep_from
        return qdh[a:b]

    def _add_states(self, stamps_ns: np.ndarray, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray,
                    v_tau: np.ndarray) -> None:
        """W and W_kl (or the rough columns) of new states into the buffer, with their v_tau,
        stamps and q̂, q̂̇, q̂̈."""
        t0 = time.perf_counter()
        m, n_j = q.shape[0], self.n_j
        X, pos = self._reserve(m)
        k = X.shape[0] - 1  # v_tau's row
        if self.rough is None:
            block = X[:k, :, pos:pos + m]
            self._block(q, qd, qdd, block)
            X[k, :, pos:pos + m] = lag_rows(self.layout, block, np.asarray(v_tau)).T
        else:  # the rough columns only: the others are built at the decimated rows
            self.layout.rough_block(self.robot, q, qd, qdd, out=X[:k, :, pos:pos + m])
            X[k, :, pos:pos + m] = v_tau[:, :n_j].T
            if v_tau.shape[1] == 2 * n_j:  # the lag instrument in joint j's rows
                for j, row in enumerate(self._lag_at):
                    X[row, j, pos:pos + m] = v_tau[:, n_j + j]
        self._ts[pos:pos + m] = stamps_ns
        self._qs[pos:pos + m] = np.hstack([q, qd, qdd])
        self._drop[:, pos:pos + m] = False
        self._S += m
        self.times["regressor"] += time.perf_counter() - t0

    def _reserve(self, m: int) -> tuple[np.ndarray, int]:
        """Room for m more states at the end of the buffer: (buffer, column of the first)."""
        used = self._S - self._b0
        if used + m > self._X.shape[2]:
            cap = used + m + max(1024, (used + m) // 8)
            X = np.empty((self._X.shape[0], self.n_j, cap))
            X[:, :, :used] = self._X[:, :, :used]
            drop = np.zeros((self.n_j, cap), bool)
            drop[:, :used] = self._drop[:, :used]
            ts = np.zeros(cap, np.int64)
            ts[:used] = self._ts[:used]
            qs = np.zeros((cap, self._qs.shape[1]))
            qs[:used] = self._qs[:used]
            self._X, self._drop, self._ts, self._qs = X, drop, ts, qs
        return self._X, used

    def _compact(self) -> None:
        """Forget states no later bridge or decimation window can reach."""
        keep = self._S
        if self.tracker is not None:
            for j in range(self.n_j):
                keep = min(keep, self._final(j) - self.anchor)
        keep = min(keep, self._i_out * self.n_d)
        k = keep - self._b0
        if k <= 0 or (k < self._X.shape[2] // 2 and self.n_states is None):
            return  # move the live tail to the front only when half the buffer is free
        used = self._S - self._b0
        self.n_unbridged += int(self._drop[:, :k].sum())
        self._X[:, :, :used - k] = self._X[:, :, k:used]
        self._drop[:, :used - k] = self._drop[:, k:used]
        self._ts[:used - k] = self._ts[k:used]
        self._qs[:used - k] = self._qs[k:used]
        self._b0 = keep
        if self._corr is not None:
            self._corr.forget(keep)

    # --- velocity reversals -------------------------------------------------------------------
    def _final(self, j: int) -> int:
        """State index below which joint j's values and drop flags are final."""
        f = self.tracker.final_upto(j)
        if self.pending[j]:
            f = min(f, self.pending[j][0].s)
        return f

    def _apply_decisions(self) -> None:
        """Bridge or drop each decided run, in order per joint, once its anchors are computed."""
        for d in self.tracker.decisions:
            self.pending[d.j].append(d)
        self.tracker.decisions.clear()
        n = self.n_states
        bridges = []
        for j in range(self.n_j):
            queue = self.pending[j]
            while queue:
                d = queue[0]
                hi = d.e + self.anchor if n is None else min(d.e + self.anchor, n)
                if d.ok and hi > self._S or not d.ok and d.e > self._S:
                    break
                queue.pop(0)
                if d.ok:
                    bridges.append((j, d.s, d.e, max(d.s - self.anchor, 0), hi))
                    self._bridge(*bridges[-1])
                else:  # the part below the buffer was marked while the run was open
                    self._drop[j, max(d.s - self._b0, 0):d.e - self._b0] = True
            span = self.tracker.open_drop(j)
            if span is not None:
                self._drop[j, max(span[0] - self._b0, 0):min(span[1], self._S) - self._b0] = True
        if self._corr is not None and bridges:  # the smooth columns' part of the bridges
            self._corr.bridge(bridges, self._states)

    def _states(self, idx: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """q̂, q̂̇, q̂̈ (m, n_j) of states idx (held in the buffer)."""
        x = self._qs[idx - self._b0]
        n_j = self.n_j
        return x[:, :n_j], x[:, n_j:2 * n_j], x[:, 2 * n_j:]

    def _bridge(self, j: int, s: int, e: int, lo: int, hi: int) -> None:
        """The straight line of reversals.bridge across states s..e-1 of joint j, every column."""
        b0 = self._b0
        x = self._X[:, j, :]
        lo_mean = x[:, lo - b0:s - b0].mean(axis=1)
        hi_mean = x[:, e - b0:hi - b0].mean(axis=1)
        alpha = bridge_weights(s, e, lo, hi)
        x[:, s - b0:e - b0] = lo_mean[:, None] + alpha[None, :] * (hi_mean - lo_mean)[:, None]
        self.n_bridged += e - s

    # --- decimation ---------------------------------------------------------------------------
    def _final_states(self) -> int:
        """States whose values (bridges) and drop flags are final."""
        end = self._S
        if self.tracker is not None:
            for j in range(self.n_j):
                end = min(end, self._final(j))
        return end

    def _decimate(self, end: int) -> DecimatedRows:
        """FIR outputs whose whole window lies below state ``end``."""
        n_d, L, b0 = self.n_d, self.L, self._b0
        r = (end - L) // n_d + 1 - self._i_out if end >= L else 0
        with_keep = self.tracker is not None
        if r <= 0:
            return DecimatedRows.empty(self.n_b + 2, self.n_j, with_keep)
        a = self._i_out * n_d - b0
        b = a + (r - 1) * n_d + L
        x = self._X[:, :, a:b]
        if self.rough is not None:
            Xd = self._smooth_at_rows(_fir_nonzero_rows(x, n_d, r), a, b, r)
        else:
            Xd = x[:, :, ::n_d].copy() if n_d == 1 else fir_decimate_last(x, n_d, r)
        keep = None
        if with_keep:
            cs = np.concatenate([np.zeros((self.n_j, 1), np.int64),
                                 np.cumsum(self._drop[:, a:b], axis=1, dtype=np.int64)], axis=1)
            start = np.arange(r) * n_d
            keep = (cs[:, start + L] - cs[:, start]) == 0
        centre = a + (L - 1) // 2 + np.arange(r) * n_d
        t = (self._ts[centre] - self.t0_ns) * 1e-9 + (0.5 * self.T if self.zoh else self.shift)
        self._i_out += r
        qs = self._qs[centre]
        return DecimatedRows(Xd, keep, t, qs[:, :self.n_j], qs[:, self.n_j:2 * self.n_j])

    def _smooth_at_rows(self, Xr: np.ndarray, a: int, b: int, r: int) -> np.ndarray:
        """The decimated rows (n_b + 2, n_j, r) from the decimated rough columns and v_tau
        ``Xr`` and W's smooth columns at the rows' instants, built from the states of buffer
        columns a..b through the same decimation filter: a smooth column is a smooth function of
        the states, so the filtered column is the column of the filtered states and of their
        spread over the filter's window (smooth_rows.smooth_columns_at_rows)."""
        n_j = self.n_j
        x = np.ascontiguousarray(self._qs[a:b].T)
        out = np.empty((self.n_b + 2, n_j, r))
        smooth_columns_at_rows(self._block, x, self.n_d, r, self.T, out[:self.n_b + 1])
        self._corr.add_to(out, self._i_out, self.n_d, fir_taps(self.n_d))
        out[self.rough] = Xr[:-1]
        out[self.n_b + 1] = Xr[-1]
        return out
