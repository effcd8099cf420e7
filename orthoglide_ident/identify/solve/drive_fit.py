"""The drive terms in the solve (columns/drive_terms.py defines them): the ripple a first solve's
residual calls for, its columns built from the folded moments, the augmented solve's σ, and the
split of its answer into the base model's view, the ripples and the current-loop lags.

The augmented normal equations are built from the R factors and the position moments folded
with the records (Σ x w e^(-iφ), Σ w², Σ w² e^(-2iφ)), so the augmented solve is the same offline
and live. Its σ are eq. (39)'s, scaled unknown by unknown by the base model's honest / eq. (39)
variance ratio (the block moments hold no ripple columns).
"""
from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from orthoglide_ident.identify.columns.drive_terms import RippleTerm, Terms
from orthoglide_ident.identify.solve.factors import RecordFactors
from orthoglide_ident.identify.solve.uncertainty import WAVELENGTHS_M, Uncertainty, spectrum_peaks
from orthoglide_ident.results import LagEstimate, RippleEstimate


def detect_ripples(unc: Uncertainty | None, joint_names: tuple[str, ...],
                   screws: Sequence[bool] | None = None) -> tuple[RippleTerm, ...]:
    """The ripple terms the residual calls for: one per joint with a position-spectrum peak
    (``screws``: the joints looked at, uncertainty.spectrum_peaks)."""
    if unc is None or unc.spectrum is None:
        return ()
    out = []
    for p in spectrum_peaks(unc, joint_names, screws):
        i = int(np.argmin(np.abs(WAVELENGTHS_M - p.wavelength_m)))
        out.append(RippleTerm(joint_names.index(p.joint), float(WAVELENGTHS_M[i]),
                              p.sign_modulated, i))
    return tuple(out)


def can_model(factors: list[RecordFactors], terms: Terms) -> bool:
    """Every record holds the moments the terms need (rows with instants and positions)."""
    return all(f.moments and all(np.any(m.spectrum_rows) for m in f.moments.values())
               for f in factors)


def _sum(f: RecordFactors, attr: str, index) -> np.ndarray:
    return sum(np.asarray(getattr(mom, attr))[index] for mom in f.moments.values())


def augmented_factors(factors: list[RecordFactors], terms: Terms) -> list[RecordFactors]:
    """The records' factors for the model with the drive terms' columns, in the order
    [W | ripple (2 per term) | W_kl | v_τ]; each column is non-zero in its own joint's rows
    only. Built from the R factors and the folded moments (no rows needed)."""
    n_b = factors[0].n_b
    k = terms.n_extra
    n_new = n_b + k + 2
    old_to_new = np.concatenate([np.arange(n_b), [n_b + k, n_b + k + 1]])
    out = []
    for f in factors:
        R_new = []
        for j in range(f.n_joints):
            G = np.zeros((n_new, n_new))
            G[np.ix_(old_to_new, old_to_new)] = f.R[j].T @ f.R[j]
            ripple = [(i, t) for i, t in enumerate(terms.ripples) if t.joint == j]
            for i, t in ripple:
                kind = 1 if t.friction else 0
                F = _sum(f, "spectrum", (j, kind, t.index))  # Σ x w e^(-iφ)
                s0 = float(_sum(f, "ripple_s0", (j, kind, t.index)))
                s2 = complex(_sum(f, "ripple_s2", (j, kind, t.index)))
                a, b = n_b + 2 * i, n_b + 2 * i + 1
                cross = np.column_stack([F.real, -F.imag])  # Σ x w cos φ, Σ x w sin φ
                G[old_to_new, a:b + 1] = cross
                G[a:b + 1, old_to_new] = cross.T
                G[a, a] = 0.5 * (s0 + s2.real)
                G[b, b] = 0.5 * (s0 - s2.real)
                G[a, b] = G[b, a] = -0.5 * s2.imag
            R_new.append(_upper_factor(G))
        out.append(RecordFactors(f.condition, f.payload_mass, n_b + k, list(f.sources), R_new,
                                 f.rows.copy(), f.n_samples))
    return out


def _upper_factor(G: np.ndarray) -> np.ndarray:
    """Upper-triangular R with RᵀR = G (G symmetric positive semi-definite)."""
    G = 0.5 * (G + G.T)
    scale = max(float(np.max(np.abs(np.diag(G)))), 1e-300)
    try:
        return np.linalg.cholesky(G + 1e-13 * scale * np.eye(G.shape[0])).T
    except np.linalg.LinAlgError:
        w, V = np.linalg.eigh(G)
        return np.linalg.qr((V * np.sqrt(np.clip(w, 0.0, None))).T, mode="r")


def transfer_inflation(sol, base, n_b: int, n_extra: int):
    """``sol`` (augmented: unknowns [active base parameters | drive terms | gains or payload
    masses]) with eq. (39)'s covariance scaled by the base solution's honest / eq. (39) variance
    ratio of the same unknown; the drive terms take the largest ratio of the gains (masses)."""
    n_a = int(np.count_nonzero(sol.active[:n_b]))
    cp = sol.cov_paper
    vp = np.diag(base.cov_paper)
    ratio_base = np.diag(base.cov) / np.where(vp > 0, vp, np.inf)
    pos = {int(k): i for i, k in enumerate(np.flatnonzero(base.active))}
    n_base = base.chi.shape[0]
    ratio = np.ones(cp.shape[0])
    for i, k in enumerate(np.flatnonzero(sol.active[:n_b])):
        ratio[i] = ratio_base[pos[int(k)]] if int(k) in pos else float(np.max(ratio_base))
    ratio[n_a:n_a + n_extra] = float(np.max(ratio_base[n_base:]))
    ratio[n_a + n_extra:] = ratio_base[n_base:]
    d = np.sqrt(np.maximum(ratio, 1.0))
    cov = cp * np.outer(d, d)
    std = np.sqrt(np.abs(np.diag(cov)))
    x = np.concatenate([sol.chi, _rest(sol)])
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = np.where(x != 0, std / np.abs(x), np.inf)
    return dataclasses.replace(sol, cov=cov, std=std, rel_std=rel)


def _rest(sol) -> np.ndarray:
    return np.asarray(sol.g_tau if hasattr(sol, "g_tau") else sol.payload_masses, float)


def split(sol, n_b: int, terms: Terms, joint_names: Sequence[str], gains: np.ndarray | None = None
          ) -> tuple[object, list[RippleEstimate], list[LagEstimate]]:
    """The base-model view of an augmented solution (``active``, χ, covariances over the base
    parameters and the gains / payload masses), its identified ripples and lags (τ = θ / g_τ,
    ``gains`` given to a WLS solve, else the solution's own with their covariance)."""
    k = terms.n_extra
    n_a = int(np.count_nonzero(sol.active[:n_b]))
    keep = np.concatenate([np.arange(n_a), np.arange(n_a + k, sol.cov.shape[0])])
    sub = np.ix_(keep, keep)
    view = dataclasses.replace(
        sol, active=sol.active[:n_b].copy(), chi=sol.chi[:n_a].copy(), cov=sol.cov[sub],
        std=sol.std[keep], rel_std=sol.rel_std[keep],
        cov_paper=None if sol.cov_paper is None else sol.cov_paper[sub],
        rel_std_paper=None if sol.rel_std_paper is None else sol.rel_std_paper[keep])
    lags = _lags(sol, n_a, n_a + k, joint_names, gains) if terms.lag else []
    ripples = []
    r0 = n_a + terms.lag
    for i, t in enumerate(terms.ripples):
        a, b = r0 + 2 * i, r0 + 2 * i + 1
        c, s = float(sol.chi[a]), float(sol.chi[b])
        amp = float(np.hypot(c, s))
        C = sol.cov[np.ix_([a, b], [a, b])]
        u = np.array([c, s]) / amp if amp > 0 else np.array([1.0, 0.0])
        # c cos φ + s sin φ = amp cos(φ + phase)
        ripples.append(RippleEstimate(joint_names[t.joint], t.wavelength_m, t.friction, amp,
                                      float(np.sqrt(max(u @ C @ u, 0.0))),
                                      float(np.arctan2(-s, c))))
    return view, ripples, lags


def _lags(sol, a: int, g0: int, joint_names: Sequence[str], gains: np.ndarray | None
          ) -> list[LagEstimate]:
    """τ_j = θ_j / g_τj of the lag coefficients θ at a.. (gains at g0.. when identified), σ to
    first order."""
    out = []
    for j, name in enumerate(joint_names):
        theta = float(sol.chi[a + j])
        if gains is None:
            g = float(sol.g_tau[j])
            idx = [a + j, g0 + j]
            grad = np.array([1.0 / g, -theta / g ** 2])
        else:
            g = float(gains[j])
            idx = [a + j]
            grad = np.array([1.0 / g])
        C = sol.cov[np.ix_(idx, idx)]
        out.append(LagEstimate(name, theta / g, float(np.sqrt(max(grad @ C @ grad, 0.0)))))
    return out
