"""Physically consistent standard parameters behind an identification (after TLS or WLS).

The base parameters χ_b = K χ_st (eq. 21) are linear combinations of masses, first moments and
inertias; nothing in the LS/TLS answer says that real bodies can produce them. Two fits under
the LMIs of pseudo_inertia.py (every body's pseudo-inertia ⪰ 0, ia, fv, fs ≥ 0), solved by
lmi.py:

- **projection** of the answer: the χ_st nearest to it in its own covariance,

      min (K χ_st − χ̂_b)ᵀ Σ⁻¹ (K χ_st − χ̂_b) + w ‖prior residual‖²

  with Σ the honest covariance of the base parameters (marginal over the gains); its value
  at the optimum is the Mahalanobis distance d² reported. The gains move with it as their
  conditional mean given the base parameters: g* = ĝ + Σ_gb Σ_bb⁻¹ (χ_b* − χ̂_b).
- **identification under the constraints** (``consistent``): χ_st solved against the data
  directly, the equations of every record weighted per joint as the solve weighted them, the
  gains (TLS: identified, WLS: given) and the payloads' known (TLS) or estimated (WLS) masses held,
  the drive terms' coefficients (lag, ripple) free:

      min Σ_j ‖(g_j v_τ,j − W_j K χ_st − W_d,j θ − w_m,j m) / σ_j‖² + w ‖prior residual‖²

How the prior is weighted: its residuals are in the unknowns' scales (pseudo_inertia.py: the
body's mass and length), weight w = ``consistency_prior_weight`` (1e-4): a Gaussian prior 100
scales wide. Where the data determine a direction to better than ~100 scales the prior moves it
by < 1e-4 of its σ² / scale²; it decides only the directions the data leave free (K's null space
and the weakly identified combinations), e.g. the Orthoglide platform's inertia, which its
translating platform never shows.

Per body, whether the unconstrained answer was consistent: the least total relaxation t_k of
the pseudo-inertias (S_k + t_k 1 ⪰ 0) that lets some χ_st reproduce χ̂_b **exactly**; t_k = 0
for every body iff a consistent χ_st with K χ_st = χ̂_b exists; the bodies with t_k > 0 are
those the least relaxation blames (the choice among them is not unique when several could).
"""
from __future__ import annotations

import json
import logging
import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from orthoglide_ident.errors import ConfigError, IdentificationError
from orthoglide_ident.identify.consistency import lmi
from orthoglide_ident.identify.consistency.pseudo_inertia import (
    RELAXATION_TOL,
    Layout,
    clean,
    layout,
)
from orthoglide_ident.identify.consistency.report import ConsistencyReport, DirectDynamics

log = logging.getLogger("orthoglide_ident.identify")

PRIOR_WEIGHT = 1e-4  # default consistency_prior_weight
CHECK_WEIGHT = 1e-8  # tie-break of the exact-feasibility check in K's null space


@dataclass
class Fit:
    """One consistent answer: χ_st (standard_names order), χ_b = K χ_st, solver figures."""

    chi_st: np.ndarray
    chi_b: np.ndarray
    objective: float
    solve_s: float
    status: str
    iterations: int


def solve_fit(lay: Layout, K: np.ndarray, W: np.ndarray, target: np.ndarray, weight: float,
              what: str) -> Fit:
    """argmin ‖W (K χ_st) − target‖² + weight ‖prior residual‖² under the LMIs."""
    A = (W @ K) * lay.scale[None, :]
    ans = lmi.fit(A, target, lay.B_s, lay.b_s, weight, lay.lmi_blocks(), lay.inequalities()[0],
                  what)
    chi = clean(lay, ans.z * lay.scale)
    return Fit(chi, K @ chi, ans.objective, ans.solve_s, ans.status, ans.iterations)


def whitening(cov: np.ndarray) -> np.ndarray:
    """W with Wᵀ W = Σ⁻¹ (Σ⁻½ by eigen-decomposition; eigenvalues floored at 1e-15 of the
    largest: a singular Σ would claim a direction known exactly)."""
    lam, U = np.linalg.eigh(0.5 * (cov + cov.T))
    lam = np.maximum(lam, 1e-15 * max(lam.max(), 1e-300))
    return (U / np.sqrt(lam)).T


def identifiable(K: np.ndarray, tol: float = 1e-8) -> np.ndarray:
    """(n_st,) bool: the standard parameters the base parameters determine on their own
    (e_i in K's row space)."""
    _, s, vt = np.linalg.svd(K, full_matrices=False)
    V = vt[s > tol * s[0]]
    return np.linalg.norm(V, axis=0) > 1.0 - 1e-9


@dataclass
class Findings:
    """Was the unconstrained answer consistent? Per body and per bounded drive term."""

    relaxation: np.ndarray  # (n_bodies,) t_k, scaled
    bound_relaxation: np.ndarray  # (n_inequalities,) u_i, scaled (Layout.inequalities)
    solve_s: float

    @property
    def consistent(self) -> bool:
        return bool(np.all(self.relaxation <= RELAXATION_TOL)
                    and np.all(self.bound_relaxation <= RELAXATION_TOL))


def check_exact(lay: Layout, K: np.ndarray, W: np.ndarray, target: np.ndarray) -> Findings:
    """Least relaxation of the LMIs and bounds that lets K χ_st = χ̂_b exactly (W-whitened)."""
    A = (W @ K) * lay.scale[None, :]
    ans = lmi.relaxation(A, target, lay.B_s, lay.b_s, CHECK_WEIGHT, lay.lmi_blocks(0.0),
                         lay.inequalities()[0], "consistency check of the unconstrained answer")
    return Findings(ans.t, ans.u, ans.solve_s)


# --------------------------------------------------------------------- the data, gains held
@dataclass
class NormalForm:
    """The weighted equations of every record with the gains and payload masses held, reduced
    to the base parameters: ‖R22 χ_b + r2‖² + rest² is their least squares over the drive terms
    θ for a given χ_b; θ(χ_b) = −R11⁻¹ (R12 χ_b + r1)."""

    R11: np.ndarray
    R12: np.ndarray
    r1: np.ndarray
    R22: np.ndarray
    r2: np.ndarray

    def theta(self, chi_b: np.ndarray) -> np.ndarray:
        if not self.R11.size:
            return np.zeros(0)
        return -np.linalg.solve(self.R11, self.R12 @ chi_b + self.r1)


def _record_map(f, g: np.ndarray, j: int, mass: float) -> np.ndarray:
    """T with ρ_j = [W | W_kl | v_τ]·T·[y; 1], y = [χ_b, θ]: −W y − w_m m + v_τ g_j."""
    n_c = f.n_b
    T = np.zeros((n_c + 2, n_c + 1))
    T[np.arange(n_c), np.arange(n_c)] = -1.0
    T[n_c, n_c] = -mass if f.loaded else 0.0
    T[n_c + 1, n_c] = g[j]
    return T


def normal_form(factors: Sequence, n_b: int, g: np.ndarray, masses: Sequence[float],
                sigma: np.ndarray) -> NormalForm:
    """The :class:`NormalForm` of ``factors`` (one held payload mass per record, kg; rows of
    joint j weighted by 1/σ_j)."""
    R = np.linalg.qr(np.vstack([f.R[j] @ _record_map(f, g, j, m) / sigma[j]
                                for f, m in zip(factors, masses) for j in range(f.n_joints)]),
                     mode="r")
    n_c = factors[0].n_b
    order = np.r_[n_b:n_c, 0:n_b, n_c]  # θ first: eliminated before the base parameters
    R = np.linalg.qr(R[:, order], mode="r")
    k = n_c - n_b
    pad = np.zeros((n_c + 1, n_c + 1))
    pad[:R.shape[0]] = R
    return NormalForm(pad[:k, :k], pad[:k, k:n_c], pad[:k, n_c], pad[k:n_c, k:n_c],
                      pad[k:n_c, n_c])


def residual_rms(factors: Sequence, y: np.ndarray, g: np.ndarray,
                 masses: Sequence[float]) -> np.ndarray:
    """(n_j,) rms of g v_τ − W y − w_m m over the equations of every record (N or N·m)."""
    n_j = factors[0].n_joints
    ss, rows = np.zeros(n_j), np.zeros(n_j)
    u = np.append(y, 1.0)
    for f, m in zip(factors, masses):
        for j in range(n_j):
            ss[j] += float(np.sum((f.R[j] @ (_record_map(f, g, j, m) @ u)) ** 2))
            rows[j] += f.rows[j]
    return np.sqrt(ss / np.maximum(rows, 1))


# --------------------------------------------------------------------- the step after TLS/WLS
@dataclass
class ConsistencyResult(ConsistencyReport):
    """What the consistency step found (its report, JSON, text and message fields: report.py).
    Base parameters in ``base_names`` order, gains N/A or N·m/A, residuals N or N·m, d²
    dimensionless."""

    robot: str
    lay: Layout = field(repr=False)
    base_names: list[str]
    joint_names: list[str]
    chi_hat: np.ndarray  # unconstrained base parameters
    sigma_b: np.ndarray  # their honest σ
    findings: Findings
    projection: Fit
    projection_d2: float
    gains: np.ndarray  # the solve's (identified or given)
    gains_projected: np.ndarray  # conditional mean given the projected base parameters
    gains_sigma: np.ndarray  # 0 when given
    identified: Fit | None
    identified_d2: float | None
    residual_rms: dict[str, list[float]]
    identifiable: np.ndarray = field(repr=False)
    prior_weight: float = PRIOR_WEIGHT
    inflation: float = 1.0  # κ of the covariance the distances are measured in (_base_answer)
    seconds: float = 0.0
    # the consistent model forward-simulated on each validation record (validate/)
    direct_dynamics: list[DirectDynamics] = field(default_factory=list)

    @property
    def answer(self) -> Fit:
        """The consistent set the product hands on: identified under the constraints, else the
        projection."""
        return self.identified if self.identified is not None else self.projection

    def values(self) -> dict[str, float]:
        """Every standard parameter of the answer by name (SI)."""
        return {n: float(v) for n, v in zip(self.lay.names, self.answer.chi_st)}


def _base_answer(result, robot) -> tuple[np.ndarray, np.ndarray, float, np.ndarray]:
    """χ̂_b in ``robot.names`` order, the covariance over [χ_b, gains or masses] the fits measure
    distances in, its inflation κ and the honest σ of the unknowns. The covariance is eq. (39)'s
    (eq. 27's for WLS) times κ, the largest honest / eq. (39) variance ratio: every σ at least
    the honest one (uncertainty.py), the correlations those of the data's normal matrix, so that
    a direction the records do not constrain stays cheap to move along. (The honest covariance's
    own correlations, or eq. (39)'s rescaled unknown by unknown, are not ⪰ eq. (39): along some
    directions they are narrower, and the projection then moved the sample bags' answer where
    the data fix it: +6 % residual.)"""
    cov, paper = getattr(result, "covariance", None), getattr(result, "covariance_paper", None)
    names = [p.name for p in result.parameters]
    if cov is None or paper is None or names != list(robot.names):
        raise IdentificationError("the consistency step needs the base answer with every base "
                                  f"parameter of {robot.name} and its covariance")
    cov, paper = np.asarray(cov, float), np.asarray(paper, float)
    kappa = float(max(1.0, np.max(np.diag(cov) / np.maximum(np.diag(paper), 1e-300))))
    return (np.array([p.value for p in result.parameters]), kappa * paper, kappa,
            np.sqrt(np.diag(cov)))


def held_masses(result, factors: Sequence) -> list[float]:
    """The payload mass each record is held at (kg): known (gains identified) or, the gains given
    (WLS), the estimate of its tag."""
    if not result.drive_gains_given:
        return [float(f.payload_mass) if f.loaded else 0.0 for f in factors]
    est = {p.tagged: p.value for p in result.payloads}
    return [float(est.get(f.payload_mass, f.payload_mass)) if f.loaded else 0.0 for f in factors]


def analyse(result, factors: Sequence, chi_rows: np.ndarray, joint_sigma: np.ndarray, robot,
            prior_weight: float = PRIOR_WEIGHT, under_constraints: bool = True,
            prior: Mapping[str, float] | np.ndarray | None = None,
            progress: Callable[..., None] | None = None) -> ConsistencyResult:
    """The consistency step on a solved identification (``result`` with its covariance; the
    records' ``factors`` and their ``chi_rows`` over every column, drive terms included;
    ``joint_sigma`` the solve's row weights): the exact-consistency check, the projection and,
    with ``under_constraints``, the identification under the LMIs with the gains held.
    ``progress(stage, done, total, unit)`` hears the fits done (None: silent)."""
    t0 = time.perf_counter()
    steps = 4 if under_constraints else 2  # check, projection (, rows' normal form, fit)

    def tell(done: int) -> None:
        if progress is not None:
            progress("physical consistency (LMI fits)", done, steps, "steps")

    tell(0)
    chi_hat, cov, kappa, std = _base_answer(result, robot)
    n_b, K = robot.n_b, np.asarray(robot.K, float)
    lay = layout(robot, prior, chi_hat)
    S_bb, S_gb = cov[:n_b, :n_b], cov[n_b:, :n_b]
    W = whitening(S_bb)
    findings = check_exact(lay, K, W, W @ chi_hat)
    tell(1)
    proj = solve_fit(lay, K, W, W @ chi_hat, prior_weight, "projection onto consistent parameters")
    tell(2)
    d = proj.chi_b - chi_hat
    g = np.array([x.value for x in result.drive_gains], float)
    given = bool(result.drive_gains_given)
    g_proj = g if given else g + S_gb[:len(g)] @ np.linalg.lstsq(S_bb, d, rcond=None)[0]
    g_sigma = np.zeros_like(g) if given else std[n_b:n_b + len(g)]
    masses = held_masses(result, factors)
    y = np.asarray(chi_rows, float).copy()
    rms = {"unconstrained": residual_rms(factors, y, g, masses)}
    y[:n_b] = proj.chi_b
    rms["projection"] = residual_rms(factors, y, g_proj, masses)
    ident, d2_ident = None, None
    if under_constraints:
        nf = normal_form(factors, n_b, g, masses, np.asarray(joint_sigma, float))
        tell(3)
        ident = solve_fit(lay, K, nf.R22, -nf.r2, prior_weight,
                          "identification under the consistency constraints")
        tell(4)
        rms["identification"] = residual_rms(factors, np.r_[ident.chi_b, nf.theta(ident.chi_b)],
                                             g, masses)
        d2_ident = float(np.sum((W @ (ident.chi_b - chi_hat)) ** 2))
    out = ConsistencyResult(
        str(robot.name), lay, list(robot.names), list(result.joint_names), chi_hat,
        std[:n_b], findings, proj, float(np.sum((W @ d) ** 2)), g, g_proj, g_sigma,
        ident, d2_ident, {k: [float(x) for x in v] for k, v in rms.items()}, identifiable(K),
        prior_weight, kappa)
    out.seconds = time.perf_counter() - t0
    log.info("physical consistency: %s", out.summary())
    return out


def read_prior(path: str) -> dict[str, float] | None:
    """Prior standard parameters from a JSON file: a mapping name -> value (SI), or an
    ``identify --json`` output (its ``consistency.standard``); None for ""."""
    if not path:
        return None
    try:
        doc = json.loads(Path(path).read_text())
    except OSError as exc:
        raise ConfigError(f"consistency_prior {path}: cannot read it ({exc.strerror or exc})") \
            from None
    except json.JSONDecodeError as exc:
        raise ConfigError(f"consistency_prior {path}: not valid JSON ({exc.msg} at line "
                          f"{exc.lineno})") from None
    if isinstance(doc, dict) and isinstance(doc.get("consistency"), dict):
        doc = doc["consistency"].get("standard")
    if not isinstance(doc, dict) or not all(
            isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
            for v in doc.values()):
        raise ConfigError(f"consistency_prior {path}: expected a mapping of standard parameter "
                          "names to numbers (or an identify --json output)")
    return {str(k): float(v) for k, v in doc.items()}


MASS_RATIO_WARN = 2.0  # a body's consistent mass this far from the description's is said


def attach(solved, model, opts, progress: Callable[..., None] | None = None) -> None:
    """The consistency step on a :class:`~solve.Solved` (option ``consistent``): the result's
    ``consistency`` (projection and identification under the constraints)."""
    res = solved.result
    res.consistency = analyse(res, solved.factors, solved.chi_rows,
                              np.asarray(solved.solver.joint_sigma, float), model,
                              opts.consistency.consistency_prior_weight,
                              prior=read_prior(opts.consistency.consistency_prior),
                              progress=progress)
    res.warnings.extend(mass_warnings(res.consistency, model, res))
    held = [b.body for b in res.consistency.bodies() if b.at_prior
            and any(n.startswith("m_") for n in b.at_prior)]
    if held:
        res.warnings.append(
            f"--consistent: the data do not determine the mass of {', '.join(held)}: it is "
            f"{res.consistency.lay.prior_source}'s (prior weight "
            f"{res.consistency.prior_weight:g}; consistency_prior gives another)")


def mass_warnings(c: ConsistencyResult, model, res) -> list[str]:
    """Bodies whose consistent mass is more than MASS_RATIO_WARN times off the description's
    (the prior from the robot file): the data say so, and the likely cause with it."""
    if c.lay.prior_source != "the robot's description":
        return []
    prior = c.lay.prior_values(c.answer.chi_st)
    off = []
    for body in c.lay.bodies:
        k = body.inertial[-1]  # INERTIAL_KINDS ends with the mass
        m, p = float(c.answer.chi_st[k]), float(prior[k])
        if p > 0 and not 1 / MASS_RATIO_WARN <= m / p <= MASS_RATIO_WARN:
            off.append(f"{body.name} {m:.3g} kg (description {p:.3g} kg)")
    if not off:
        return []
    if res.drive_gains_given and not model.nominal_gains_given:
        cause = ("the gains are not known (WLS with a bare URDF's 1 per unit scales every mass "
                 "by 1/g): give --gains, e.g. a TLS identification's")
    elif res.drive_gains_given:
        cause = (
            "the gains given (or the nominal ones) are not the drives', or the description is wrong"
        )
    else:
        cause = "the description's masses are not the robot's, or the payload tag is wrong"
    return [f"--consistent: bodies far from the description's masses: {', '.join(off)}: {cause}"]
