"""The σ an identification will reach on a trajectory, before it is run: eq. (39) at the nominal
model.

IDIM-TLS (eqs. 33–36) solves W_tot χ_tot = 0 with W_tot = [−W | −W_kl m | V_τ] (unloaded rows:
m = 0), χ_tot = [χ_b, 1, g_τ]; the loaded rows' known payload m fixes the scale. With the noise
in the current references only (σ_j A on joint j, white at the 1 kHz sample rate), the
linearised (Cramér–Rao) covariance of θ = [χ_b, g_τ] is

    cov θ = (Σ_rows a aᵀ / (g_j σ_j)²)⁻¹,   a = [W_row, −v_τ,row e_j],   v_τ = (W χ_b + m W_kl) /
    g_j

which is eq. (39) at small noise. Evaluated at the nominal model (the URDF's inertials,
armature, damping and friction, regrouped into χ_b = K χ_st: eq. 21) and the manufacturer's
gains, on samples of one period standing for the run's 1 kHz samples. The decimation's low-pass
keeps the signal and drops noise outside its band, so the identification reaches about this σ
(bench/excitation_design.py measures it on the simulated plants).

The identification adds a current-loop lag column per joint on periodic records
(``lag_model: auto``, identify/current_lag.py: g_j (v_τ − τ_j v̇_τ)): with ``lag`` the prediction
carries those unknowns too (column −v̇_τ,j, v̇_τ from the nominal efforts by a periodic central
difference: the samples must be one period on a uniform grid). On the simulated UR5 they are what
sets the fastest wrist's gain σ.

The condition number κ is that of the column-scaled weighted [W | V_τ] of both runs (the
matrix whose smallest singular value sets every σ above): the design's second criterion, so that
no base parameter is left unexcited while the gains are already good. The eigen-directions of
the scaled information beyond a cap on κ are not excited (``Unexcited``: the unknowns they
load, their κ): the prediction is for the rest, those unknowns' σ infinite ("not determined").
"""
from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from orthoglide_ident.errors import ExcitationError
from orthoglide_ident.identify.solve.partial import payload_share
from orthoglide_ident.model.robot import Payload

RATE_HZ = 1000.0  # the records' sample rate the prediction is for
DEFAULT_CURRENT_NOISE = 0.02  # A, per joint, when no record says otherwise
MAX_CONDITION = 1e6  # κ (√ of the eigenvalue ratio) beyond which a direction is not excited
STRUCTURAL = 1e-14  # λ/λmax of the scaled F below which a direction is null up to rounding
LOADS = 0.3  # an unknown's |component| (of the largest) in a direction that names it
DEFAULT_DECIMATION = 10  # n_d of a result that does not say (ObserveOptions.decimation)


@dataclass(frozen=True)
class RunSamples:
    """One run sampled over one period (m, n) each, standing for ``seconds`` s at RATE_HZ."""

    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    seconds: float
    payload: Payload | None = None
    noise_a: np.ndarray | None = None  # (n,) A for this run only (else predict's)


@dataclass(frozen=True)
class Prediction:
    """σ of the gains (relative) and base parameters (absolute and relative) and κ."""

    gain_rel_std: np.ndarray  # (n_j,) fraction
    base_std: np.ndarray  # (n_b,) in each parameter's unit
    base_rel_std: np.ndarray  # (n_b,) fraction of the nominal value (inf where it is 0)
    condition: float
    noise_a: np.ndarray  # (n_j,) A
    unexcited: tuple[Unexcited, ...] = ()  # directions beyond the cap, left out (σ = inf)
    condition_kept: float = math.nan  # κ of the directions kept
    # the gains the payload does not scale by the identification's rule (``unloaded``): the
    # joints' names and the payload's share of their rms torque on the loaded run
    not_loaded: tuple[str, ...] = ()
    payload_share: np.ndarray | None = None

    @property
    def undetermined_gains(self) -> np.ndarray:
        return ~np.isfinite(self.gain_rel_std)

    def worst_determined_gain(self) -> float:
        ok = self.gain_rel_std[np.isfinite(self.gain_rel_std)]
        return float(ok.max()) if ok.size else math.inf

    @property
    def worst_gain(self) -> float:
        return float(self.gain_rel_std.max())

    def to_dict(self, joints: Sequence[str], names: Sequence[str]) -> dict[str, Any]:
        def num(x: float) -> float | None:
            return float(x) if math.isfinite(x) else None

        return {"current_noise_a": {j: float(s) for j, s in zip(joints, self.noise_a)},
                "gain_rel_std": {j: num(s) for j, s in zip(joints, self.gain_rel_std)},
                "base_std": {n: num(s) for n, s in zip(names, self.base_std)},
                "base_rel_std": {n: num(s) for n, s in zip(names, self.base_rel_std)},
                "condition_number": num(self.condition),
                "condition_number_excited": num(self.condition_kept),
                "not_excited": [u.to_text() for u in self.unexcited]
                + [not_loaded_text(j) for j in self.not_loaded],
                **({} if self.payload_share is None else {"payload_share": {
                    j: num(s) for j, s in zip(joints, self.payload_share)}})}


def not_loaded_text(joint: str) -> str:
    return (f"the payload adds almost no torque on {joint}'s axis (a payload offset from the "
            "flange, e.g. --payload-com X,Y,Z, would)")


def nominal_base_values(robot) -> np.ndarray:
    """χ_b of the description's own standard parameters (eq. 21)."""
    return robot.base_values(robot.standard_values())


def run_rows(robot, chi_b: np.ndarray, gains: np.ndarray, run: RunSamples
             ) -> tuple[np.ndarray, np.ndarray]:
    """(X (n_b + 1, n, m) of the run's payload, nominal efforts τ (n, m) N or N·m)."""
    model = robot.with_payload(run.payload) if run.payload is not None else robot
    X = model.observation_block(run.q, run.qd, run.qdd)
    mass = run.payload.mass if run.payload is not None else 0.0
    tau = np.tensordot(chi_b, X[:-1], axes=(0, 0)) + mass * X[-1]
    return X, tau


def periodic_rate(tau: np.ndarray, seconds_per_sample: float) -> np.ndarray:
    """τ̇ (n, m) of efforts sampled over one period on a uniform grid (central difference)."""
    return (np.roll(tau, -1, axis=1) - np.roll(tau, 1, axis=1)) / (2.0 * seconds_per_sample)


def information(X: np.ndarray, tau: np.ndarray, gains: np.ndarray, noise_a: np.ndarray,
                weight: float, tau_rate: np.ndarray | None = None) -> np.ndarray:
    """Σ a aᵀ / (g_j σ_j)² over a run's rows (module docstring), times ``weight`` (1 kHz
    samples per sample given); unknowns [χ_b, g_τ] and, with ``tau_rate`` (τ̇, n × m), each
    joint's lag term θ_j = g_j τ_j (column −v̇_τ,j)."""
    n_b, n_j = X.shape[0] - 1, X.shape[1]
    c = n_b + n_j * (1 if tau_rate is None else 2)
    F = np.zeros((c, c))
    for j in range(n_j):
        A = np.zeros((X.shape[2], c))
        A[:, :n_b] = X[:-1, j, :].T
        A[:, n_b + j] = -tau[j] / gains[j]
        if tau_rate is not None:
            A[:, n_b + n_j + j] = tau_rate[j] / gains[j]
        A /= gains[j] * noise_a[j]
        F += A.T @ A
    return weight * F


def scaled_condition(F: np.ndarray) -> float:
    """cond of the column-scaled matrix whose Gram matrix is F: √(λmax/λmin) of D F D."""
    d = np.sqrt(np.diag(F))
    if np.any(d <= 0):
        return math.inf
    lam = np.linalg.eigvalsh(F / np.outer(d, d))
    return math.sqrt(lam[-1] / lam[0]) if lam[0] > 0 else math.inf


@dataclass(frozen=True)
class Unexcited:
    """A direction of the unknowns no motion of the design excites: the base parameters and
    gains it loads (|component| ≥ LOADS), its κ (√ of λmax/λ of the scaled information) and
    whether it is structural (columns dependent up to rounding: no motion separates them)."""

    names: tuple[str, ...]
    condition: float
    structural: bool
    direction: np.ndarray | None = None  # in the unknowns' own units (θ = D⁻¹ v)
    on_any_motion: bool | None = None  # structural on random motion too (None: not tested)

    def to_text(self) -> str:
        if any(n.startswith("g(") for n in self.names):
            why = ("the drive gains are scaled only by the payload's known mass (eq. 29): "
                   + ("a loaded run is needed, moving these joints with the payload"
                      if self.structural else "the payload hardly loads these joints: a "
                      "heavier or offset payload, or a payload on an outer link, would help"))
            return f"{' + '.join(self.names)} (κ {self.condition:.3g}): {why}"
        if self.on_any_motion is False:
            why = ("no motion found within these limits and this period separates them (on "
                   "motion free of the limits they are): a longer period, looser velocity or "
                   "acceleration limits, or a longer run would help")
            return f"{' + '.join(self.names)} (κ {self.condition:.3g}): {why}"
        why = ("their columns are dependent in this description up to rounding (the base-"
               "parameter reduction kept them apart by a hair, e.g. a URDF angle rounded to "
               "1.5708): no motion separates them, only their combination is identified"
               if self.structural or self.on_any_motion else
               "they move the efforts less than the current noise at these limits (a light "
               "link, a small offset, or a gain the payload hardly loads): a heavier or "
               "offset payload, a longer run or looser limits would help")
        return f"{' + '.join(self.names)} (κ {self.condition:.3g}): {why}"


def _unknown_names(names: Sequence[str] | None, n: int) -> list[str]:
    return list(names) + [f"lag {k}" for k in range(n - len(names))] if names is not None \
        else [f"unknown {k}" for k in range(n)]


def _unexcited(lam: np.ndarray, V: np.ndarray, weak: np.ndarray, names: list[str],
               scale: np.ndarray) -> tuple[Unexcited, ...]:
    out = []
    for k in np.flatnonzero(weak):
        v = V[:, k] / np.abs(V[:, k]).max()
        loads = [names[i] for i in np.argsort(-np.abs(v)) if abs(v[i]) >= LOADS]
        kappa = math.sqrt(lam[-1] / lam[k]) if lam[k] > 0 else math.inf
        out.append(Unexcited(tuple(loads), kappa, not lam[k] > STRUCTURAL * lam[-1],
                             V[:, k] / scale))
    return tuple(out)


def excitation_ratio(F: np.ndarray, u: np.ndarray) -> float:
    """How much information F gives direction ``u`` (unknowns' units) relative to its best
    direction, in the column-scaled coordinates (λ/λmax of an eigen-direction)."""
    d = np.sqrt(np.clip(np.diag(F), 0.0, None))
    d = np.where(d > 0, d, 1.0)
    w = d * u
    top = np.linalg.eigvalsh(F / np.outer(d, d))[-1]
    return float(w @ (F / np.outer(d, d)) @ w / (w @ w) / top) if top > 0 else 0.0


def from_information(F: np.ndarray, chi_b: np.ndarray, gains: np.ndarray,
                     noise_a: np.ndarray, cap: float = MAX_CONDITION,
                     names: Sequence[str] | None = None, strict: bool = False) -> Prediction:
    """The prediction of information F (module docstring). Directions of the scaled F whose κ
    is beyond ``cap`` are not excited: ``strict``, ExcitationError naming them; else the
    prediction is for the rest (their combination held), the unknowns they load get σ = inf,
    and ``unexcited`` names them. The full κ is kept either way (finite up to rounding: what a
    search ranks candidates beyond the cap by)."""
    n_b = chi_b.shape[0]
    d = np.sqrt(np.clip(np.diag(F), 0.0, None))
    d = np.where(d > 0, d, 1.0)  # a column never excited: a zero row/column, a null direction
    lam, V = np.linalg.eigh(F / np.outer(d, d))
    top = max(lam[-1], 0.0)
    kappa = math.sqrt(top / lam[0]) if lam[0] > 0 else math.inf
    weak = ~(lam > top / cap ** 2) if top > 0 else np.ones(lam.shape, bool)
    found = _unexcited(lam, V, weak, _unknown_names(names, F.shape[0]), d)
    if weak.any() and strict:
        raise ExcitationError(
            f"the runs do not determine every gain and base parameter (κ {kappa:.3g} beyond "
            f"{cap:.3g}): " + "; ".join(u.to_text() for u in found)) from None
    keep = ~weak
    cov = (V[:, keep] / lam[keep]) @ V[:, keep].T / np.outer(d, d)
    std = np.sqrt(np.abs(np.diag(cov)))
    loaded = (np.abs(V[:, weak]) >= LOADS * np.abs(V[:, weak]).max(axis=0, initial=0.0)).any(axis=1)
    std = np.where(loaded, math.inf, std)[:n_b + gains.shape[0]]  # without the lag terms
    with np.errstate(divide="ignore", invalid="ignore"):
        base_rel = np.where(np.abs(chi_b) > 1e-12, std[:n_b] / np.abs(chi_b), np.inf)
    kept = math.sqrt(top / lam[keep].min()) if keep.any() else math.inf
    return Prediction(std[n_b:] / gains, std[:n_b], base_rel, kappa,
                      np.asarray(noise_a, float), found, kept)


def predict(robot, runs: Sequence[RunSamples], noise_a: np.ndarray | float,
            chi_b: np.ndarray | None = None, gains: np.ndarray | None = None,
            lag: bool = False, period_s: float | None = None) -> Prediction:
    """σ of the gains and base parameters an IDIM-TLS of ``runs`` reaches (module docstring);
    ``lag``: with the current-loop lag terms, the runs sampled over one period ``period_s``."""
    chi_b = nominal_base_values(robot) if chi_b is None else np.asarray(chi_b, float)
    gains = robot.nominal_gains if gains is None else np.asarray(gains, float)
    noise = np.broadcast_to(np.asarray(noise_a, float), (robot.n_joints,)).copy()
    F = 0.0
    for r in runs:
        X, tau = run_rows(robot, chi_b, gains, r)
        rate = periodic_rate(tau, period_s / r.q.shape[0]) if lag else None
        F = F + information(X, tau, gains, noise if r.noise_a is None else
                            np.asarray(r.noise_a, float), RATE_HZ * r.seconds / r.q.shape[0], rate)
    return from_information(F, chi_b, gains, noise, names=list(robot.names) + [
        f"g({j})" for j in robot.joint_names], strict=True)


def loaded_share(X: np.ndarray, tau: np.ndarray, mass: float) -> np.ndarray:
    """Per joint, the payload's share of the rms torque on a loaded run (its rows X, nominal
    efforts τ, payload ``mass``): what the identification's rule judges (min_payload_share,
    identify/solve/partial.py). A point mass on a joint's axis adds no torque on it."""
    return payload_share(np.sum((mass * X[-1]) ** 2, axis=1), np.sum(tau ** 2, axis=1))


def unloaded(pred: Prediction, share: np.ndarray, low: np.ndarray, joints: Sequence[str]
             ) -> Prediction:
    """``pred`` with the gains ``low`` (those the payload does not scale: the identification
    would refuse them) left out, σ = inf; ``share`` each joint's payload share."""
    return dataclasses.replace(pred, gain_rel_std=np.where(low, math.inf, pred.gain_rel_std),
                               not_loaded=tuple(j for j, x in zip(joints, low) if x),
                               payload_share=share)


def periods_needed(pred: Prediction, periods: int, target: float) -> int:
    """Whole periods per run for every determined gain's σ to reach ``target`` (σ ∝
    1/√duration)."""
    return max(1, math.ceil(periods * (pred.worst_determined_gain() / target) ** 2 - 1e-9))


def noise_from_result(doc: Any, joints: Sequence[str], where: str) -> np.ndarray:
    """(n,) A: the current noise at 1 kHz that weighs like a previous identification's equation
    error (``identify --json``): its residual rms per decimated row (N or N·m) divided by its
    gains, times √n_d (eq. 39 takes σ_ρ per row of the n_d-times decimated equations: r/g at
    rate f/n_d weighs as r/g·√n_d at rate f). The residual holds everything the IDIM does not
    explain — current noise, friction and drive effects the model lacks, encoder steps — which
    on the simulated UR5 outweighs the current noise itself (bench/excitation_design.py).

    The identification weights each joint's rows by the σ of a first, unweighted TLS pass
    (``diagnostics.solver.joint_sigma``, tls.py), which for a quiet joint is above its final
    residual (the UR5's wrist 3: 0.0071 vs 0.0038 N·m), so eq. (39) reports its gain σ up to ~1.8
    times the optimally weighted one. When the result gives those weights, the noise is taken
    proportional to them (scaled to the residuals' pooled size): the prediction is then of what
    ``identify`` reports."""
    from orthoglide_ident.errors import ConfigError

    try:
        names = list(doc["joint_names"])
        res = np.array([float(r) for r in doc.get("residual_rms_per_actuator",  # the motors'
                                                  doc["residual_rms_per_joint"])])
        g = {d["joint"]: float(d["value"]) for d in doc["drive_gains"]}
        diag = doc.get("diagnostics") or {}
        n_d = int(diag.get("decimation") or DEFAULT_DECIMATION)
        weights = (diag.get("solver") or {}).get("joint_sigma")
        if weights is not None and len(weights) == len(res) and min(weights) > 0:
            w = np.array([float(x) for x in weights])
            res = w * math.sqrt(float(np.mean((res / w) ** 2)))
        by_joint = dict(zip(names, res))
        return np.array([by_joint[j] / g[j] for j in joints]) * math.sqrt(n_d)
    except (KeyError, TypeError, ValueError, ZeroDivisionError) as exc:
        raise ConfigError(f"{where}: not an identification result of these joints (needs "
                          f"joint_names, residual_rms_per_joint, drive_gains; {exc!r})") from None
