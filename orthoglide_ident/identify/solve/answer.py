"""From decimated equations (per-joint R factors) to an :class:`IdentificationResult` (§6.5-7).

Shared by the offline pipeline (one :class:`~factors.RecordFactors` per bag) and the live
identification (one per payload condition, folded while recording): IDIM-TLS with the gains
identified and the scale from the known payload mass (eqs. 33-39), or IDIM-WLS with given gains
and the payload masses estimated (eqs. 24-28), each optionally reduced to essential parameters
(Sect. 5.2). Which method runs is methods.py's table (``methods.solve``).
"""
from __future__ import annotations

import dataclasses
import logging
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from orthoglide_ident.errors import ExcitationError, IdentificationError
from orthoglide_ident.identify.columns import drive_terms
from orthoglide_ident.identify.observe import joint_units
from orthoglide_ident.identify.options import IdentifyOptions
from orthoglide_ident.identify.solve import drive_fit, partial
from orthoglide_ident.identify.solve.essential import EssentialResult, essential_parameters
from orthoglide_ident.identify.solve.factors import RecordFactors
from orthoglide_ident.identify.solve.tls import (
    ExcitationLimits,
    TLSProblem,
    TLSSolution,
    check_excitation,
    check_gains,
    check_subspace,
    require_loaded_and_unloaded,
)
from orthoglide_ident.identify.solve.uncertainty import diagnose, ripple_warning_start
from orthoglide_ident.identify.solve.wls import WLSSolution, idim_wls
from orthoglide_ident.results import (
    EssentialReduction,
    Estimate,
    IdentificationResult,
    PayloadMass,
    SolverInfo,
    lag_text,
)

log = logging.getLogger("orthoglide_ident.identify")
UNNAMED = ""  # a result's method until the methods table names it (methods.solve)


@dataclass
class Solved:
    """A result and what cross-validation and diagnostics need from the solve."""

    result: IdentificationResult
    chi: np.ndarray  # (n_b,) base parameters, zero where cancelled; + the drive terms' whose
    # columns the equations hold (columns/layout.py): what cross-validation multiplies
    g_tau: np.ndarray  # (n_j,) N/A or N·m/A, identified (TLS) or given (WLS)
    solver: SolverInfo = field(default_factory=SolverInfo)
    tls: TLSSolution | None = None
    timings: dict[str, float] = field(default_factory=dict)  # s: "essential" when asked
    # the factors of the reported solve and its χ over all their columns (consistency.py)
    factors: list[RecordFactors] = field(default_factory=list)
    chi_rows: np.ndarray | None = None


def limits(model, opts: IdentifyOptions) -> ExcitationLimits:
    """The excitation checks' thresholds for ``model``: a gain band only when its robot file
    gives nominal gains (a bare URDF's 1 per unit is no manufacturer's figure)."""
    return opts.solve.limits(model.nominal_gains, model.nominal_gains_given)


def min_rows(n_b: int) -> int:
    """Fewest equations per joint worth solving: max(50, 2 n_b)."""
    return max(50, 2 * n_b)


def check_length(factors: list[RecordFactors], opts: IdentifyOptions) -> None:
    """ExcitationError when the records are too short: fewer decimated samples than needed,
    whatever the dead band."""
    need = min_rows(factors[0].n_b)
    total = sum(f.n_samples for f in factors)
    if total < need:
        raise ExcitationError(
            f"the records are too short: {total} equations per joint (decimated samples, 1 in "
            f"{opts.observe.decimation}) where {need} are needed (max(50, 2 n_b), n_b = "
            f"{factors[0].n_b}); record longer trajectories")


def check_rows(factors: list[RecordFactors], model, opts: IdentifyOptions) -> None:
    """ExcitationError when a joint has too few equations left: the records are too short
    (check_length), or the joint stays below the velocity dead band (reversals.py) almost all
    the time."""
    check_length(factors, opts)
    need = min_rows(factors[0].n_b)
    total = sum(f.n_samples for f in factors)
    for j, joint in enumerate(model.joints):
        rows = sum(int(f.rows[j]) for f in factors)
        if rows < need:
            raise ExcitationError(
                f"{joint.name} moves slower than the velocity dead band "
                f"({opts.observe.velocity_deadband_mps} {joint.unit}/s)"
                f" almost all the time: {rows} of {total} equations left, {need} needed; the "
                "trajectories are not exciting (or lower velocity_deadband_mps)")


def _gains_estimates(joint_names: Sequence[str], g: np.ndarray, rel: np.ndarray | None,
                     rel_paper: np.ndarray | None = None) -> list[Estimate]:
    return [Estimate(j, float(g[i]), float(rel[i]) if rel is not None else 0.0,
                     rel_std_paper=float(rel_paper[i]) if rel_paper is not None else
                     (None if rel is not None else 0.0))
            for i, j in enumerate(joint_names)]


def _param_estimates(cols, sol: TLSSolution | WLSSolution) -> list[Estimate]:
    """The identified unknowns beside the gains, named by ``cols`` (a ColumnLayout, or a
    partial answer's Subsystem)."""
    idx = np.flatnonzero(sol.active)
    exprs = list(cols.expressions)
    paper = sol.rel_std_paper
    return [Estimate(str(cols.names[k]), float(sol.chi[i]), float(sol.rel_std[i]),
                     str(exprs[k]) if k < len(exprs) else "",
                     float(paper[i]) if paper is not None else None)
            for i, k in enumerate(idx)]


def _uncertainty(result: IdentificationResult, sol: TLSSolution | WLSSolution, model,
                 opts: IdentifyOptions, gains: bool) -> None:
    """The honest σ's diagnostics and the residual's warnings into ``result``."""
    if sol.uncertainty is None:
        return
    n, n_j = sol.chi.shape[0], model.n_joints
    d, warnings = diagnose(sol.uncertainty, opts.observe.decimation, n, model.joint_names,
                           gain_index=slice(n, n + n_j) if gains else None,
                           screws=drive_terms.screw_mask(model))
    result.uncertainty = d
    result.warnings.extend(warnings)


FRICTION_PREFIXES = ("fv_", "fs_")  # viscous and Coulomb friction: never negative (Sect. 2.2)


def friction_sign_warnings(result: IdentificationResult) -> list[str]:
    """A friction coefficient negative beyond 3 σ: the sign of a drive gain is wrong (given, or
    the current recorded opposite to the effort), not a physical answer."""
    out = []
    for p in result.parameters:
        if p.name.startswith(FRICTION_PREFIXES) and p.value < 0 and \
                math.isfinite(p.rel_std) and p.rel_std < 1.0 / 3.0:
            out.append(f"{p.name} = {p.value:.4g} is a negative friction coefficient: the drive "
                       "gain of the joint it belongs to has the wrong sign (a gain given with the "
                       "wrong sign, or the current recorded opposite to the effort: a reversed "
                       "motor or a negative reduction), or that joint's data are not the model's")
    return out


PAYLOAD_TAG_TOLERANCE = 0.10  # WLS payload estimate vs its tag beyond which the answer is doubted


def payload_tag_warnings(result: IdentificationResult, model, gains_given: bool) -> list[str]:
    """A WLS payload estimate far from its weighed tag (beyond 10 % and 3 honest σ): the answer
    does not answer the question; the likely cause is the gains (eq. 28 scales with them)."""
    out = []
    for p in result.payloads:
        if not p.tagged or not math.isfinite(p.value):
            continue
        dev = p.value / p.tagged - 1.0
        if abs(dev) > PAYLOAD_TAG_TOLERANCE and abs(dev) > 3 * abs(p.rel_std * p.value / p.tagged):
            if gains_given:
                cause = ("the gains given are not the robot's (in another unit or side of the "
                         "reduction), or the currents are not in A")
            elif not model.nominal_gains_given:
                cause = ("no gains were given and the robot file has no nominal gains (1 per "
                         "unit stands in): give --gains, e.g. the --json of a TLS identification")
            else:
                cause = ("the robot file's nominal gains are not the drives' (give --gains from a "
                         "TLS identification), or the currents are not in A")
            out.append(f"payload mass estimated {p.value:.4g} kg by WLS, tagged {p.tagged:g} kg "
                       f"({100 * dev:+.0f} %): {cause}")
    return out


def _sources(factors: list[RecordFactors], mass: float) -> list[str]:
    return [s for f in factors if f.loaded and abs(f.payload_mass - mass) < 1e-9
            for s in f.sources]


def tls_result(model, cols, sol: TLSSolution, factors: list[RecordFactors],
               opts: IdentifyOptions, bags: list[str]) -> IdentificationResult:
    """The result of an IDIM-TLS solve (payload masses known): ``model`` the robot, ``cols`` its
    columns (columns/layout.ColumnLayout, or a partial answer's Subsystem, both)."""
    n, n_j = sol.chi.shape[0], model.n_joints
    payloads = [PayloadMass(m, opts.input.payload_mass_std_kg / m, True, m, _sources(factors, m))
                for m in sorted({f.payload_mass for f in factors if f.loaded})]
    return IdentificationResult(
        method=UNNAMED, joint_names=list(model.joint_names),
        drive_gains=_gains_estimates(model.joint_names, sol.g_tau, sol.rel_std[n:n + n_j],
                                     None if sol.rel_std_paper is None
                                     else sol.rel_std_paper[n:n + n_j]),
        drive_gains_given=False,
        parameters=_param_estimates(cols, sol), payload_mass=payloads[0] if payloads else None,
        payloads=payloads, condition_number=sol.condition_number,
        residual_rms=[float(x) for x in sol.residual_rms], bags=bags, **_robot_fields(model),
        covariance=sol.cov, covariance_paper=sol.cov_paper,
    )


def _robot_fields(model) -> dict[str, Any]:
    """The result's robot name and per-joint units (RobotModel)."""
    return {"robot": str(model.name),
            "gain_units": [j.gain_unit for j in model.joints],
            "effort_units": [j.effort_unit for j in model.joints],
            "nominal_gains": [float(j.nominal_gain) for j in model.joints],
            "locked_joints": list(model.locked_joints)}


def wls_result(model, cols, sol: WLSSolution, g_tau: np.ndarray, factors: list[RecordFactors],
               bags: list[str]) -> IdentificationResult:
    """The result of an IDIM-WLS solve (gains given, payload masses estimated)."""
    n = sol.chi.shape[0]
    payloads = [PayloadMass(float(sol.payload_masses[k]), float(sol.rel_std[n + k]), False, m_tag,
                            _sources(factors, m_tag),
                            None if sol.rel_std_paper is None else float(sol.rel_std_paper[n + k]))
                for k, m_tag in enumerate(sol.payload_groups)]
    return IdentificationResult(
        method=UNNAMED, joint_names=list(model.joint_names),
        drive_gains=_gains_estimates(model.joint_names, g_tau, None),
        drive_gains_given=True, parameters=_param_estimates(cols, sol),
        payload_mass=payloads[0] if payloads else None, payloads=payloads,
        condition_number=sol.condition_number, residual_rms=[float(x) for x in sol.residual_rms],
        bags=bags, **_robot_fields(model), covariance=sol.cov,
        covariance_paper=sol.cov_paper,
    )


@dataclass
class _Model:
    """How a solve is set up: the base problem, or the one with the drive terms' columns
    (drive_terms.py: unknowns = the base parameters, then the terms'), and how to read it."""

    solve_active: Any  # active (n_b + n_extra,) bool -> solution
    full: Any  # solution on every column
    n_b: int  # base parameters
    terms: drive_terms.Terms
    names: list[str]
    n_rows_cols: int  # columns of W in the decimated equations (base + the terms in them)
    joint_names: tuple[str, ...]
    gains: np.ndarray | None = None  # given to WLS (None: identified by TLS)
    factors: list[RecordFactors] = field(default_factory=list)  # the equations of ``full``

    @property
    def fixed(self) -> np.ndarray:
        f = np.zeros(self.n_b + self.terms.n_extra, bool)
        f[self.n_b:] = True
        return f

    def view(self, sol) -> tuple[Any, list, list]:
        """Base-model view of a solution, its identified ripples and current-loop lags."""
        if not self.terms:
            return sol, [], []
        return drive_fit.split(sol, self.n_b, self.terms, self.joint_names, self.gains)


def _set_up(factors: list[RecordFactors], model, cols, opts: IdentifyOptions, base, make_solver,
            gains: np.ndarray | None = None) -> _Model:
    """The model to report: the base one with the drive terms already in the equations (the
    layout's: lag, ripple at a given lead), and the ripple columns the base residual's
    position spectrum calls for when no lead is given (built from the moments).

    ``make_solver(factors) -> solve(active, reweight)`` builds a solver on (augmented) factors.
    """
    n_cols = factors[0].n_b
    names = tuple(model.joint_names)
    base_solve = make_solver(factors)
    # the drive terms in the equations: the layout's, or a partial answer's (partial.py)
    in_rows = cols.terms
    n_b = n_cols - in_rows.n_extra
    plain = _Model(lambda act: base_solve(act, False), base, n_b, in_rows, list(cols.names),
                   n_cols, names, gains, factors)
    if in_rows.ripples or opts.solve.ripple_model != "auto":
        return plain
    found = drive_terms.Terms(drive_fit.detect_ripples(base.uncertainty, names,
                                                         drive_terms.screw_mask(model)))
    if not found or not drive_fit.can_model(factors, found):
        return plain
    k = found.n_extra
    log.info("ripple in the residual of %s: two columns each added to the model", ", ".join(
        f"{names[t.joint]} ({1e3 * t.wavelength_m:.1f} mm)" for t in found.ripples))
    aug_factors = drive_fit.augmented_factors(factors, found)
    aug_solve = make_solver(aug_factors)
    full = drive_fit.transfer_inflation(aug_solve(None, None), base, n_cols, k)
    return _Model(lambda act: drive_fit.transfer_inflation(aug_solve(act, False), base, n_cols,
                                                             k),
                  full, n_b, drive_terms.Terms(found.ripples, in_rows.lag),
                  list(cols.names) + found.names(names), n_cols, names, gains, aug_factors)


def _drive_notes(result: IdentificationResult, ripples: list, lags: list,
                 terms: drive_terms.Terms, joint_names: Sequence[str]) -> None:
    """The identified drive terms into ``result`` (and the log); the warnings they answer."""
    result.current_lag = list(lags)
    if lags:
        log.info("current-loop lag (lag_model: auto): %s", lag_text(result.current_lag))
    result.ripple = list(ripples)
    if any(t.index is None for t in terms.ripples):  # modelled at the given lead: a figure
        lead_mm = 1e3 * terms.ripples[0].wavelength_m
        log.info("screw friction ripple at the %.1f mm lead (screw_lead_m): %s", lead_mm,
                 ", ".join(f"{r.joint} ±{r.amplitude_n:.2g} N (σ {r.amplitude_std_n:.1g})"
                           for r in ripples))
        result.warnings = [  # a ripple left in the residual: another period than the one given
            f"{w}; screw_lead_m is {lead_mm:.1f} mm: check the screws' lead"
            if any(w.startswith(ripple_warning_start(j)) for j in joint_names) else w
            for w in result.warnings]
        return
    for r in ripples:  # said once: as modelled, not as a peak in the residual
        result.warnings = [w for w in result.warnings
                           if not w.startswith(ripple_warning_start(r.joint))]
        result.warnings.append(
            f"{r.joint}: a {'friction' if r.friction else 'force'} ripple of ±{r.amplitude_n:.2g} "
            "N "
            ""
            ""
            ""
            ""
            f"(σ {r.amplitude_std_n:.1g} N) at a {1e3 * r.wavelength_m:.1f} mm period of its "
            "position was found in the residual and added to the model (ripple_model: auto; "
            "screw_lead_m models it at a given lead); the gains and parameters are those of "
            "the model with it"
        )


def tls_model(factors: list[RecordFactors], model, cols, opts: IdentifyOptions
              ) -> tuple[_Model, Any]:
    """The IDIM-TLS solve a result reports (with the ripple columns the residual calls for), not
    checked for excitation; and the base model's solution (whose residual the diagnostics
    describe). ``model``: the robot; ``cols``: its columns (columns/layout.ColumnLayout, or a
    partial answer's Subsystem). Shared by :func:`solve_tls` and the live estimate."""
    def problem_of(fs):  # a motor's equations in joint-side units (joint_units.py)
        return TLSProblem(fs, opts.solve.weighting, noisy_columns=opts.solve.tls_noisy_columns,
                          row_scale=joint_units.equation_scale(model),
                          column_scale=joint_units.column_scale(model, fs[0].n_b, cols.names))

    problem = problem_of(factors)
    base = problem.solve()

    def make_solver(fs):
        return (problem if fs is factors else problem_of(fs)).solve

    return _set_up(factors, model, cols, opts, base, make_solver), base


def solve_tls(factors: list[RecordFactors], model, cols, opts: IdentifyOptions,
              essential: bool, bags: list[str],
              progress: Callable[..., None] | None = None) -> Solved:
    """IDIM-TLS (eqs. 33-39), excitation checked, optionally the essential parameters; a
    partial answer (partial.py) when the data fix only some gains (``progress`` hears the
    subset search)."""
    require_loaded_and_unloaded(factors, "IDIM-TLS")
    log.info("IDIM-TLS on %d equations × %d unknowns", sum(f.n_rows for f in factors),
             factors[0].n_b + model.n_joints + 1)
    partial_ok = opts.solve.partial_answers and opts.solve.check_excitation and model.n_joints > 1
    left_out = {**partial.hardly_moved(factors, model, opts, min_rows(factors[0].n_b)),
                **partial.at_limit(factors, model)} if partial_ok else {}
    if left_out:
        return _solve_partial(factors, model, cols, opts, bags, left_out, essential, progress)
    m, base = tls_model(factors, model, cols, opts)
    sol = m.full
    if opts.solve.check_excitation:
        try:
            left_out = _undetermined(factors, model, cols, opts, m, sol) if partial_ok else {}
        except ExcitationError as exc:
            if not _not_separated(sol, limits(model, opts)):
                raise
            left_out = _search(factors, model, cols, opts, {}, str(exc), progress)
        if left_out:
            return _solve_partial(factors, model, cols, opts, bags, left_out, essential,
                                  progress)
        band_warnings = check_excitation(sol, limits(model, opts), m.names, model.joint_names)
    view, ripples, lags = m.view(sol)
    result = tls_result(model, cols, view, factors, opts, bags)
    if opts.solve.check_excitation:
        result.warnings.extend(band_warnings)
    _uncertainty(result, base, model, opts, gains=True)
    _drive_notes(result, ripples, lags, m.terms, model.joint_names)
    solver = SolverInfo(opts.solve.tls_noisy_columns, sol.singular_ratio,
                        tuple(float(x) for x in sol.singular_values[-3:]),
                        joint_sigma=tuple(float(x) for x in sol.joint_sigma),
                        lambda_scale=sol.lambda_scale)
    out = Solved(result, _chi(m, sol), view.g_tau, solver, view, factors=m.factors,
                 chi_rows=sol.chi_full())
    if essential:
        t0 = time.perf_counter()
        log.info("essential parameters (%s, r_sigma = %g)", opts.solve.essential_method,
                 opts.solve.r_sigma)
        ess = _essential(m, opts, [f"g_tau {j}" for j in model.joint_names])
        ess_view, ess_ripples, ess_lags = m.view(ess.solution)
        result.essential = tls_result(model, cols, ess_view, factors, opts, bags)
        result.essential.ripple = list(ess_ripples)
        result.essential.current_lag = list(ess_lags)
        _note_essential(m.names, result, ess)
        out.timings["essential"] = time.perf_counter() - t0
    return out


def _undetermined(factors: list[RecordFactors], model, cols, opts: IdentifyOptions, m: _Model,
                  sol: TLSSolution) -> dict[int, str]:
    """Gains of a solve the data do not fix (partial.py), by joint index, with the reason: the
    payload adds almost no torque on the axis; else, eq. (37) holding, a σ above the limit."""
    names = model.joint_names
    left_out = partial.little_payload(factors, m.view(sol)[0].g_tau, names,
                                      opts.solve.min_payload_share, _payload_unknowns(cols, sol))
    if left_out:
        return left_out
    lim = limits(model, opts)
    check_subspace(sol, lim)
    n = sol.chi.shape[0]
    return partial.weak_gain(sol.rel_std[n:n + model.n_joints], names, lim.max_gain_rel_std)


def _not_separated(sol: TLSSolution, lim: ExcitationLimits) -> bool:
    """Eq. (37) or the condition fails: a subset of the gains may still be fixed (partial.py)."""
    return sol.singular_ratio > lim.max_singular_ratio or sol.condition_number > lim.max_condition


def _failure(factors: list[RecordFactors], model: partial.Subsystem, opts: IdentifyOptions
             ) -> partial.Trial:
    """``model``'s (a subsystem's: its robot and its columns) solve on ``factors`` judged as a
    full answer is: why it is not one (eq. 37, condition, payload share, honest σ, sign), or
    None."""
    kept = frozenset(int(j) for j in model.joint_idx)
    try:
        m, _ = tls_model(factors, model, model, opts)
    except ExcitationError as exc:  # a direction without the payload, a singular Ŵ_tot
        return partial.Trial(kept, math.inf, str(exc))
    sol, names = m.full, model.joint_names
    lim = limits(model, opts)
    if sol.singular_ratio > lim.max_singular_ratio:
        return partial.Trial(kept, sol.singular_ratio, "the two smallest singular values of W_tot "
                             f"are not separated (s_c/s_c-1 = {sol.singular_ratio:.2f} > "
                             f"{lim.max_singular_ratio:g}, eq. 37)")
    if sol.condition_number > lim.max_condition:
        return partial.Trial(kept, sol.singular_ratio, "the scaled regressor's condition number "
                             f"is {sol.condition_number:.3g} (> {lim.max_condition:.3g})")
    g = m.view(sol)[0].g_tau
    little = partial.little_payload(factors, g, names, opts.solve.min_payload_share,
                                    _payload_unknowns(model, sol))
    n = sol.chi.shape[0]
    rel = sol.rel_std[n:n + model.n_joints]
    if little:
        j = min(little)
        why = f"the payload adds almost no torque on {names[j]}"
    elif np.any(rel > lim.max_gain_rel_std):
        j = int(np.argmax(rel))
        why = (f"the honest σ of {names[j]}'s gain is {100 * rel[j]:.2g} % (> max_gain_rel_std "
               f"{100 * lim.max_gain_rel_std:g} %)")
    elif np.any(g <= 0):
        why = f"{names[int(np.argmin(g))]}'s gain comes out negative"
    else:
        why = None
    idx = sorted(kept)
    t = partial.Trial(kept, sol.singular_ratio, why, dict(zip(idx, g.tolist())),
                      dict(zip(idx, (rel * np.abs(g)).tolist())))
    return t if why or not opts.solve.weighting else _weights_shift(t, factors, model, opts)


def _weights_shift(t: partial.Trial, factors: list[RecordFactors], model,
                   opts: IdentifyOptions) -> partial.Trial:
    """``t`` (rows weighted by 1/σ_j, Sect. 4.2) failed if the same subsystem with unweighted
    rows moves a gain beyond noise (partial.shift_beyond_noise): both are consistent when the
    model fits the records; a shift beyond noise is a model error (e.g. the regressor of
    coarsely printed positions at a low rate) that biases the answer beyond its σ."""
    try:
        m, _ = tls_model(factors, model, model, opts.replace(weighting=False))
    except ExcitationError:
        return t
    sol = m.full
    n, g = sol.chi.shape[0], m.view(sol)[0].g_tau
    std = sol.rel_std[n:n + model.n_joints] * np.abs(g)
    idx = sorted(t.kept)
    moved = partial.shift_beyond_noise(t, partial.Trial(t.kept, sol.singular_ratio, None,
                                                        dict(zip(idx, g.tolist())),
                                                        dict(zip(idx, std.tolist()))))
    if moved is None:
        return t
    i, z = moved
    return dataclasses.replace(t, failure=(
        f"{model.full.joint_names[i]}'s gain moves by {z:.1f} of its σ between weighted and "
        f"unweighted rows (beyond what noise explains, > {partial.NESTED_Z:g}): the model does "
        "not fit these records to within their noise"),
        advice="log positions finer than their print, or at a higher rate")


def _search(factors: list[RecordFactors], model, cols, opts: IdentifyOptions,
            left_out: dict[int, str], why: str,
            progress: Callable[..., None] | None = None) -> dict[int, str]:
    """The gains to leave out beside ``left_out`` (joint index -> reason) so that the rest is an
    answer: the largest such subset of the free gains (partial.search_subsets). ExcitationError
    with ``why`` (the full set's failure) when no subset is one."""
    free = [j for j in range(model.n_joints) if j not in left_out]

    def trial(kept: frozenset[int]) -> partial.Trial:
        out = dict(left_out)
        out.update({j: "" for j in free if j not in kept})
        with np.errstate(over="ignore", divide="ignore", invalid="ignore"):  # failed trials' σ
            return _failure(*partial.reduce(factors, model, cols, out), opts)

    best, tried = partial.search_subsets(free, trial, model.joint_names, progress=progress)
    if best is None:
        raise ExcitationError(
            ("no drive gain is determined: " if left_out else "") + why + "; nor is any subset "
            f"of the gains of {', '.join(model.joint_names[j] for j in free)} ({len(tried)} "
            "tried, eq. 37, honest σ)")
    log.info("partial answer: %s of %s separated (s_c/s_c-1 = %.2f, %d subsets tried)",
             ", ".join(model.joint_names[j] for j in sorted(best.kept)), len(free), best.ratio,
             len(tried))
    return partial.search_reasons(best, free, trial, tried, model.joint_names)


def _payload_unknowns(cols, sol: TLSSolution) -> tuple[slice, np.ndarray] | None:
    """The columns of a payload known by its mass and their identified χ_ul (none otherwise)."""
    if not cols.has_payload_unknowns:
        return None
    chi = np.zeros(sol.active.shape[0])
    chi[sol.active] = sol.chi
    return cols.payload_slice, chi[cols.payload_slice]


def _left_out_text(names: Sequence[str], left_out: dict[int, str]) -> list[str]:
    return [r if r.startswith(names[j]) else f"{names[j]}: {r}"
            for j, r in sorted(left_out.items())]


def _solve_partial(factors: list[RecordFactors], model, cols, opts: IdentifyOptions,
                   bags: list[str], left_out: dict[int, str], essential: bool,
                   progress: Callable[..., None] | None = None) -> Solved:
    """IDIM-TLS on the joints whose gains the data fix (partial.py): their rows only, the
    columns only the others' rows held left out; judged as a full answer is, on that
    subsystem. The result lists every joint, those left out "not determined" with the reason."""
    names = model.joint_names
    for _ in range(model.n_joints):
        if len(left_out) == model.n_joints:
            raise ExcitationError("no drive gain is determined: "
                                  + "; ".join(_left_out_text(names, left_out)))
        log.info("partial answer: %s", "; ".join(f"{names[j]} left out" for j in left_out))
        fs, sub = partial.reduce(factors, model, cols, left_out)
        m, base = tls_model(fs, sub, sub, opts)
        sol = m.full
        try:  # eq. (37) on the subsystem of the determined gains
            new = _undetermined(fs, sub, sub, opts, m, sol)
        except ExcitationError as exc:
            why = "; ".join(_left_out_text(names, left_out)) + f"; and without them {exc}"
            if not _not_separated(sol, limits(sub, opts)):
                raise ExcitationError("no drive gain is determined: " + why) from None
            left_out.update(_search(factors, model, cols, opts, left_out, why, progress))
            continue
        if not new:
            break
        left_out.update({int(sub.joint_idx[k]): r for k, r in new.items()})
    band_warnings = check_gains(sol, limits(sub, opts), sub.joint_names)
    view, ripples, lags = m.view(sol)
    result = tls_result(sub, sub, view, fs, opts, bags)
    result.warnings.extend(band_warnings)
    _uncertainty(result, base, sub, opts, gains=True)
    _drive_notes(result, ripples, lags, m.terms, sub.joint_names)
    partial.expand(result, model, sub, left_out)
    if essential:
        result.warnings.append("--essential is not run on a partial answer: the essential "
                               "reduction protects every gain")
    chi = np.zeros(factors[0].n_b)
    chi[sub.col_idx] = _chi(m, sol)[:sub.col_idx.shape[0]]
    g = np.full(model.n_joints, np.nan)
    g[sub.joint_idx] = view.g_tau
    solver = SolverInfo(opts.solve.tls_noisy_columns, sol.singular_ratio,
                        tuple(float(x) for x in sol.singular_values[-3:]),
                        joints_solved=tuple(sub.joint_names), lambda_scale=sol.lambda_scale)
    return Solved(result, chi, g, solver, None, factors=[])


def _chi(m: _Model, sol) -> np.ndarray:
    """χ for the observation matrix of the records (cross-validation): with the drive terms'
    coefficients whose columns the equations hold (lag, ripple at a given lead)."""
    return sol.chi_full()[:m.n_rows_cols]


def _essential(m: _Model, opts: IdentifyOptions, protected_names: list[str]) -> EssentialResult:
    return essential_parameters(m.solve_active, len(m.names), opts.solve.r_sigma, start=m.full,
                                method=opts.solve.essential_method, names=m.names,
                                min_tolerance=opts.solve.essential_min_tolerance,
                                max_residual_increase=opts.solve.essential_max_residual_increase,
                                protected_names=protected_names, fixed=m.fixed)


def manufacturer_or_given(gains: Sequence[float] | None, model) -> np.ndarray:
    """Drive gains for WLS: the given ones (N/A, N·m/A) or the robot's nominal (manufacturer's)
    gains (the Orthoglide's 637π)."""
    n_j = model.n_joints
    g = np.asarray(model.nominal_gains if gains is None else gains, dtype=float)
    if g.shape != (n_j,) or not np.all(np.isfinite(g)) or np.any(g <= 0):
        raise IdentificationError(
            f"drive gains must be {n_j} positive numbers ({', '.join(model.joint_names)}), "
            f"not {gains}")
    if gains is None:
        log.info("IDIM-WLS with the manufacturer's drive gains %s (give --gains to use "
                 "identified ones)", ", ".join(f"{x:.1f}" for x in g))
    return g


def solve_wls(factors: list[RecordFactors], model, cols, opts: IdentifyOptions,
              gains: Sequence[float] | None, essential: bool, bags: list[str]) -> Solved:
    """IDIM-WLS (eqs. 24-28) with given gains, payload masses estimated."""
    g = manufacturer_or_given(gains, model)
    log.info("IDIM-WLS on %d equations", sum(f.n_rows for f in factors))
    rows = joint_units.equation_scale(model)
    base = idim_wls(factors, g, weighting=opts.solve.weighting, row_scale=rows)

    def make_solver(fs):
        def solve_active(act, reweight):
            return idim_wls(fs, g, active=act, weighting=opts.solve.weighting, row_scale=rows)
        return solve_active

    m = _set_up(factors, model, cols, opts, base, make_solver, g)
    view, ripples, lags = m.view(m.full)
    result = wls_result(model, cols, view, g, factors, bags)
    result.warnings.extend(payload_tag_warnings(result, model, gains is not None))
    _uncertainty(result, base, model, opts, gains=False)
    _drive_notes(result, ripples, lags, m.terms, model.joint_names)
    out = Solved(result, _chi(m, m.full), g,
                 SolverInfo(joint_sigma=tuple(float(x) for x in view.joint_sigma)),
                 factors=m.factors, chi_rows=m.full.chi_full())
    if essential:
        t0 = time.perf_counter()
        ess = _essential(m, opts, [f"m_7 ({mass:g} kg)" for mass in base.payload_groups])
        ess_view, ess_ripples, ess_lags = m.view(ess.solution)
        result.essential = wls_result(model, cols, ess_view, g, factors, bags)
        result.essential.ripple = list(ess_ripples)
        result.essential.current_lag = list(ess_lags)
        _note_essential(m.names, result, ess)
        out.timings["essential"] = time.perf_counter() - t0
    return out


def _note_essential(names: list[str], result: IdentificationResult, ess: EssentialResult) -> None:
    assert result.essential is not None
    result.essential.removed = [str(names[k]) for k in ess.removed]
    result.essential.reduction = EssentialReduction(
        ess.method, ess.stopped_because, tuple(float(x) for x in ess.ratios),
        tuple(ess.tolerance), tuple(ess.steps))
    result.removed = list(result.essential.removed)
