"""Essential parameters by the iterative procedure of Sect. 5.2.

Starting from all base parameters, the one with the largest relative standard deviation is
cancelled and the model identified again, until max(%σ)/min(%σ) < r_σ (the paper uses 10).
The %σ of the drive gains (TLS) take part in the ratio but the gains are never cancelled.
The reduction can cost accuracy on the gains (DESIGN §6): report base and essential side by side.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Union

import numpy as np

from orthoglide_ident.errors import OrthoglideError
from orthoglide_ident.identify.tls import TLSSolution
from orthoglide_ident.identify.wls import WLSSolution

Solution = Union[TLSSolution, WLSSolution]


@dataclass
class EssentialResult:
    """Final solution on the essential set, and the base parameters cancelled, in order."""

    solution: Solution
    removed: list[int] = field(default_factory=list)  # base-parameter indices, in removal order
    ratios: list[float] = field(default_factory=list)  # max/min %σ at each step
    stopped_because: str = ""


def _ratio(sol: Solution) -> tuple[float, int]:
    """max/min relative std over parameters and gains/payload; index (in chi) of the worst param."""
    rel = np.abs(sol.rel_std)
    n = sol.chi.shape[0]
    finite = np.where(np.isfinite(rel), rel, np.inf)
    worst = int(np.argmax(finite[:n])) if n else -1
    lo = float(np.min(finite)) if finite.size else np.inf
    hi = float(np.max(finite))
    return (hi / lo if lo > 0 else np.inf), worst


def essential_parameters(
    solve: Callable[[np.ndarray], Solution], n_b: int, r_sigma: float = 10.0,
    start: Solution | None = None, min_parameters: int = 1,
) -> EssentialResult:
    """Iterate ``solve(active)`` cancelling the worst-%σ base parameter until the ratio < r_σ."""
    active = np.ones(n_b, dtype=bool)
    sol = start if start is not None else solve(active)
    res = EssentialResult(solution=sol)
    while True:
        ratio, worst = _ratio(sol)
        res.ratios.append(ratio)
        if ratio < r_sigma:
            res.stopped_because = f"max %σ / min %σ = {ratio:.2f} < r_σ = {r_sigma:g}"
            break
        if int(active.sum()) <= min_parameters or worst < 0:
            res.stopped_because = f"only {int(active.sum())} parameters left"
            break
        idx = int(np.flatnonzero(active)[worst])
        trial = active.copy()
        trial[idx] = False
        try:
            new = solve(trial)
        except OrthoglideError as exc:
            res.stopped_because = f"cancelling base parameter #{idx} failed: {exc}"
            break
        active = trial
        res.removed.append(idx)
        sol = new
    res.solution = sol
    return res
