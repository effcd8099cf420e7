"""Essential parameters: the base parameters worth keeping in a simplified model (Sect. 5.2).

Two procedures, both iterating ``solve(active)`` from all base parameters and cancelling one base
parameter at a time (never a drive gain or a payload mass):

- ``"paper"``: the paper's rule. The parameter with the largest relative standard deviation (of
  eqs. 38-39) is cancelled and the model identified again, until max(%σ)/min(%σ) < r_σ (the paper
  uses 10; the gains' and payload's %σ take part in the ratio). On the Orthoglide this rule can
  cancel parameters the gains lean on: 13 parameters kept moved two gains by 3-6 %
  (docs/design/method.md).
- ``"keep_gains"`` (the default): the same order (largest honest %σ first) and the same stopping
  ratio, but a cancellation is accepted only if the protected quantities — the drive gains (TLS)
  or the estimated payload masses (WLS) — stay within their tolerance of the base model's values
  (the larger of their honest σ and ``min_tolerance``, 0.3 %) and the weighted residual norm
  grows by at most ``max_residual_increase``. A parameter whose cancellation would break that is
  kept, and the next one is tried; every trial is recorded with its cost.

Every step says what cancelling the parameter cost: the change of the weighted residual norm
and of each joint's residual rms, and the shift of the gains (or payload masses) from the base
model, cumulative (:class:`EssentialStep`).
"""
from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from orthoglide_ident.errors import OrthoglideError
from orthoglide_ident.identify.solve.tls import TLSSolution
from orthoglide_ident.identify.solve.wls import WLSSolution
from orthoglide_ident.results import EssentialStep

Solution = TLSSolution | WLSSolution
METHODS = ("keep_gains", "paper")


@dataclass
class EssentialResult:
    """Final solution on the essential set, and the base parameters cancelled, in order."""

    solution: Solution
    removed: list[int] = field(default_factory=list)  # base-parameter indices, in removal order
    ratios: list[float] = field(default_factory=list)  # max/min %σ at each step
    stopped_because: str = ""
    steps: list[EssentialStep] = field(default_factory=list)
    method: str = "keep_gains"
    tolerance: list[float] = field(default_factory=list)  # of the protected quantities, fraction


def protected(sol: Solution) -> np.ndarray:
    """What the reduction must not move: the gains (TLS) or the estimated payload masses (WLS)."""
    return np.asarray(sol.g_tau if isinstance(sol, TLSSolution) else sol.payload_masses, float)


def protected_rel_std(sol: Solution) -> np.ndarray:
    n = sol.chi.shape[0]
    k = protected(sol).shape[0]
    return np.abs(np.asarray(sol.rel_std[n:n + k], float))


def _weighted_ss(sol: Solution, sigma: np.ndarray) -> float:
    """Σ_j ‖ρ_j‖² / σ_j² with the base model's row weights ``sigma``. Not the trial's own σ_j:
    WLS estimates them again from each trial's residual (eq. 26), so a joint whose residual
    grows 100-fold gets a 100-fold σ_j and its weighted residual would not move at all."""
    return float(np.sum(np.asarray(sol.residual_rms) ** 2 * _rows(sol) / sigma ** 2))


def _rows(sol: Solution) -> np.ndarray:
    rows = sol.rows_per_joint
    return np.ones(len(sol.joint_sigma)) if rows is None else np.asarray(rows, float)


def _ratio(sol: Solution, paper: bool, fixed: np.ndarray) -> tuple[float, np.ndarray]:
    """max/min relative std over parameters and gains/payload (the ``fixed`` parameters, indexed
    like ``sol.chi``, left out); the other parameters by decreasing %σ."""
    rel = sol.rel_std_paper if paper and sol.rel_std_paper is not None else sol.rel_std
    rel = np.abs(np.asarray(rel, float))
    n = sol.chi.shape[0]
    finite = np.where(np.isfinite(rel), rel, np.inf)
    use = np.ones(finite.shape[0], bool)
    use[:n] = ~fixed
    order = [int(i) for i in np.argsort(-finite[:n], kind="stable") if not fixed[i]]
    lo = float(np.min(finite[use])) if use.any() else np.inf
    hi = float(np.max(finite[use])) if use.any() else np.inf
    return (hi / lo if lo > 0 else np.inf), np.asarray(order, dtype=int)


@dataclass
class _Budget:
    """What a cancellation may cost (keep_gains): the base solution's protected quantities, their
    tolerance and weighted residual."""

    p0: np.ndarray
    tol: np.ndarray
    sigma0: np.ndarray  # (n_j,) the base model's σ_j: every trial's residual weighted by them
    ss0: float
    names: list[str]
    max_residual_increase: float
    enforce: bool  # keep_gains refuses a step beyond the budget; the paper's rule only reports it


def _judge(new: Solution, idx: int, name: str, rel: float, budget: _Budget) -> EssentialStep:
    """The step of cancelling parameter ``idx`` giving ``new``; refused (when the budget is
    enforced) if it moves a protected quantity beyond its tolerance or raises the residual."""
    shift = protected(new) / budget.p0 - 1.0
    ss0 = budget.ss0
    dres = float(np.sqrt(_weighted_ss(new, budget.sigma0) / ss0) - 1.0) if ss0 > 0 else 0.0
    step = EssentialStep(idx, name, rel, True, dres, [float(x) for x in new.residual_rms],
                         [float(x) for x in shift])
    if not budget.enforce:
        return step
    # nothing protected (WLS on unloaded records: no payload mass estimated): the residual only
    worst = int(np.argmax(np.abs(shift) / budget.tol)) if shift.size else -1
    if worst >= 0 and abs(shift[worst]) > budget.tol[worst]:
        step.accepted = False
        step.reason = (f"kept: cancelling it would move {budget.names[worst]} by "
                       f"{100 * shift[worst]:+.2f} % (tolerance {100 * budget.tol[worst]:.2f} %)")
    elif dres > budget.max_residual_increase:
        step.accepted = False
        step.reason = (f"kept: cancelling it would raise the residual by {100 * dres:.1f} % "
                       f"(> {100 * budget.max_residual_increase:g} %)")
    return step


def _cancel_one(solve: Callable[[np.ndarray], Solution], sol: Solution, active: np.ndarray,
                order: np.ndarray, rel: np.ndarray, names: list[str], budget: _Budget,
                rejected: set[int], res: EssentialResult) -> tuple[Solution | None, str]:
    """Cancel the first parameter of ``order`` (indices among the active ones) that the rule
    accepts: the new solution (``active`` updated), or None and why the last trial failed."""
    idx_active = np.flatnonzero(active)
    for i in order:
        idx = int(idx_active[i])
        if idx in rejected:
            continue
        trial = active.copy()
        trial[idx] = False
        try:
            new = solve(trial)
        except OrthoglideError as exc:
            if not budget.enforce:  # the paper's rule stops at the first failure
                return None, f"cancelling {names[idx]} failed: {exc}"
            rejected.add(idx)
            res.steps.append(EssentialStep(idx, names[idx], float(abs(rel[i])), False, np.nan,
                                           [], [], "kept: the model without it is not "
                                           f"identifiable ({exc})"))
            continue
        step = _judge(new, idx, names[idx], float(abs(rel[i])), budget)
        res.steps.append(step)
        if not step.accepted:
            rejected.add(idx)
            continue
        step.reason = "cancelled"
        active[idx] = False
        res.removed.append(idx)
        return new, ""
    return None, ""


def essential_parameters(
    solve: Callable[[np.ndarray], Solution], n_b: int, r_sigma: float = 10.0,
    start: Solution | None = None, min_parameters: int = 1, method: str = "keep_gains",
    names: Sequence[str] | None = None, min_tolerance: float = 0.003,
    max_residual_increase: float = 0.05, protected_names: Sequence[str] | None = None,
    fixed: np.ndarray | None = None,
) -> EssentialResult:
    """Cancel base parameters by ``method`` (module doc) from ``start`` (or ``solve(all)``).

    ``names``: of the base parameters; ``protected_names``: of the gains / payload masses (for
    the steps' reasons); ``fixed`` (n_b,) bool: parameters never cancelled nor counted in the
    ratio (e.g. identified ripple terms).
    """
    if method not in METHODS:
        raise ValueError(f"essential method must be one of {', '.join(METHODS)}, not {method!r}")
    names = list(names) if names is not None else [f"#{k}" for k in range(n_b)]
    active = np.ones(n_b, dtype=bool)
    base = start if start is not None else solve(active)
    paper = method == "paper"
    p0 = protected(base)
    tol = np.maximum(protected_rel_std(base), min_tolerance)
    pnames = list(protected_names) if protected_names is not None else [
        f"#{k + 1}" for k in range(p0.shape[0])]
    sigma0 = np.asarray(base.joint_sigma, float)
    budget = _Budget(p0, tol, sigma0, _weighted_ss(base, sigma0), pnames, max_residual_increase,
                     not paper)
    res = EssentialResult(solution=base, method=method, tolerance=[float(x) for x in tol])
    rejected: set[int] = set()
    fixed = np.zeros(n_b, bool) if fixed is None else np.asarray(fixed, bool)
    sol = base
    while True:
        ratio, order = _ratio(sol, paper, fixed[active])
        res.ratios.append(ratio)
        if ratio < r_sigma:
            res.stopped_because = f"max %σ / min %σ = {ratio:.2f} < r_σ = {r_sigma:g}"
            break
        if int((active & ~fixed).sum()) <= min_parameters:
            res.stopped_because = f"only {int(active.sum())} parameters left"
            break
        rel = sol.rel_std_paper if paper and sol.rel_std_paper is not None else sol.rel_std
        new, failed = _cancel_one(solve, sol, active, order, rel, names, budget, rejected, res)
        if new is None:
            moves = f"move {', '.join(pnames)} beyond its tolerance or " if pnames else ""
            res.stopped_because = failed or (
                f"max %σ / min %σ = {ratio:.2f} ≥ r_σ = {r_sigma:g}, but cancelling any further "
                f"parameter would {moves}raise the residual by more than "
                f"{100 * max_residual_increase:g} %")
            break
        sol = new
    res.solution = sol
    return res
