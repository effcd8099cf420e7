"""From decimated equations (per-joint R factors) to an :class:`IdentificationResult` (§6.5-7).

Shared by the offline pipeline (one :class:`~factors.RecordFactors` per bag) and the live
identification (one per payload condition, folded while recording): IDIM-TLS with the gains
identified and the scale from the known payload mass (eqs. 33-39), or IDIM-WLS with given gains
and the payload masses estimated (eqs. 24-28), each optionally reduced to essential parameters
(Sect. 5.2).
"""
from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np

from orthoglide_ident.errors import ExcitationError, IdentificationError
from orthoglide_ident.identify.essential import EssentialResult, essential_parameters
from orthoglide_ident.identify.factors import RecordFactors
from orthoglide_ident.identify.options import IdentifyOptions
from orthoglide_ident.identify.segments import JOINT_NAMES
from orthoglide_ident.identify.tls import (TLSProblem, TLSSolution, check_excitation,
                                           require_loaded_and_unloaded)
from orthoglide_ident.identify.wls import WLSSolution, idim_wls
from orthoglide_ident.results import Estimate, IdentificationResult, PayloadMass

log = logging.getLogger("orthoglide_ident.identify")

G_TAU_MANUFACTURER = 637.0 * np.pi  # N/A, eq. (17), the paper's 2001


@dataclass
class Solved:
    """A result and what cross-validation and diagnostics need from the solve."""

    result: IdentificationResult
    chi: np.ndarray  # (n_b,) base parameters, zero where cancelled
    g_tau: np.ndarray  # (3,) N/A, identified (TLS) or given (WLS)
    solver: dict[str, Any] = field(default_factory=dict)
    tls: TLSSolution | None = None
    timings: dict[str, float] = field(default_factory=dict)  # s: "essential" when asked


def min_rows(n_b: int) -> int:
    """Fewest equations per joint worth solving: max(50, 2 n_b)."""
    return max(50, 2 * n_b)


def check_rows(factors: list[RecordFactors], opts: IdentifyOptions) -> None:
    """ExcitationError when a joint has too few equations left (below the dead band)."""
    n_b = factors[0].n_b
    for j, name in enumerate(JOINT_NAMES):
        rows = sum(int(f.rows[j]) for f in factors)
        total = sum(f.n_samples for f in factors)
        if rows < min_rows(n_b):
            raise ExcitationError(
                f"{name} moves slower than the velocity dead band "
                f"({opts.velocity_deadband_mps} m/s)"
                f" almost all the time: {rows} of {total} equations left; the trajectories are "
                "not exciting (or lower velocity_deadband_mps)")


def _gains_estimates(g: np.ndarray, rel: np.ndarray | None) -> list[Estimate]:
    return [Estimate(j, float(g[i]), float(rel[i]) if rel is not None else 0.0)
            for i, j in enumerate(JOINT_NAMES)]


def _param_estimates(model, sol: TLSSolution | WLSSolution) -> list[Estimate]:
    idx = np.flatnonzero(sol.active)
    exprs = list(getattr(model, "expressions", [""] * len(model.names)))
    return [Estimate(str(model.names[k]), float(sol.chi[i]), float(sol.rel_std[i]),
                     str(exprs[k]) if k < len(exprs) else "")
            for i, k in enumerate(idx)]


def _sources(factors: list[RecordFactors], mass: float) -> list[str]:
    return [s for f in factors if f.loaded and abs(f.payload_mass - mass) < 1e-9
            for s in f.sources]


def tls_result(model, sol: TLSSolution, factors: list[RecordFactors], opts: IdentifyOptions,
               bags: list[str]) -> IdentificationResult:
    """The result of an IDIM-TLS solve (payload masses known)."""
    n = sol.chi.shape[0]
    payloads = [PayloadMass(m, opts.payload_mass_std_kg / m, True, m, _sources(factors, m))
                for m in sorted({f.payload_mass for f in factors if f.loaded})]
    return IdentificationResult(
        method="tls", joint_names=list(JOINT_NAMES),
        drive_gains=_gains_estimates(sol.g_tau, sol.rel_std[n:n + 3]), drive_gains_given=False,
        parameters=_param_estimates(model, sol), payload_mass=payloads[0] if payloads else None,
        payloads=payloads, condition_number=sol.condition_number,
        residual_rms=[float(x) for x in sol.residual_rms], bags=bags,
    )


def wls_result(model, sol: WLSSolution, g_tau: np.ndarray, factors: list[RecordFactors],
               bags: list[str]) -> IdentificationResult:
    """The result of an IDIM-WLS solve (gains given, payload masses estimated)."""
    n = sol.chi.shape[0]
    payloads = [PayloadMass(float(sol.payload_masses[k]), float(sol.rel_std[n + k]), False, m_tag,
                            _sources(factors, m_tag))
                for k, m_tag in enumerate(sol.payload_groups)]
    return IdentificationResult(
        method="wls", joint_names=list(JOINT_NAMES), drive_gains=_gains_estimates(g_tau, None),
        drive_gains_given=True, parameters=_param_estimates(model, sol),
        payload_mass=payloads[0] if payloads else None, payloads=payloads,
        condition_number=sol.condition_number, residual_rms=[float(x) for x in sol.residual_rms],
        bags=bags,
    )


def solve_tls(factors: list[RecordFactors], model, opts: IdentifyOptions, essential: bool,
              bags: list[str]) -> Solved:
    """IDIM-TLS (eqs. 33-39), excitation checked, optionally the essential parameters."""
    require_loaded_and_unloaded(factors, "IDIM-TLS")
    log.info("IDIM-TLS on %d equations × %d unknowns", sum(f.n_rows for f in factors),
             factors[0].n_b + 4)
    problem = TLSProblem(factors, opts.weighting, noisy_columns=opts.tls_noisy_columns)
    sol = problem.solve()
    if opts.check_excitation:
        check_excitation(sol, opts.limits(), list(model.names))
    result = tls_result(model, sol, factors, opts, bags)
    solver = {"tls_noisy_columns": opts.tls_noisy_columns, "singular_ratio": sol.singular_ratio,
              "smallest_singular_values": [float(x) for x in sol.singular_values[-3:]],
              "joint_sigma": [float(x) for x in sol.joint_sigma], "lambda": sol.lambda_scale}
    out = Solved(result, sol.chi_full(), sol.g_tau, solver, sol)
    if essential:
        t0 = time.perf_counter()
        log.info("essential parameters (r_sigma = %g)", opts.r_sigma)
        ess = essential_parameters(lambda act: problem.solve(act, reweight=False), problem.n_b,
                                   opts.r_sigma, start=sol)
        result.essential = tls_result(model, ess.solution, factors, opts, bags)
        _note_essential(model, result, ess)
        out.timings["essential"] = time.perf_counter() - t0
    return out


def manufacturer_or_given(gains: Sequence[float] | None) -> np.ndarray:
    """Drive gains for WLS: the given ones (N/A) or the manufacturer's 637π."""
    g = np.full(3, G_TAU_MANUFACTURER) if gains is None else np.asarray(gains, dtype=float)
    if g.shape != (3,) or not np.all(np.isfinite(g)) or np.any(g <= 0):
        raise IdentificationError(
            f"drive gains must be three positive numbers in N/A, not {gains}")
    if gains is None:
        log.info("IDIM-WLS with the manufacturer's drive gains 637π = %.1f N/A "
                 "(give --gains to use identified ones)", G_TAU_MANUFACTURER)
    return g


def solve_wls(factors: list[RecordFactors], model, opts: IdentifyOptions,
              gains: Sequence[float] | None, essential: bool, bags: list[str]) -> Solved:
    """IDIM-WLS (eqs. 24-28) with given gains, payload masses estimated."""
    g = manufacturer_or_given(gains)
    log.info("IDIM-WLS on %d equations", sum(f.n_rows for f in factors))
    wsol = idim_wls(factors, g, weighting=opts.weighting)
    result = wls_result(model, wsol, g, factors, bags)
    out = Solved(result, wsol.chi_full(), g, {"joint_sigma": [float(x) for x in wsol.joint_sigma]})
    if essential:
        t0 = time.perf_counter()
        ess = essential_parameters(
            lambda act: idim_wls(factors, g, active=act, weighting=opts.weighting),
            len(model.names), opts.r_sigma, start=wsol)
        result.essential = wls_result(model, ess.solution, g, factors, bags)
        _note_essential(model, result, ess)
        out.timings["essential"] = time.perf_counter() - t0
    return out


def _note_essential(model, result: IdentificationResult, ess: EssentialResult) -> None:
    assert result.essential is not None
    result.essential.removed = [str(model.names[k]) for k in ess.removed]
    result.essential.diagnostics = {"stopped_because": ess.stopped_because,
                                    "ratios": [float(x) for x in ess.ratios]}
    result.removed = list(result.essential.removed)


def solve(factors: list[RecordFactors], model, opts: IdentifyOptions, method: str = "tls",
          gains: Sequence[float] | None = None, essential: bool = False,
          bags: Sequence[str] = ()) -> Solved:
    """IDIM-TLS or IDIM-WLS on the factors; raises the product's errors with a reason."""
    if method not in ("tls", "wls"):
        raise IdentificationError(f"unknown method {method!r}: use tls or wls")
    if not factors:
        raise IdentificationError("no bag given")
    check_rows(factors, opts)
    if method == "tls":
        return solve_tls(factors, model, opts, essential, list(bags))
    return solve_wls(factors, model, opts, gains, essential, list(bags))
