"""Do the records agree on their drive chain? One model, each record's currents scaled per joint.

Every record of one robot obeys the same dynamics: g_τ v_τ = W χ (+ W_kl m_7, eq. 33) with the
same χ and gains. A record whose currents are in another unit, through another gain or from the
other side of a transmission (a motor-side record beside joint-side ones) obeys it only up to a
factor per joint. The factors are found by alternating least squares: χ from all records with
each record's currents divided by its factors, then each factor s_rj = ⟨y, p⟩ / ⟨p, p⟩ on
that record's rows of that joint; relative to the first record's. A factor off by more than
``SCALE_TOLERANCE`` is said (issue 43: a motor-side record beside a joint-side one was told
"the loaded records do not excite the payload mass").
"""
from __future__ import annotations

import numpy as np

from orthoglide_ident.identify.observe.equations import Observations

SCALE_TOLERANCE = 0.15  # of a factor: the same robot's records agree within a few %
ITERATIONS = 6
MIN_SHARE = 0.05  # of a joint's rows: a record that hardly moves it is not judged there


def _rows(b: Observations, j: int) -> np.ndarray:
    return np.ones(b.n_samples, bool) if b.keep is None else np.asarray(b.keep[j], bool)


def current_scales(blocks: list[Observations], g_tau: np.ndarray) -> np.ndarray:
    """(n_records, n_j) factor of each record's currents per joint against the first record's,
    NaN where a record holds too few rows of a joint. Each loaded record's payload mass is an
    unknown too (a payload tagged wrong is the payload checks' to say, not a drive chain).
    Normal equations, one block at a time: no matrix of all records' rows is formed."""
    g = np.asarray(g_tau, float)
    n_r, n_j = len(blocks), blocks[0].v_tau.shape[0]
    s = np.ones((n_r, n_j))
    w2 = np.zeros(n_j)  # each joint's rows weighted by 1 / its mean square torque (0: none)
    for j in range(n_j):
        y = np.concatenate([g[j] * b.v_tau[j][_rows(b, j)] for b in blocks])
        ms = float(np.mean(y ** 2)) if y.size else 0.0
        w2[j] = 1.0 / ms if np.isfinite(ms) and ms > 0 else 0.0
    for _ in range(ITERATIONS):
        x = _solve(blocks, g, s, w2)
        for r, b in enumerate(blocks):
            for j in range(n_j):
                k = _rows(b, j)
                p = _columns(blocks, r, j, k) @ x
                pp = float(p @ p)
                s[r, j] = float(g[j] * b.v_tau[j][k] @ p) / pp if pp > 0 else np.nan
    few = np.array([[_rows(b, j).sum() < MIN_SHARE * b.n_samples for j in range(n_j)]
                    for b in blocks])
    s = np.where(few, np.nan, s)
    return s / s[0]


def _columns(blocks: list[Observations], r: int, j: int, k: np.ndarray) -> np.ndarray:
    """Record r's rows ``k`` of joint j over [χ, one payload mass per loaded record]."""
    loaded = [i for i, b in enumerate(blocks) if b.loaded]
    b = blocks[r]
    X = np.zeros((int(k.sum()), b.W.shape[2] + len(loaded)))
    X[:, :b.W.shape[2]] = b.W[j][k]
    if b.loaded:
        X[:, b.W.shape[2] + loaded.index(r)] = b.w_m[j][k]
    return X


def _solve(blocks: list[Observations], g: np.ndarray, s: np.ndarray,
           w2: np.ndarray) -> np.ndarray:
    """[χ, payload masses] from every record, its currents divided by its factors ``s``."""
    AtA, Atb = 0.0, 0.0
    for r, b in enumerate(blocks):
        for j in range(len(g)):
            k = _rows(b, j)
            X = _columns(blocks, r, j, k)
            AtA = AtA + w2[j] * (X.T @ X)
            Atb = Atb + w2[j] * (X.T @ (g[j] * b.v_tau[j][k] / s[r, j]))
    return np.linalg.lstsq(AtA, Atb, rcond=None)[0]


def disagreement(blocks: list[Observations], g_tau: np.ndarray, joints: list[str]) -> str:
    """One line naming the records and joints whose currents disagree with the first record's
    by more than ``SCALE_TOLERANCE`` for the same dynamics; "" when they agree."""
    if len(blocks) < 2:
        return ""
    try:
        s = current_scales(blocks, g_tau)
    except np.linalg.LinAlgError:  # no usable rows (a robot held still): nothing to compare
        return ""
    parts = []
    for r, b in enumerate(blocks[1:], start=1):
        off = [f"{joints[j]} ×{s[r, j]:.3g}" for j in range(s.shape[1])
               if np.isfinite(s[r, j]) and abs(s[r, j] - 1.0) > SCALE_TOLERANCE]
        if off:
            parts.append(f"{b.source}'s ({', '.join(off)})")
    if not parts:
        return ""
    return (f"the records disagree on their drive chain: for the same dynamics the currents of "
            f"{'; '.join(parts)} are off {blocks[0].source}'s beyond "
            f"{100 * SCALE_TOLERANCE:g} % (another current unit or gain, a torque logged as a "
            "current, or motor-side signals beside joint-side ones: check the bags' tags)")
