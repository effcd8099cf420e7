"""Do the records agree on their drive chain? One model, each record's currents scaled per joint.

Every record of one robot obeys the same dynamics: g_τ v_τ = W χ (+ W_kl m_7, eq. 33) with the
same χ and gains. A record whose currents are in another unit, through another gain or from the
other side of a transmission (a motor-side record beside joint-side ones) obeys it only up to a
factor per joint. The factors are found by alternating least squares: χ from all records with
each record's currents divided by its factors, then each factor s_rj = ⟨y, p⟩ / ⟨p, p⟩ on
that record's rows of that joint; relative to the first record's. A factor off by more than
``SCALE_TOLERANCE`` is said (issue 43: a motor-side record beside a joint-side one was told
"the loaded records do not excite the payload mass").

Everything is computed from each record's Gram matrix per joint of its kept rows [W | W_kl | v_τ]
(Rᵀ R of solve/factors.RecordFactors), so the offline records and the live recordings (which
keep only their R factors) are judged by this one implementation.
"""
from __future__ import annotations

import numpy as np

from orthoglide_ident.identify.solve.factors import RecordFactors

SCALE_TOLERANCE = 0.15  # of a factor: the same robot's records agree within a few %
ITERATIONS = 6
MIN_SHARE = 0.05  # of a joint's rows: a record that hardly moves it is not judged there


def _grams(f: RecordFactors) -> list[np.ndarray]:
    """Per joint, the Gram matrix of the record's kept rows [W (n_b) | W_kl | v_τ]."""
    return [R.T @ R for R in f.R]


def _normal(G: np.ndarray, g: float, n_b: int, col: int | None, n_x: int
            ) -> tuple[np.ndarray, np.ndarray, float]:
    """(XᵀX, Xᵀy, yᵀy) of one record's rows of one joint over [χ, one payload mass per loaded
    record] (its mass in column ``col``, None when unloaded), y = g v_τ."""
    A, b = np.zeros((n_x, n_x)), np.zeros(n_x)
    A[:n_b, :n_b], b[:n_b] = G[:n_b, :n_b], g * G[:n_b, n_b + 1]
    if col is not None:
        A[:n_b, col] = A[col, :n_b] = G[:n_b, n_b]
        A[col, col], b[col] = G[n_b, n_b], g * G[n_b, n_b + 1]
    return A, b, g * g * G[n_b + 1, n_b + 1]


def current_scales(factors: list[RecordFactors], g_tau: np.ndarray) -> np.ndarray:
    """(n_records, n_j) factor of each record's currents per joint against the first record's,
    NaN where a record holds too few rows of a joint. Each loaded record's payload mass is an
    unknown too (a payload tagged wrong is the payload checks' to say, not a drive chain)."""
    g = np.asarray(g_tau, float)
    n_r, n_j, n_b = len(factors), factors[0].n_joints, factors[0].n_b
    loaded = [i for i, f in enumerate(factors) if f.loaded]
    n_x = n_b + len(loaded)
    cols = [n_b + loaded.index(r) if r in loaded else None for r in range(n_r)]
    eq = [[_normal(G, g[j], n_b, cols[r], n_x) for j, G in enumerate(_grams(f))]
          for r, f in enumerate(factors)]
    w2 = np.zeros(n_j)  # each joint's rows weighted by 1 / its mean square torque (0: none)
    for j in range(n_j):
        n = sum(int(f.rows[j]) for f in factors)
        ms = sum(e[j][2] for e in eq) / n if n else 0.0
        w2[j] = 1.0 / ms if np.isfinite(ms) and ms > 0 else 0.0
    s = np.ones((n_r, n_j))
    for _ in range(ITERATIONS):
        AtA = sum(w2[j] * eq[r][j][0] for r in range(n_r) for j in range(n_j))
        Atb = sum(w2[j] * eq[r][j][1] / s[r, j] for r in range(n_r) for j in range(n_j))
        x = np.linalg.lstsq(AtA, Atb, rcond=None)[0]
        for r in range(n_r):
            for j in range(n_j):
                A, b, _ = eq[r][j]
                pp = float(x @ A @ x)  # ⟨p, p⟩ with p = X x
                s[r, j] = float(b @ x) / pp if pp > 0 else np.nan
    few = np.array([[f.rows[j] < MIN_SHARE * f.n_samples for j in range(n_j)] for f in factors])
    s = np.where(few, np.nan, s)
    return s / s[0]


def disagreement(factors: list[RecordFactors], g_tau: np.ndarray, joints: list[str]) -> str:
    """One line naming the records and joints whose currents disagree with the first record's
    by more than ``SCALE_TOLERANCE`` for the same dynamics; "" when they agree."""
    if len(factors) < 2:
        return ""
    try:
        s = current_scales(factors, g_tau)
    except np.linalg.LinAlgError:  # no usable rows (a robot held still): nothing to compare
        return ""
    parts = []
    for r, f in enumerate(factors[1:], start=1):
        off = [f"{joints[j]} ×{s[r, j]:.3g}" for j in range(s.shape[1])
               if np.isfinite(s[r, j]) and abs(s[r, j] - 1.0) > SCALE_TOLERANCE]
        if off:
            parts.append(f"{f.source}'s ({', '.join(off)})")
    if not parts:
        return ""
    return (f"the records disagree on their drive chain: for the same dynamics the currents of "
            f"{'; '.join(parts)} are off {factors[0].source}'s beyond "
            f"{100 * SCALE_TOLERANCE:g} % (another current unit or gain, a torque logged as a "
            "current, or motor-side signals beside joint-side ones: check the bags' tags)")
