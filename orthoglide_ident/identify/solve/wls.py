"""IDIM-LS / IDIM-WLS with given drive gains (paper eqs. 24-28 and Sect. 3.3).

Y = g_τ·v_τ (N) is computed with the given gains. The payload mass of loaded records is
**unknown** here: each distinct tagged payload gets its own column W_kl (eq. 29 with m_7 in
χ_ul), which is how the paper re-identifies its 1.136 kg payload to validate the gains. Rows of
joint j are weighted by 1/σ_j from an ordinary LS pass (eq. 28); σ of the estimates by eqs. 26-27.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from orthoglide_ident.errors import ExcitationError, IdentificationError
from orthoglide_ident.identify.observe.equations import Observations
from orthoglide_ident.identify.solve.factors import RecordFactors, as_factors
from orthoglide_ident.identify.solve.uncertainty import Uncertainty, evaluate


@dataclass
class WLSSolution:
    """``chi (n,)`` active base parameters, ``payload_masses (k,)`` kg, one per payload group."""

    active: np.ndarray
    chi: np.ndarray
    payload_masses: np.ndarray
    payload_groups: list[float]  # tagged mass of each group, kg
    cov: np.ndarray  # over [chi, payload_masses]: honest (uncertainty.py)
    std: np.ndarray
    rel_std: np.ndarray
    joint_sigma: np.ndarray
    residual_rms: np.ndarray  # (n_j,) N or N·m
    condition_number: float
    n_rows: int
    n_cols: int
    cov_paper: np.ndarray | None = None  # eq. (27)
    rel_std_paper: np.ndarray | None = None
    uncertainty: Uncertainty | None = None
    rows_per_joint: np.ndarray | None = None  # (n_j,) equations

    def chi_full(self) -> np.ndarray:
        out = np.zeros(self.active.shape[0])
        out[self.active] = self.chi
        return out


def payload_groups(blocks: list[Observations | RecordFactors]) -> list[float]:
    """Distinct tagged payload masses of the loaded records (one unknown m_7 per group)."""
    groups: list[float] = []
    for b in blocks:
        if b.loaded and not any(abs(b.payload_mass - m) < 1e-9 for m in groups):
            groups.append(b.payload_mass)
    return groups


def wls_columns(b: RecordFactors, g_j: float, groups: list[float], estimate_payload: bool,
                cols: np.ndarray) -> np.ndarray:
    """T with [W | W_kl | v_τ]·T = [A_j | Y_j] (eq. 28) for record b: (n_b + 2, len(cols) + 1)."""
    n_b = b.n_b
    T = np.zeros((n_b + 2, n_b + len(groups) + 1))
    T[np.arange(n_b), np.arange(n_b)] = 1.0
    T[n_b + 1, -1] = g_j  # Y = g_τ v_τ
    if b.loaded:
        if estimate_payload:
            k = next(i for i, m in enumerate(groups) if abs(b.payload_mass - m) < 1e-9)
            T[n_b, n_b + k] = 1.0
        else:
            T[n_b, -1] = -b.payload_mass
    return T[:, np.concatenate([cols, [T.shape[1] - 1]])]


def _joint_r(blocks: list[RecordFactors], j: int, g_j: float, groups: list[float],
             estimate_payload: bool, cols: np.ndarray) -> tuple[np.ndarray, int]:
    """R of [A_j | Y_j] for joint j's rows (eq. 28), from each record's R of [W | W_kl | v_τ]."""
    Rs, rows = [], 0
    for b in blocks:
        rows += int(b.rows[j])
        Rs.append(b.joint_r(j, wls_columns(b, g_j, groups, estimate_payload, cols)))
    return np.linalg.qr(np.vstack(Rs), mode="r"), rows


def _solve_r(R: np.ndarray, c: int) -> tuple[np.ndarray, np.ndarray]:
    """LS solution (eq. 24) from the R factor of [A | Y]; raises on rank deficiency."""
    R11 = R[:c, :c]
    d = np.abs(np.diag(R11))
    if d.size == 0 or d.min() <= 1e-13 * d.max():
        raise ExcitationError(
            "the observation matrix is rank deficient: some base parameter (or the payload mass) "
            "has no effect on the recorded forces; record more exciting trajectories, with an "
            "unloaded bag next to the loaded ones"
        )
    return np.linalg.solve(R11, R[:c, c]), R11


def _joint_ss(Rj: list[np.ndarray], x: np.ndarray) -> np.ndarray:
    """‖Y_j - A_j x‖² per joint from the R factors of [A_j | Y_j]."""
    xe = np.concatenate([x, [-1.0]])
    return np.array([float(np.sum((R @ xe) ** 2)) for R in Rj])


def _weighted_ls(Rj: list[np.ndarray], nrows: list[int], c: int, weighting: bool,
                 row_scale: np.ndarray | None = None
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Ordinary LS (eq. 24), then the rows of joint j weighted by 1/σ_j (eq. 28) and solved again:
    the first pass's stacked R factor, x, the weighted triangular R11 and σ_j. ``row_scale``:
    the first pass's row weights (None: 1; joint_units.py)."""
    r = int(sum(nrows))
    first = np.ones(len(Rj)) if row_scale is None else np.asarray(row_scale, float)
    R0 = np.linalg.qr(np.vstack([R * w for R, w in zip(Rj, first)]), mode="r")
    x, _ = _solve_r(R0, c)
    sig = 1.0 / first
    if not weighting:
        return R0, x, _solve_r(R0, c)[1], sig
    ss = _joint_ss(Rj, x)
    for j in range(len(Rj)):
        sig[j] = np.sqrt(ss[j] / max(nrows[j] - c * nrows[j] / r, 1.0))  # eq. (28)
    sig[sig <= 0] = 1.0
    x, R11 = _solve_r(np.linalg.qr(np.vstack([R / s for R, s in zip(Rj, sig)]), mode="r"), c)
    return R0, x, R11, sig


def idim_wls(blocks: list[Observations | RecordFactors], g_tau: np.ndarray,
             active: np.ndarray | None = None,
             estimate_payload: bool = True, weighting: bool = True,
             row_scale: np.ndarray | None = None) -> WLSSolution:
    """IDIM-WLS (eqs. 24-28) with the given drive gains ``g_tau (n_j,)`` N/A or N·m/A; the
    first pass's rows weighted by ``row_scale`` (None: 1, the paper's; joint_units.py).

    Works on one R factor of [A_j | Y_j] per joint: weighting scales them, residual norms per
    joint are ‖R_j [x; -1]‖, and no (r × c) matrix of all records is ever formed.
    """
    g_tau = np.asarray(g_tau, dtype=float)
    blocks = as_factors(blocks)
    n_b = blocks[0].n_b
    n_j = blocks[0].n_joints
    if active is None:
        active = np.ones(n_b, dtype=bool)
    active = np.asarray(active, dtype=bool)
    if estimate_payload and any(b.loaded for b in blocks) and all(b.loaded for b in blocks):
        raise IdentificationError(
            "estimating the payload mass needs an unloaded bag too: with the payload always on, "
            "its mass cannot be told apart from the mass of the link that carries it"
        )
    groups = payload_groups(blocks) if estimate_payload else []
    cols = np.concatenate([np.flatnonzero(active), n_b + np.arange(len(groups))])
    c = cols.shape[0]
    Rj, nrows = [], []
    for j in range(n_j):
        R, rows = _joint_r(blocks, j, g_tau[j], groups, estimate_payload, cols)
        Rj.append(R)
        nrows.append(rows)
    r = int(sum(nrows))
    if r <= c:
        raise IdentificationError(f"only {r} equations for {c} unknowns: record longer")

    R0, x, R11, sig = _weighted_ls(Rj, nrows, c, weighting, row_scale)
    ss = _joint_ss(Rj, x)
    sigma_rho2 = float(np.sum(ss / sig**2)) / (r - c)  # eq. (26), weighted rows
    Rinv = np.linalg.inv(R11)
    G_inv = Rinv @ Rinv.T
    cov_paper = sigma_rho2 * G_inv  # eq. (27)
    unc = evaluate(blocks, lambda b, j: wls_columns(b, g_tau[j], groups, estimate_payload, cols),
                   np.concatenate([x, [-1.0]]), sig, G_inv, cov_paper, r)
    cov = unc.cov
    std = np.sqrt(np.diag(cov))
    std_paper = np.sqrt(np.diag(cov_paper))
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = np.where(x != 0, std / np.abs(x), np.inf)
        rel_paper = np.where(x != 0, std_paper / np.abs(x), np.inf)
    rms = np.sqrt(ss / np.maximum(np.array(nrows), 1))
    n = int(active.sum())
    Aw = R0[:c, :n]  # same column norms and singular values as the stacked W
    norms = np.linalg.norm(Aw, axis=0)
    sv = np.linalg.svd(Aw / np.where(norms > 0, norms, 1.0), compute_uv=False)
    return WLSSolution(
        active=active.copy(), chi=x[:n], payload_masses=x[n:], payload_groups=groups, cov=cov,
        std=std, rel_std=rel, joint_sigma=sig, residual_rms=rms,
        condition_number=float(sv[0] / sv[-1]) if sv[-1] > 0 else np.inf, n_rows=r, n_cols=c,
        cov_paper=cov_paper, rel_std_paper=rel_paper, uncertainty=unc,
        rows_per_joint=np.asarray(nrows),
    )
