"""Base parameters of any robot from its standard regressor on random states (paper Sect. 3.1).

The columns of W_st are ordered (eq. 23 for symmetric legs; bodies from the base outwards for a
serial robot, so the wrist's parameters are the ones regrouped) and factored by QR (eq. 22): a
column whose |R_kk| is below ``QR_EPS`` max|R_jj| depends on the columns before it and is
regrouped into them, W_D = W_B β, so every kept parameter carries the expression
χ_b = χ_B + Σ β χ_D. The threshold and the coefficient cleaning are the closed form's
(model/base.py). Pivoted QR (column pivoting, rank-revealing) on the same matrix gives the
numerical rank independently; the two must agree, or the states do not excite the model
clearly enough to tell which columns depend on which.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np
import scipy.linalg

from orthoglide_ident.errors import ModelError
from orthoglide_ident.model.base import COEF_TOL, QR_EPS, BaseParameter


@dataclass(frozen=True)
class BaseSet:
    """The base parameters of a standard regressor: kept columns, K (χ_b = K χ_st), expressions."""

    columns: tuple[int, ...]  # kept standard columns, in the QR order
    K: np.ndarray  # (n_b, n_st)
    parameters: tuple[BaseParameter, ...]
    rank_gap: float  # smallest kept |R_kk| over the largest dropped one (inf: none dropped)


def pivoted_rank(W: np.ndarray, eps: float = QR_EPS) -> int:
    """Numerical rank by QR with column pivoting: |R_kk| > eps max|R_jj|."""
    R = scipy.linalg.qr(W, mode="r", pivoting=True)[0]
    d = np.abs(np.diag(R))
    return int(np.sum(d > eps * d[0])) if d.size and d[0] > 0 else 0


def base_parameters(W_st: np.ndarray, names: Sequence[str], order: Sequence[int]) -> BaseSet:
    """Base parameters of ``W_st`` (rows, n_st) with standard ``names``, columns taken in
    ``order`` (every index once)."""
    order = list(order)
    W_r = W_st[:, order]
    R = np.linalg.qr(W_r, mode="r")  # eq. (22)
    d = np.abs(np.diag(R))
    keep = d > QR_EPS * d.max()
    kept = [order[j] for j in np.flatnonzero(keep)]
    dropped = [order[j] for j in np.flatnonzero(~keep)]
    rank = pivoted_rank(W_r)
    if rank != len(kept):
        raise ModelError(f"the base parameters are ambiguous: QR in the column order keeps "
                         f"{len(kept)} columns but the regressor's rank is {rank}; excite the "
                         "model on more or wider random states")
    beta = np.linalg.lstsq(W_r[:, keep], W_r[:, ~keep], rcond=None)[0]  # W_D = W_B β
    beta[np.abs(beta) < COEF_TOL] = 0.0
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
