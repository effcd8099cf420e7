"""Base parameters of any robot from its standard regressor on random states (paper Sect. 3.1).

The columns of W_st are ordered (eq. 23 for symmetric legs; bodies from the base outwards for a
serial robot, so the wrist's parameters are the ones regrouped) and factored by QR (eq. 22): a
column whose |R_kk| is below ``QR_EPS`` max|R_jj| depends on the columns before it and is
regrouped into them, W_D = W_B β, so every kept parameter carries the expression
χ_b = χ_B + Σ β χ_D. The threshold, the coefficient cleaning and BaseParameter are every robot's
(the Orthoglide's closed form, model/orthoglide/base.py, uses them too). The singular values of
the same matrix (those of R) give its numerical rank
independently of the column order; the two must agree, or the states do not excite the model
clearly enough to tell which columns depend on which.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from orthoglide_ident.errors import ModelError

QR_EPS = 1e-8  # exact model data: dependent columns sit at ~1e-13 relative
COEF_TOL = 1e-7  # coefficients below this (relative to 1) are numerical noise
ROUNDOFF = 1e-12  # a column this small relative to W_st's largest entry is zero but round-off


def _fmt_coef(c: float) -> str:
    return f"{c:.5g}"


@dataclass(frozen=True)
class BaseParameter:
    """One base parameter: the standard parameter kept and the regrouping it stands for."""

    name: str  # paper style, 'm_11R' when regrouped
    standard: str  # kept standard parameter, e.g. 'm_11'
    # (standard name, coefficient), the kept one first with 1.0
    terms: tuple[tuple[str, float], ...]
    legs: tuple[int, ...]  # legs whose base parameter of this kind has the same form

    @property
    def expression(self) -> str:
        out = self.standard
        for name, c in self.terms[1:]:
            sign = "-" if c < 0 else "+"
            mag = abs(c)
            out += (
                f" {sign} {name}" if abs(mag - 1.0) < 1e-9 else f" {sign} {_fmt_coef(mag)} {name}"
            )
        return out


@dataclass(frozen=True)
class BaseSet:
    """Base parameters of a standard regressor: kept columns, K (χ_b = K χ_st), expressions."""

    columns: tuple[int, ...]  # kept standard columns, in the QR order
    K: np.ndarray  # (n_b, n_st)
    parameters: tuple[BaseParameter, ...]
    rank_gap: float  # smallest kept |R_kk| over the largest dropped one (inf: none dropped)


def svd_rank(R: np.ndarray, eps: float = QR_EPS) -> int:
    """Numerical rank from the singular values (R's are W's): s_k > eps max s."""
    s = np.linalg.svd(R, compute_uv=False)
    return int(np.sum(s > eps * s[0])) if s.size and s[0] > 0 else 0


def base_parameters(W_st: np.ndarray, names: Sequence[str], order: Sequence[int],
                    groups: Sequence[Sequence[int]] | None = None) -> BaseSet:
    """Base parameters of ``W_st`` (rows, n_st) with standard ``names``, columns taken in
    ``order`` (every index once); ``groups``: standard columns of one scale, within which a
    column that is round-off is told (None: all of them)."""
    order = list(order)
    W_r = np.asfortranarray(W_st[:, order])  # LAPACK's layout: no copy inside the QR
    # A structurally zero column (a planar robot's out-of-plane terms) holds round-off only;
    # left in, its Householder reflection (a direction of noise) would decide which later
    # columns look dependent. Exactly zero, it is skipped and dropped.
    W_r[:, _roundoff_columns(W_r, None if groups is None else
                             [[order.index(c) for c in g] for g in groups])] = 0.0
    # Each column scaled to unit norm (W_r = W_s S): the rank of W_st does not depend on the
    # units of its parameters, nor on a transmission's scale (N 1e-12 I scales the links'
    # columns by 1e12 and the motors' by 1e-24: 58 base parameters became 36 unscaled).
    S = np.linalg.norm(W_r, axis=0)
    S[S == 0.0] = 1.0
    W_r /= S
    # eq. (22); numpy's QR (LAPACK's, as scipy's): the 0.15-0.25 s of importing scipy.linalg
    # are then not spent by `identify` of a general robot (R decides the kept columns only)
    R = np.linalg.qr(W_r, mode="r")
    d = np.abs(np.diag(R))
    keep = d > QR_EPS * d.max()
    kept = [order[j] for j in np.flatnonzero(keep)]
    dropped = [order[j] for j in np.flatnonzero(~keep)]
    rank = svd_rank(R[:W_r.shape[1]])
    if rank != len(kept):
        raise ModelError(f"the base parameters are ambiguous: QR in the column order keeps "
                         f"{len(kept)} columns but the regressor's singular values give rank "
                         f"{rank}; excite the model on more or wider random states")
    beta = np.linalg.lstsq(W_r[:, keep], W_r[:, ~keep], rcond=None)[0]  # W_sD = W_sB β_s
    beta[np.abs(beta) < COEF_TOL] = 0.0  # noise relative to the scaled columns
    beta *= S[~keep][None, :] / S[keep][:, None]  # W_D = W_B β: β = S_B⁻¹ β_s S_D
    K = np.zeros((len(kept), W_st.shape[1]))
    K[np.arange(len(kept)), kept] = 1.0
    K[:, dropped] = beta
    params = []
    for b, col in enumerate(kept):
        terms = [(names[col], 1.0)] + [(names[c], float(beta[b, n]))
                                       for n, c in enumerate(dropped) if beta[b, n] != 0.0]
        params.append(BaseParameter(names[col] + ("R" if len(terms) > 1 else ""), names[col],
                                    tuple(terms), ()))
    gap = float(d[keep].min() / max(d[~keep].max(), 1e-300)) if (~keep).any() else np.inf
    return BaseSet(tuple(kept), K, tuple(params), gap)


def _roundoff_columns(W: np.ndarray, groups: Sequence[Sequence[int]] | None) -> np.ndarray:
    """Columns that hold round-off only: below ``ROUNDOFF`` of the largest entry of their group
    (columns of one scale; None: all of W). A group apart keeps a column of small but exact
    numbers (a motor's, behind a 1e-12 reduction) from being taken for round-off."""
    top = np.abs(W).max(axis=0)
    out = np.zeros(top.shape, bool)
    for g in ([range(W.shape[1])] if groups is None else groups):
        g = np.asarray(list(g), int)
        out[g] = top[g] <= ROUNDOFF * top[g].max() if g.size else False
    return out


class NamedByParameters:
    """``names`` and ``expressions`` of a robot model from its ``parameters`` (BaseParameter
    list, in column order): one source for the models that keep such a list."""

    parameters: list[BaseParameter]

    @property
    def names(self) -> list[str]:  # type: ignore[override]
        return [p.name for p in self.parameters]

    @property
    def expressions(self) -> list[str]:  # type: ignore[override]
        return [p.expression for p in self.parameters]
