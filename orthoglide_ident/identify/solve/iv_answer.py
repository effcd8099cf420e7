"""IDIM-IV as a method of the table (``--method iv``) and as TLS's cross-check.

``solve_iv`` starts from the TLS answer with each current column scaled to its joint's noise
(``tls_noisy_columns: per-joint``, the start least biased by the current noise), iterates IDIM-IV
(iv.py) and reports it as a TLS answer is reported: the gains, the base parameters, the payload
mass that fixed the scale. ``cross_check`` runs the same IV from a TLS answer and, for each gain
further from IV's than CROSS_CHECK_SIGMAS combined σ, warns and marks the TLS gain not determined
(the paper's TLS is biased when the joints' current noise differs, issue 43): its σ would not be
an honest error bar.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from orthoglide_ident.errors import ExcitationError, IdentificationError
from orthoglide_ident.identify.options import IdentifyOptions
from orthoglide_ident.identify.solve import drive_fit
from orthoglide_ident.identify.solve.answer import Solved, limits, tls_model, tls_result
from orthoglide_ident.identify.solve.factors import RecordFactors
from orthoglide_ident.identify.solve.iv import (
    CROSS_CHECK_SIGMAS,
    IVSolution,
    disagreement,
    idim_iv,
    observations_of,
)
from orthoglide_ident.identify.solve.tls import (
    TLSSolution,
    check_gains,
    require_loaded_and_unloaded,
)
from orthoglide_ident.results import SolverInfo

log = logging.getLogger("orthoglide_ident.identify")
IV_START = "tls per-joint"  # where IV starts from: the per-joint TLS answer (solve_iv)


@dataclass(frozen=True)
class CrossCheck:
    """One joint's gain by TLS and by IV, and how far apart in combined σ (the JSON's
    ``diagnostics.cross_check_iv``, keyed by the two methods)."""

    joint: str
    tls: float
    iv: float
    iv_rel_std: float
    sigmas: float

    def to_json(self) -> dict:
        return {"joint": self.joint, "tls": self.tls, "iv": self.iv,
                "iv_rel_std": self.iv_rel_std, "sigmas": self.sigmas}


def _as_tls(iv: IVSolution, start: TLSSolution) -> TLSSolution:
    """The IV answer in a TLSSolution's fields (what the result and the checks read)."""
    n = iv.chi.shape[0]
    cov = iv.cov
    std = iv.std
    x = np.concatenate([iv.chi, iv.g_tau])
    with np.errstate(divide="ignore", invalid="ignore"):
        rel_white = np.where(x != 0, np.sqrt(np.abs(np.diag(iv.cov_white))) / np.abs(x), np.inf)
    return TLSSolution(
        active=np.ones(n, bool), chi=iv.chi, g_tau=iv.g_tau, cov=cov, std=std,
        rel_std=iv.rel_std, sigma_w=float("nan"), singular_values=start.singular_values,
        joint_sigma=iv.joint_sigma, residual_rms=iv.residual_rms,
        condition_number=start.condition_number, n_rows=iv.n_rows, n_cols=x.shape[0] + 1,
        lambda_scale=1.0, cov_paper=iv.cov_white, rel_std_paper=rel_white, uncertainty=None,
        rows_per_joint=iv.rows_per_joint)


def iv_from(factors: list[RecordFactors], chi0: np.ndarray, g0: np.ndarray) -> IVSolution:
    """IDIM-IV on the rows behind ``factors`` from the start (χ0 over their columns, g0)."""
    g0 = np.asarray(g0, float)
    if not np.all(np.isfinite(g0)) or np.any(g0 == 0):
        raise ExcitationError("IDIM-IV has no start: the TLS answer has no drive gains")
    return idim_iv(observations_of(factors), chi0, g0)


def solve_iv(factors: list[RecordFactors], model, cols, opts: IdentifyOptions, gains,
             essential: bool, bags: list[str]) -> Solved:
    """IDIM-IV (iv.py) from the per-joint TLS answer; the gains' σ and signs checked as TLS's."""
    require_loaded_and_unloaded(factors, "IDIM-IV")
    observations_of(factors)  # refused before the TLS start when the rows are not kept
    start_opts = opts.replace(tls_noisy_columns="per-joint")
    _, base = tls_model(factors, model, cols, start_opts)
    log.info("IDIM-IV from the per-joint TLS answer on %d equations",
             sum(f.n_rows for f in factors))
    iv = iv_from(factors, base.chi_full(), base.g_tau)
    sol = _as_tls(iv, base)
    terms = cols.terms
    n_b = sol.chi.shape[0] - terms.n_extra
    view, _, lags = drive_fit.split(sol, n_b, terms, model.joint_names) if terms else \
        (sol, [], [])
    if opts.solve.check_excitation:
        band_warnings = check_gains(view, limits(model, opts), model.joint_names)
    result = tls_result(model, cols, view, factors, opts, bags)
    if opts.solve.check_excitation:
        result.warnings.extend(band_warnings)
    result.current_lag = list(lags)
    if essential:
        result.warnings.append("--essential is not run with IDIM-IV: use --method tls for the "
                               "essential parameters")
    solver = SolverInfo(iv_iterations=iv.iterations, iv_start=IV_START,
                        joint_sigma=tuple(float(x) for x in iv.joint_sigma))
    return Solved(result, sol.chi.copy(), view.g_tau, solver, None, factors=factors,
                  chi_rows=sol.chi.copy())


def cross_check(out: Solved, factors: list[RecordFactors], model, mark: bool = True) -> None:
    """IDIM-IV from a complete TLS answer ``out``; gains that disagree beyond
    CROSS_CHECK_SIGMAS combined σ are warned about and, when ``mark`` (the excitation checks
    on), marked not determined (in place). Nothing when the rows were not kept (live) or IV
    cannot run: a cross-check, not a method."""
    result = out.result
    try:
        iv = iv_from(factors, out.chi, out.g_tau)
    except (IdentificationError, np.linalg.LinAlgError) as exc:
        log.info("IV cross-check not run: %s", exc)
        return
    g_tls = np.array([g.value for g in result.drive_gains])
    rel_tls = np.array([g.rel_std for g in result.drive_gains])
    z = disagreement(g_tls, rel_tls, iv)
    iv_rel = iv.rel_std[-g_tls.shape[0]:]
    result.cross_check = [CrossCheck(g.name, float(g.value), float(v), float(r), float(k))
                          for g, v, r, k in zip(result.drive_gains, iv.g_tau, iv_rel, z)]
    bad = [j for j in range(g_tls.shape[0]) if z[j] > CROSS_CHECK_SIGMAS]
    texts = []
    for j in bad:
        g = result.drive_gains[j]
        reason = (f"IDIM-TLS {g.value:.5g} and IDIM-IV {iv.g_tau[j]:.5g} (±{100 * iv_rel[j]:.2g}"
                  f" %) disagree by {z[j]:.1f} combined σ: the joints' current noise differs, "
                  "which biases the paper's TLS (use --method iv, or tls_noisy_columns: "
                  "per-joint), or the model lacks a force of the records")
        if mark:
            g.determined, g.value, g.rel_std, g.reason = False, float("nan"), float("nan"), \
                reason
        texts.append(f"{g.name} {'not determined' if mark else 'doubtful'}: {reason}")
    if bad:
        result.warnings.insert(0, "TLS cross-checked by IV: " + "; ".join(texts))
