"""Honest standard deviations and residual diagnostics, from moments folded with the R factors.

The paper's eqs. (38)-(39) assume that the equation errors of W_tot are independent from row to
row. Decimated residuals of a real drive are not: the decimation filter correlates neighbouring
rows (white current noise gives a lag-1 autocorrelation of ~0.37 after it), and the forces the
IDIM lacks (current-loop lag, Stribeck friction, screw ripple) leave a residual that is
correlated sample to sample and concentrated where the regressors are large (velocity
reversals, fast moves). A covariance that assumes white errors then covers the noise but not
the error those forces cause. Two sandwich estimates of the covariance of the solution (the
errors-in-the-equation linearisation of TLS and WLS: δx = G⁻¹ Aᵀ ρ, so Cov(x) = G⁻¹ M G⁻¹ with
M = Cov(Aᵀ ρ)) fix this, both from quantities folded as the data come (same offline and live):

- **stationary correlation** (lag window): M = Σ_j Σ_|L|≤K w_L γ_j(L) Σ_k a_k a_(k+L)ᵀ / σ_j², the
  exact covariance of least squares under a stationary error with the residual's autocovariance
  γ_j(L) per joint (Bartlett weights w_L, K = ``LAGS`` rows): it covers the decimation filter's
  correlation and short-range correlation of the residual;
- **blocks** (cluster-robust sandwich, the linearised block bootstrap): rows grouped in blocks
  of consecutive time (``BLOCK_S``, doubled while a record has more than ``MAX_BLOCKS``), all
  joints of a block together; M = Σ_b s_b s_bᵀ with the block score s_b = Σ_(k in b) a_k ρ_k. It
  covers residuals that are correlated over a block and aligned with the regressors (an
  unmodelled force that recurs at every reversal), whose error no row-by-row estimate sees.

The reported σ ("honest") is, parameter by parameter, the largest of eqs. (38)-(39), the
stationary and the block estimate; the paper's σ is reported next to it.

Folded per record (``ResidualMoments``): per-block Gram matrices of the rows of each joint, lagged
products z_k z_(k+L)ᵀ (L = 1..LAGS) over consecutive rows of a segment, and the Fourier
coefficients of the rows against position, Σ_k z_k w_k exp(-2πi q_k / λ) on a grid of
wavelengths λ, which give the residual's spectrum over position: a peak at the screw lead says
"ripple". The weights are w_k = H_k (a force ripple) and sign(q̇_k) H_k (a friction ripple), with
H_k = H(|q̇_k| / λ) the decimation filter's gain at the ripple's frequency in time when the joint
moves at q̇_k: what of a ripple r(q) survives in the decimated row is ≈ r(q_k) H_k. With
Σ w_k² and Σ w_k² exp(-4πi q_k / λ) they also hold the normal equations of a model with two more
columns per joint, w cos and w sin of 2π q / λ (drive_terms.py). Everything stays linear in the
solution, so it is evaluated for whatever solution the solver picks, without the rows.
"""
from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np

from orthoglide_ident.results import ResidualDiagnostics, SpectrumPeak

BLOCK_S = 1.0  # s, shortest block of the block sandwich
MAX_BLOCKS = 64  # per record: beyond, neighbouring blocks merge (block length doubles)
MIN_BLOCKS = 8  # fewer blocks in all: the block sandwich is too noisy to use
LAGS = 5  # decimated rows of lagged products (autocorrelation, stationary sandwich)
# wavelengths of the position spectrum of the residual: 4 mm .. 50 mm, 3 % apart (screw leads;
# shorter ones are lost by the decimated rows except at a crawl)
WAVELENGTHS_M = np.geomspace(4.0e-3, 50.0e-3, 86)
CONTINUITY_TOL = 0.25  # of the row period: consecutive rows of one segment
# rows with at most this fraction of their columns non-zero (a serial arm's joint: not the
# bodies before it, nor the other joints' drive terms) have their products and QR computed on
# those columns only; a closed chain's rows fill nearly all (the Orthoglide's 64 of 66)
SPARSE_COLUMNS = 0.75
# rows of a joint from a sign change of its current on (that row included): where a backlash is
# crossed (the drive's torque reverses) and the residual of what the model lacks there sits
REVERSAL_ROWS = 3


@dataclass
class ResidualMoments:
    """What one record's decimated rows leave for the σ and the diagnostics (see module doc).

    ``n_c`` columns per row ([W | W_kl | v_tau]); ``blocks``: block index → (n_j, n_c, n_c) Gram of
    the kept rows of each joint in [index·block_s, (index+1)·block_s); ``lagged: (n_j, LAGS, n_c,
    n_c)`` Σ z_k z_(k+L)ᵀ over rows L apart in one segment (z = 0 where a row is left out);
    ``pairs: (n_j, LAGS + 1)`` rows (L = 0) and pairs of kept rows; ``spectrum: (n_j, 2, n_λ, n_c)``
    Σ z_k w_k exp(-2πi q_k/λ) with w = (H, sign(q̇) H); ``ripple_s0: (n_j, 2, n_λ)`` Σ w_k² and
    ``ripple_s2: (n_j, 2, n_λ)`` Σ w_k² exp(-4πi q_k/λ) over kept rows; ``spectrum_rows: (n_j,)``.
    ``decimation``: n_d of the rows (for H), ``row_period_s`` = n_d x the tick period.
    """

    n_c: int
    n_j: int  # actuated joints
    row_period_s: float | None = None
    decimation: int = 1
    block_s: float = 0.0  # s, current block length (0: BLOCK_S)
    blocks: dict[int, np.ndarray] = field(default_factory=dict)
    block_rows: dict[int, np.ndarray] = field(default_factory=dict)  # (n_j,) kept rows per joint
    lagged: np.ndarray | None = None
    pairs: np.ndarray | None = None
    spectrum: np.ndarray | None = None
    ripple_s0: np.ndarray | None = None
    ripple_s2: np.ndarray | None = None
    spectrum_rows: np.ndarray | None = None
    _tail: tuple | None = None  # last LAGS rows: (Z (n_j, m, n_c), t (m,))
    # the joints whose position spectrum is folded (a screw's ripple: prismatic joints); None: all
    screws: tuple[bool, ...] | None = None
    # (n_j, n_c, n_c) Gram of each joint's rows at a reversal of its current (REVERSAL_ROWS from
    # its sign change on), their count, and the state carried from fold to fold (rows since the
    # last sign change, that sign): the same rows whatever the batches
    reversal: np.ndarray | None = None
    reversal_rows: np.ndarray | None = None
    reversal_state: tuple[np.ndarray, np.ndarray] | None = None

    def __post_init__(self) -> None:
        n_j, n_l = self.n_j, WAVELENGTHS_M.shape[0]
        if self.lagged is None:
            self.lagged = np.zeros((n_j, LAGS, self.n_c, self.n_c))
        if self.pairs is None:
            self.pairs = np.zeros((n_j, LAGS + 1), dtype=np.int64)
        if self.block_s <= 0:
            self.block_s = BLOCK_S
        if self.spectrum is None:
            self.spectrum = np.zeros((n_j, 2, n_l, self.n_c), dtype=complex)
        if self.ripple_s0 is None:
            self.ripple_s0 = np.zeros((n_j, 2, n_l))
        if self.ripple_s2 is None:
            self.ripple_s2 = np.zeros((n_j, 2, n_l), dtype=complex)
        if self.spectrum_rows is None:
            self.spectrum_rows = np.zeros(n_j, dtype=np.int64)
        if self.reversal is None:
            self.reversal = np.zeros((n_j, self.n_c, self.n_c))
            self.reversal_rows = np.zeros(n_j, dtype=np.int64)
        if self.reversal_state is None:
            self.reversal_state = (np.full(n_j, REVERSAL_ROWS), np.zeros(n_j))

    @property
    def n_blocks(self) -> int:
        return len(self.blocks)

    def without_columns(self, keep: np.ndarray) -> ResidualMoments:
        """The moments of the columns ``keep`` only (RecordFactors.without_columns)."""
        ix = np.ix_(keep, keep)
        tail = None if self._tail is None else (self._tail[0][:, :, keep], self._tail[1],
                                                self._tail[2])
        return ResidualMoments(
            len(keep), self.n_j, self.row_period_s, self.decimation, self.block_s,
            {b: g[(slice(None),) + ix] for b, g in self.blocks.items()},
            {b: r.copy() for b, r in self.block_rows.items()},
            self.lagged[(slice(None), slice(None)) + ix], self.pairs.copy(),
            self.spectrum[..., keep], self.ripple_s0.copy(), self.ripple_s2.copy(),
            self.spectrum_rows.copy(), tail, self.screws, self.reversal[(slice(None),) + ix],
            self.reversal_rows.copy(), tuple(a.copy() for a in self.reversal_state))

    def only_joints(self, idx: np.ndarray) -> ResidualMoments:
        """The moments of the joints ``idx`` only (RecordFactors.only_joints: a partial answer)."""
        tail = None if self._tail is None else (self._tail[0][idx], self._tail[1],
                                                self._tail[2][idx])
        return ResidualMoments(
            self.n_c, len(idx), self.row_period_s, self.decimation, self.block_s,
            {b: g[idx] for b, g in self.blocks.items()},
            {b: r[idx] for b, r in self.block_rows.items()},
            self.lagged[idx], self.pairs[idx], self.spectrum[idx], self.ripple_s0[idx],
            self.ripple_s2[idx], self.spectrum_rows[idx], tail,
            None if self.screws is None else tuple(self.screws[i] for i in idx),
            self.reversal[idx], self.reversal_rows[idx], tuple(a[idx] for a in self.reversal_state))

    def fold(self, X: np.ndarray, keep: np.ndarray | None, t: np.ndarray,
             q: np.ndarray | None = None, qd: np.ndarray | None = None) -> None:
        """Fold decimated rows ``X: (n_c, n_j, r)`` at instants ``t: (r,)`` s (in time order,
        after the rows already folded), ``keep: (n_j, r)`` or None, positions/velocities (r,
        n_j)."""
        if X.shape[2]:
            self.fold_rows(np.array(X.transpose(1, 2, 0), order="C"), keep, t, q, qd)  # a copy

    def fold_rows(self, Z: np.ndarray, keep: np.ndarray | None, t: np.ndarray,
                  q: np.ndarray | None = None, qd: np.ndarray | None = None) -> None:
        """:meth:`fold` of the rows as ``Z: (n_j, r, n_c)``, a C-contiguous array of the
        caller's (rows left out, ``keep`` False, are zeroed in it)."""
        r = Z.shape[1]
        if r == 0:
            return
        if keep is not None:
            Z *= keep[:, :, None]
        kept = np.ones((self.n_j, r), bool) if keep is None else np.asarray(keep, bool)
        cols = _nonzero_columns(Z, None if self._tail is None else self._tail[0])
        self._fold_blocks(Z, kept, t, cols)
        self._fold_lagged(Z, kept, t, cols)
        self._fold_reversals(Z)
        if q is not None and qd is not None:
            self._fold_spectrum(Z, kept, q, qd)

    def _fold_blocks(self, Z: np.ndarray, kept: np.ndarray, t: np.ndarray, cols) -> None:
        idx = np.floor(np.asarray(t) / self.block_s).astype(np.int64)
        cuts = np.flatnonzero(np.diff(idx)) + 1
        compact = _compact(Z, cols)
        for a, b in zip(np.concatenate([[0], cuts]), np.concatenate([cuts, [idx.shape[0]]])):
            G = _products(Z, compact, cols, slice(a, b), slice(a, b))  # Gram per joint
            n = kept[:, a:b].sum(axis=1)
            key = int(idx[a])
            if key in self.blocks:
                self.blocks[key] += G
                self.block_rows[key] += n
            else:
                self.blocks[key] = G
                self.block_rows[key] = n
        while len(self.blocks) > MAX_BLOCKS:  # longer records: longer blocks, bounded memory
            merged: dict[int, np.ndarray] = {}
            rows: dict[int, np.ndarray] = {}
            for key, G in self.blocks.items():
                k2 = key // 2
                merged[k2] = merged[k2] + G if k2 in merged else G
                rows[k2] = rows[k2] + self.block_rows[key] if k2 in rows else self.block_rows[key]
            self.blocks, self.block_rows = merged, rows
            self.block_s *= 2.0

    def _fold_lagged(self, Z: np.ndarray, kept: np.ndarray, t: np.ndarray, cols) -> None:
        n_t = 0
        if self._tail is not None:
            Zt, tt, kt = self._tail
            n_t = tt.shape[0]
            Z = np.concatenate([Zt, Z], axis=1)
            t = np.concatenate([tt, t])
            kept = np.concatenate([kt, kept], axis=1)
        m = t.shape[0]
        compact = _compact(Z, cols)
        self.pairs[:, 0] += kept[:, n_t:].sum(axis=1)
        if self.row_period_s is not None and m > 1:
            step = np.diff(t)
            brk = np.abs(step - self.row_period_s) > CONTINUITY_TOL * self.row_period_s
            run = np.concatenate([[0], np.cumsum(brk)])
            for L in range(1, LAGS + 1):
                i0 = max(n_t - L, 0)
                if i0 + L >= m:
                    continue
                same = run[i0:m - L] == run[i0 + L:m]
                # a gap: no product across it (most folds have none)
                gap = None if same.all() else same
                self.lagged[:, L - 1] += _products(Z, compact, cols, slice(i0, m - L),
                                                   slice(i0 + L, m), gap)
                self.pairs[:, L] += np.sum(same & kept[:, i0:m - L] & kept[:, i0 + L:m], axis=1)
        k = min(LAGS, m)
        self._tail = (Z[:, m - k:].copy(), t[m - k:].copy(), kept[:, m - k:].copy())

    def _fold_reversals(self, Z: np.ndarray) -> None:
        """The Gram of each joint's rows at a reversal of its current (the last column, v_τ):
        the row where its sign changes and the REVERSAL_ROWS - 1 after it. Rows left out (zero)
        carry no sign."""
        since, last = self.reversal_state
        for j in range(self.n_j):
            sign = np.sign(Z[j, :, -1])
            flag = np.zeros(sign.shape[0], bool)
            for k, sg in enumerate(sign):
                if sg != 0 and last[j] != 0 and sg != last[j]:
                    since[j] = 0
                flag[k] = sg != 0 and since[j] < REVERSAL_ROWS
                since[j] += 1
                last[j] = sg if sg != 0 else last[j]
            if flag.any():
                Zr = Z[j, flag]
                self.reversal[j] += Zr.T @ Zr
                self.reversal_rows[j] += int(flag.sum())

    def _fold_spectrum(self, Z: np.ndarray, kept: np.ndarray, q: np.ndarray, qd: np.ndarray
                       ) -> None:
        k = 2.0 * np.pi / WAVELENGTHS_M
        tick = None if self.row_period_s is None else self.row_period_s / max(self.decimation, 1)
        for j in range(self.n_j):
            if self.screws is not None and not self.screws[j]:
                continue  # no screw: its spectrum stays empty (spectrum_peaks skips it too)
            phase = np.outer(q[:, j], k)  # (r, n_λ)
            H = fir_gain(np.abs(qd[:, j])[:, None] / WAVELENGTHS_M[None, :], self.decimation, tick)
            H *= kept[j][:, None]
            C, S = np.cos(phase) * H, np.sin(phase) * H  # w exp(-iφ) = C - iS, real products
            sgn = np.sign(qd[:, j])[:, None]
            both = np.concatenate([Z[j], Z[j] * sgn], axis=1)  # kinds 0 (w = H), 1 (w = sign H)
            n_c = Z.shape[2]
            F = C.T @ both - 1j * (S.T @ both)  # (n_λ, 2 n_c)
            w2 = H * H
            s0 = w2.sum(axis=0)
            s2 = (C * C - S * S).sum(axis=0) - 2j * (C * S).sum(axis=0)  # Σ w² exp(-2iφ)
            s0_sign, s2_sign = s0, s2  # sign² = 1, but where q̇ is exactly 0
            if not np.all(sgn):
                nz = sgn != 0
                s0_sign = (w2 * nz).sum(axis=0)
                s2_sign = ((C * C - S * S) * nz).sum(axis=0) - 2j * ((C * S) * nz).sum(axis=0)
            self.spectrum[j, 0] += F[:, :n_c]
            self.spectrum[j, 1] += F[:, n_c:]
            self.ripple_s0[j, 0] += s0
            self.ripple_s0[j, 1] += s0_sign
            self.ripple_s2[j, 0] += s2
            self.ripple_s2[j, 1] += s2_sign
            self.spectrum_rows[j] += int(kept[j].sum())


def _nonzero_columns(Z: np.ndarray, tail: np.ndarray | None) -> list[np.ndarray] | None:
    """Per joint, the columns of its rows ``Z: (n_j, m, n_c)`` (and of the held ``tail``) that
    hold a non-zero value; None when every joint has nearly all (a closed chain's rows). A
    serial arm's joint j has none of the bodies before it nor the other joints' drive terms:
    the UR5's hold 42 .. 14 of 66, so its moments' products cost a quarter."""
    nz = np.any(Z != 0.0, axis=1)
    if tail is not None:
        nz |= np.any(tail != 0.0, axis=1)
    if nz.sum() > SPARSE_COLUMNS * nz.size:
        return None
    return [np.flatnonzero(row) for row in nz]


def _compact(Z: np.ndarray, cols: list[np.ndarray] | None) -> list[np.ndarray] | None:
    """Per joint, its rows on its non-zero columns only (r, len(cols[j])), or None."""
    return None if cols is None else [np.ascontiguousarray(Z[j][:, c]) for j, c in enumerate(cols)]


def _products(Z: np.ndarray, compact, cols, a: slice, b: slice,
              mask: np.ndarray | None = None) -> np.ndarray:
    """Σ_k z_a(k) z_b(k)ᵀ per joint (n_j, n_c, n_c) of rows ``a`` and rows ``b`` of ``Z``
    (n_j, m, n_c), the first factor's rows times ``mask`` when given; on each joint's non-zero
    columns only when ``compact`` holds them (the others' products are 0)."""
    if compact is None:
        Z1 = Z[:, a] if mask is None else Z[:, a] * mask[None, :, None]
        return Z1.transpose(0, 2, 1) @ Z[:, b]  # batched BLAS
    n_c = Z.shape[2]
    out = np.zeros((Z.shape[0], n_c, n_c))
    for j, (Zc, c) in enumerate(zip(compact, cols)):
        Z1 = Zc[a] if mask is None else Zc[a] * mask[:, None]
        out[j][np.ix_(c, c)] = Z1.T @ Zc[b]
    return out


# --------------------------------------------------------------------------------------------
# Evaluation for a solution
# --------------------------------------------------------------------------------------------
# A solver describes, for every (record factors f, joint j), how the record's columns map to its
# unknowns: T (n_c, c + 1), whose last column is the fixed one (TLS: the payload column with
# coefficient 1; WLS: Y with coefficient -1), and z (c + 1,) the solution with the fixed entry,
# so that the residual of a row x is x·T·z (N, unweighted) and its regressor row is x·T[:, :c].
LayoutFn = Callable[[object, int], np.ndarray]


@lru_cache(maxsize=8)
def _fir_gain_table(n_d: int) -> tuple[np.ndarray, np.ndarray]:
    """Gain H of the decimation FIR against frequency (cycles per tick), 0..0.5."""
    from orthoglide_ident.identify.observe.decimation import fir_taps

    h = fir_taps(n_d)
    tl = np.arange(h.shape[0]) - (h.shape[0] - 1) / 2.0
    f = np.linspace(0.0, 0.5, 4001)
    return f, np.cos(2.0 * np.pi * np.outer(f, tl)) @ h


def fir_gain(freq_hz: np.ndarray, n_d: int, tick_s: float | None) -> np.ndarray:
    """Gain of the zero-phase decimation FIR (n_d) at ``freq_hz`` for ticks of ``tick_s``."""
    if n_d <= 1 or tick_s is None:
        return np.ones_like(np.asarray(freq_hz, float))
    f, H = _fir_gain_table(n_d)
    return np.interp(np.asarray(freq_hz) * tick_s, f, H, right=0.0)


def fir_white_autocorrelation(n_d: int, lags: int = LAGS) -> np.ndarray:
    """Autocorrelation at lags 1..``lags`` of white noise after the FIR decimation by ``n_d``."""
    if n_d <= 1:
        return np.zeros(lags)
    from orthoglide_ident.identify.observe.decimation import fir_taps

    h = fir_taps(n_d)
    out = np.zeros(lags)
    for L in range(1, lags + 1):
        s = L * n_d
        out[L - 1] = float(h[:-s] @ h[s:]) / float(h @ h) if s < h.shape[0] else 0.0
    return out


@dataclass
class Uncertainty:
    """Covariances of a solve's unknowns and what the residual looks like (per joint)."""

    cov: np.ndarray  # honest: per unknown the largest of the three variances (correlations of
    #                  the stationary estimate)
    cov_paper: np.ndarray
    var_stationary: np.ndarray
    var_block: np.ndarray
    n_blocks: int
    block_s: float
    autocorrelation: np.ndarray  # (n_j, LAGS + 1), lag 0 = 1
    rows: np.ndarray  # (n_j,) rows with a residual (kept)
    spectrum: np.ndarray | None = None  # (n_j, 2, n_λ) amplitude (N) vs wavelength (1, sign q̇)
    spectrum_floor: np.ndarray | None = None  # (n_j, 2, n_λ) N, what a white residual would give
    notes: list[str] = field(default_factory=list)
    # (n_j,) rms residual of the rows at reversals of each joint's current / of its other rows
    # (nan: fewer than REVERSAL_MIN_ROWS of either)
    reversal_ratio: np.ndarray | None = None


@dataclass
class _Folded:
    """Sums over records and joints of what ``evaluate`` needs, for one solution z."""

    n_j: int  # actuated joints
    scores: dict = field(default_factory=dict)  # (record, block) → block score s_b
    score_rows: dict = field(default_factory=dict)  # (record, block) → rows in it
    lag_terms: list = field(default_factory=list)  # (j, L, Tcᵀ C_L Tc)
    spec: np.ndarray | None = None  # (n_j, 2, n_λ) complex
    spec_s0: np.ndarray | None = None
    have_moments: bool = False
    block_s: float = BLOCK_S

    def __post_init__(self) -> None:
        self.ac_num = np.zeros((self.n_j, LAGS + 1))  # Σ ρ_k ρ_(k+L)
        self.pairs = np.zeros((self.n_j, LAGS + 1))
        self.ss = np.zeros(self.n_j)  # Σ ρ² per joint
        self.rows = np.zeros(self.n_j)
        # Σ ρ² and rows over the blocks (every kept row) and over the rows at current reversals
        self.block_ss, self.block_n = np.zeros(self.n_j), np.zeros(self.n_j)
        self.rev_ss, self.rev_n = np.zeros(self.n_j), np.zeros(self.n_j)

    def add(self, rec: int, mom: ResidualMoments, j: int, v: np.ndarray, Tc: np.ndarray,
            w2j: float) -> None:
        """Fold joint j of one record's moments; ``v``: residual of a record row x is x·v."""
        self.have_moments = True
        self.block_s = max(self.block_s, mom.block_s)
        for key, P in mom.blocks.items():
            Pv = P[j] @ v
            self.block_ss[j] += float(v @ Pv)
            self.block_n[j] += float(mom.block_rows[key][j])
            s = Tc.T @ Pv * w2j
            k = (rec, key)
            self.scores[k] = self.scores[k] + s if k in self.scores else s
            self.score_rows[k] = self.score_rows.get(k, 0.0) + float(mom.block_rows[key][j])
        for L in range(1, LAGS + 1):
            if mom.pairs[j, L] == 0:
                continue
            C = mom.lagged[j, L - 1]
            self.ac_num[j, L] += float(v @ C @ v)
            self.pairs[j, L] += mom.pairs[j, L]
            self.lag_terms.append((j, L, Tc.T @ C @ Tc))
        if mom.reversal is not None and mom.reversal_rows[j]:
            self.rev_ss[j] += float(v @ mom.reversal[j] @ v)
            self.rev_n[j] += float(mom.reversal_rows[j])
        if mom.spectrum_rows[j]:
            if self.spec is None:
                self.spec = np.zeros((self.n_j, 2, WAVELENGTHS_M.shape[0]), dtype=complex)
                self.spec_s0 = np.zeros((self.n_j, 2, WAVELENGTHS_M.shape[0]))
            self.spec[j] += mom.spectrum[j] @ v
            self.spec_s0[j] += mom.ripple_s0[j]


def _fold(factors: list, layout: LayoutFn, z: np.ndarray, w2: np.ndarray, c: int) -> _Folded:
    acc = _Folded(len(factors[0].R))
    for fi, f in enumerate(factors):
        moments = f.moments
        for j in range(acc.n_j):
            T = layout(f, j)
            v = T @ z
            Rv = f.R[j] @ v
            acc.ss[j] += float(Rv @ Rv)
            acc.rows[j] += float(f.rows[j])
            for mi, mom in enumerate(moments.values()):
                acc.add(fi * 1000 + mi, mom, j, v, T[:, :c], w2[j])
    return acc


def _autocovariance(acc: _Folded, n_rows: int, c: int) -> np.ndarray:
    """γ_j(L), N², L = 0..LAGS; lag 0 from the R factors (all kept rows, dof-corrected)."""
    p = max(n_rows, 1)
    gamma = np.zeros((acc.n_j, LAGS + 1))
    gamma[:, 0] = acc.ss / np.maximum(acc.rows - c * acc.rows / p, 1.0)
    gamma[:, 1:] = np.where(acc.pairs[:, 1:] > 0,
                            acc.ac_num[:, 1:] / np.maximum(acc.pairs[:, 1:], 1), 0.0)
    return gamma


def _block_variance(acc: _Folded, G_inv: np.ndarray, n_rows: int) -> np.ndarray:
    """Diagonal of the block sandwich (CR1 small-sample factor)."""
    c = G_inv.shape[0]
    n_b = len(acc.scores)
    # centred: TLS's estimating equation is Aᵀρ = s_c² x (not 0 as for LS), shared by rows
    S = np.array(list(acc.scores.values()))
    share = np.array([acc.score_rows[k] for k in acc.scores])
    S = S - np.outer(share / max(share.sum(), 1.0), S.sum(axis=0))
    p = max(n_rows, 1)
    corr = n_b / (n_b - 1.0) * (p - 1.0) / max(p - c, 1.0)
    return np.diag(corr * (G_inv @ (S.T @ S) @ G_inv)).copy()


def _position_spectrum(acc: _Folded, gamma0: np.ndarray, autocorrelation: np.ndarray
                       ) -> tuple[np.ndarray, np.ndarray]:
    """Amplitude (N) of a sinusoid of wavelength λ as it is before the decimation filter (least
    squares on the weights w), and a white residual's level times what the rows' correlation adds
    (the weights vary slowly from row to row): 1 + 2 Σ_L autocorrelation(L)."""
    s0 = np.maximum(acc.spec_s0, 1e-12)
    amplitude = 2.0 * np.abs(acc.spec) / s0
    corr = np.maximum(1.0 + 2.0 * autocorrelation[:, 1:].sum(axis=1), 1.0)
    floor = 2.0 * np.sqrt((np.maximum(gamma0, 0.0) * corr)[:, None, None] / s0)
    return amplitude, floor


def evaluate(factors: Iterable, layout: LayoutFn, z: np.ndarray, joint_sigma: np.ndarray,
             G_inv: np.ndarray, cov_paper: np.ndarray, n_rows: int) -> Uncertainty:
    """The three covariances and the residual statistics of one solution (see module doc).

    ``layout(f, j)``: T of record factors f, joint j; ``z``: solution with its fixed entry;
    ``joint_sigma``: row weights 1/σ_j of the solve; ``G_inv``: (c × c) inverse of the weighted
    normal matrix the solver used for eq. (39) (cov_paper = σ² G_inv); ``n_rows``: equations.
    """
    c = G_inv.shape[0]
    w2 = 1.0 / np.asarray(joint_sigma, float) ** 2
    acc = _fold(list(factors), layout, z, w2, c)
    var_paper = np.diag(cov_paper).copy()
    out = Uncertainty(cov=cov_paper.copy(), cov_paper=cov_paper, var_stationary=var_paper.copy(),
                      var_block=np.zeros(c), n_blocks=0, block_s=acc.block_s,
                      autocorrelation=np.zeros((acc.n_j, LAGS + 1)), rows=acc.rows.copy())
    out.autocorrelation[:, 0] = 1.0
    if not acc.have_moments:
        out.notes.append("no row instants: σ by eqs. (38)-(39) only")
        return out
    gamma = _autocovariance(acc, n_rows, c)
    with np.errstate(invalid="ignore", divide="ignore"):
        out.autocorrelation[:, 1:] = np.where(gamma[:, :1] > 0, gamma[:, 1:] / gamma[:, :1], 0.0)
    # stationary sandwich: σ_ρ² G (the white part, as eq. 39) + the lagged terms (Bartlett)
    M = np.zeros((c, c))
    for j, L, S in acc.lag_terms:
        M += (1.0 - L / (LAGS + 1.0)) * gamma[j, L] * w2[j] * (S + S.T)
    cov_stat = cov_paper + G_inv @ M @ G_inv
    out.var_stationary = np.diag(cov_stat).copy()
    out.n_blocks = len(acc.scores)
    if out.n_blocks >= MIN_BLOCKS:
        out.var_block = _block_variance(acc, G_inv, n_rows)
    else:
        out.notes.append(f"only {out.n_blocks} blocks of {acc.block_s:g} s: the block estimate "
                         "is left out (record longer for a σ that covers correlated residuals)")
    # honest: per parameter the largest variance, with the stationary estimate's correlations
    var = np.maximum(np.maximum(var_paper, out.var_stationary), out.var_block)
    d = np.sqrt(np.maximum(out.var_stationary, 1e-300))
    out.cov = (cov_stat / np.outer(d, d)) * np.outer(np.sqrt(var), np.sqrt(var))
    if acc.spec is not None:
        out.spectrum, out.spectrum_floor = _position_spectrum(acc, gamma[:, 0], out.autocorrelation)
    out.reversal_ratio = _reversal_ratio(acc)
    return out


def _reversal_ratio(acc: _Folded) -> np.ndarray:
    """(n_j,) rms residual of the rows at current reversals over that of the other rows."""
    other_n = acc.block_n - acc.rev_n
    other_ss = acc.block_ss - acc.rev_ss
    enough = (acc.rev_n >= REVERSAL_MIN_ROWS) & (other_n >= REVERSAL_MIN_ROWS) & (other_ss > 0)
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = np.sqrt((acc.rev_ss / acc.rev_n) / (other_ss / other_n))
    return np.where(enough, ratio, np.nan)


# --------------------------------------------------------------------------------------------
# What the residual says, in words
# --------------------------------------------------------------------------------------------
# A residual is said far from white when its slow part, the long-run variance factor
# 1 + 2 Σ_L ρ_L over lags 1..LAGS (what the stationary sandwich multiplies eq. (39)'s variance
# by), is this many times white current noise's after the decimation FIR. One-sided: a residual
# with less slow content than white noise (the encoders' quantisation through q̈, blue, the
# clean simulated UR5: 0.2-0.3x) leaves eq. (39) conservative, and its short-lag shape depends on
# the mix of noises, not on what the model lacks. Calibrated: the clean UR5 0.2-0.3x, the
# synthetic plant (model = plant, white current noise) 1.2-1.3x, point-sampled currents 1.6x;
# a 0.1 mrad backlash 3.3x on the joint it biases (bench/unmodelled_effects.py).
SLOW_WARN = 2.0
INFLATION_WARN = 2.0  # honest σ of a gain / eq. (39)'s beyond which the residual is said to matter
PEAK_RATIO = 4.0  # a position-spectrum peak this far above the spectrum's median ...
PEAK_FLOOR = 5.0  # ... and this far above a white residual's level (P < 1e-10 each) is reported
# rms residual at current reversals / elsewhere beyond which it is said (the UR5: 1.0-1.4
# without a backlash, with Stribeck, elasticity or a current loop; 2.4-3.8 with one)
REVERSAL_WARN = 2.0
REVERSAL_MIN_ROWS = 30  # rows at reversals (and elsewhere) for that ratio to mean something


def spectrum_peaks(unc: Uncertainty, joint_names: tuple[str, ...],
                   screws: Sequence[bool] | None = None) -> list[SpectrumPeak]:
    """The strongest position-periodic component of each joint's residual, when it stands out.

    ``screws``: per joint, whether to look (a prismatic joint's ball screw; the wavelengths are
    in m); default every joint."""
    if unc.spectrum is None:
        return []
    out = []
    for j, name in enumerate(joint_names):
        if screws is not None and not screws[j]:
            continue
        best = None
        for kind in (1, 0):  # sign-modulated first: a friction ripple also shows in the plain one
            a = unc.spectrum[j, kind]
            i = int(np.argmax(a))
            med = float(np.median(a))
            if a[i] > PEAK_RATIO * med and a[i] > PEAK_FLOOR * float(
                unc.spectrum_floor[j, kind, i]
            ):
                if best is None or a[i] > 1.5 * best.amplitude_n:
                    best = SpectrumPeak(name, float(WAVELENGTHS_M[i]), float(a[i]), med, kind == 1)
        if best is not None:
            out.append(best)
    return out


def ripple_warning_start(joint: str) -> str:
    """How diagnose's warning of a position-spectrum peak of ``joint`` begins (solve.py
    replaces or completes it once the ripple is modelled)."""
    return f"the residual of {joint} varies with its position"


def slow_ratio(ac: np.ndarray, white: np.ndarray) -> np.ndarray:
    """(n_j,) long-run variance factor 1 + 2 Σ ρ_L of each joint's residual (``ac``: (n_j,
    LAGS) at lags 1..LAGS) over that of white noise after the decimation FIR (``white``)."""
    return (1.0 + 2.0 * ac.sum(axis=1)) / (1.0 + 2.0 * float(white.sum()))


def _slow_warning(joint: str, ratio: float, ac: np.ndarray, white: np.ndarray,
                  reversal: float | None) -> str:
    """What a residual with slow content says, and its likely cause: at current reversals
    (backlash), else a force of the motion the IDIM has no term for."""
    cause = ("it is largest where the current reverses: a backlash (lost motion) or a friction "
             "at torque reversals" if reversal is not None and reversal > REVERSAL_WARN else
             "a friction unlike fv q̇ + fs sign(q̇) (Stribeck), a joint's elasticity or a "
             "current-loop lag")
    return (f"the residual of {joint} is far from white: its slow part (1 + 2 Σ autocorrelation "
            f"over lags 1-{ac.shape[0]}) is {ratio:.1f}x that of white current noise after the "
            f"decimation filter (autocorrelation {ac[0]:.2f} at lag 1, white {white[0]:.2f}); "
            f"forces the model lacks are in it, likely {cause} (the reported σ covers them)")


def diagnose(unc: Uncertainty, decimation: int, n_params: int, joint_names: tuple[str, ...],
             values: np.ndarray | None = None, gain_index: slice | None = None,
             screws: Sequence[bool] | None = None) -> tuple[ResidualDiagnostics, list[str]]:
    """``diagnostics["uncertainty"]`` of a result, and the warnings the residual calls for.

    ``values``: the solution's unknowns (for the relative inflation of the gains at
    ``gain_index``); ``screws``: the joints whose position spectrum is looked at
    (:func:`spectrum_peaks`).
    """
    white = fir_white_autocorrelation(decimation)
    ac = unc.autocorrelation[:, 1:]
    var_paper = np.diag(unc.cov_paper)
    inflation = np.sqrt(
        np.maximum(np.diag(unc.cov), 0.0) / np.where(var_paper > 0, var_paper, np.inf)
    )
    slow = slow_ratio(ac, white)
    warnings = [_slow_warning(n, slow[j], ac[j], white, None if unc.reversal_ratio is None
                              else unc.reversal_ratio[j])
                for j, n in enumerate(joint_names)
                if unc.rows[j] > 0 and unc.n_blocks and slow[j] > SLOW_WARN]
    g_inflation = None
    if gain_index is not None:
        g_inf = inflation[gain_index]
        g_inflation = {n: float(x) for n, x in zip(joint_names, g_inf)}
        worst = int(np.argmax(g_inf))
        if unc.n_blocks and g_inf[worst] > INFLATION_WARN:
            warnings.append(
                f"the σ of the drive gains is up to {g_inf[worst]:.1f}x that of eqs. (38)-(39) "
                f"({joint_names[worst]}): the residual is correlated with the regressors over "
                f"{unc.block_s:g} s blocks — forces the IDIM lacks (friction near velocity "
                "reversals, current-loop lag, ripple); the reported σ includes them")
    warnings += _reversal_warnings(unc, joint_names)
    peaks = spectrum_peaks(unc, joint_names, screws)
    for p in peaks:
        what = (
            "a friction ripple (it turns with the velocity), e.g. of the ball screw at its lead"
            if p.sign_modulated
            else "a position-dependent force, e.g. a cogging or screw ripple"
        )
        warnings.append(
            f"{ripple_warning_start(p.joint)} with a {1e3 * p.wavelength_m:.1f} mm period "
            f"(±{p.amplitude_n:.2g} N, "
            f"{p.amplitude_n / max(p.median_n, 1e-12):.0f}x the spectrum's median): {what} "
            "that the IDIM does not model"
        )
    return ResidualDiagnostics(
        method="largest of eqs. (38)-(39), a stationary-correlation sandwich (lags 1.."
               f"{LAGS} rows) and a block sandwich (blocks of {unc.block_s:g} s)",
        blocks=unc.n_blocks, block_s=unc.block_s, lags=LAGS,
        autocorrelation={n: [float(x) for x in ac[j]] for j, n in enumerate(joint_names)},
        autocorrelation_white=tuple(float(x) for x in white), notes=tuple(unc.notes),
        slow_ratio={n: float(x) for n, x in zip(joint_names, slow)},
        gain_sigma_inflation=g_inflation,
        reversal_residual_ratio=None if unc.reversal_ratio is None else {
            n: None if np.isnan(x) else float(x) for n, x in zip(joint_names, unc.reversal_ratio)},
        position_spectrum_peaks=tuple(peaks)), warnings


def _reversal_warnings(unc: Uncertainty, joint_names: tuple[str, ...]) -> list[str]:
    """A residual concentrated where a joint's current reverses (``reversal_residual_ratio``:
    rms there / elsewhere): what crosses a backlash then, or a friction that changes there, is
    not in the IDIM, and the block sandwich does not see an error that recurs with the motion."""
    if unc.reversal_ratio is None:
        return []
    return [f"the residual of {n} is {r:.1f}x larger where its current reverses than elsewhere: "
            "a backlash (lost motion) or a friction at torque reversals that the IDIM does not "
            "model; the σ of the drive gains may not cover the error it causes"
            for n, r in zip(joint_names, unc.reversal_ratio) if r > REVERSAL_WARN]
