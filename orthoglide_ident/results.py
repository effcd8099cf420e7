"""Identification results: one dataclass, serialised once to the JSON of docs/design/interfaces.md
and to a table.

Relative standard deviations are fractions (0.002 = 0.2 %σ); the table prints %σ. Two are given:
``rel_std`` the honest one, which also covers residuals correlated from row to row (the forces
the IDIM lacks; identify/uncertainty.py) — the one to trust, and the one the ROS message carries;
``rel_std_paper`` that of the paper's eqs. (38)-(39), which assumes independent errors.
Units: drive gains N/A (N·m/A for a revolute joint: ``gain_units``), payload mass kg, residuals
N or N·m (``effort_units``), base parameters in the SI units of the standard parameters they
regroup (kg, kg·m, kg·m², N·s/m, N; N·m·s/rad, N·m for revolute joints).
"""
from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

from orthoglide_ident.model.locked_joints import LockedJoint
from orthoglide_ident.ticks import UNEVEN_SHARE, StepStats


def _num(x: float) -> float | None:
    """JSON-safe float (inf/NaN become null)."""
    x = float(x)
    return x if math.isfinite(x) else None


def finite_only(doc: Any) -> Any:
    """``doc`` with every non-finite number (NaN, ±inf, numpy's too) as None: what strict JSON
    can hold; the key beside it says what is missing (e.g. a validation's ``note``)."""
    if isinstance(doc, dict):
        return {str(k): finite_only(v) for k, v in doc.items()}
    if isinstance(doc, (list, tuple)):
        return [finite_only(v) for v in doc]
    if isinstance(doc, bool) or doc is None or isinstance(doc, str):
        return doc
    if hasattr(doc, "tolist") and not isinstance(doc, (int, float)):  # numpy arrays, scalars
        return finite_only(doc.tolist())
    if isinstance(doc, float):
        return doc if math.isfinite(doc) else None
    return doc


def json_text(doc: Any) -> str:
    """Strict JSON (RFC 8259: no NaN/Infinity tokens) of a document the product writes."""
    return json.dumps(finite_only(doc), indent=2, allow_nan=False) + "\n"


@dataclass(frozen=True)
class LagEstimate:
    """An identified current-loop lag (identify/columns/drive_terms.py): the drive applies
    g_τ (v_τ - τ v̇_τ)."""

    joint: str
    tau_s: float
    tau_std_s: float

    @property
    def tau_ms(self) -> float:
        return 1e3 * self.tau_s

    @property
    def tau_std_ms(self) -> float:
        return 1e3 * self.tau_std_s

    def to_json(self) -> dict:
        return {"joint": self.joint, "tau_ms": self.tau_ms, "tau_std_ms": self.tau_std_ms}


@dataclass(frozen=True)
class RippleEstimate:
    """An identified ripple (identify/columns/drive_terms.py): a cos(2π q / λ + phase),
    amplitude a in N."""

    joint: str
    wavelength_m: float
    friction: bool
    amplitude_n: float
    amplitude_std_n: float
    phase_rad: float

    @property
    def kind(self) -> str:
        return "friction (sign of velocity)" if self.friction else "force"

    def to_json(self) -> dict:
        return {"joint": self.joint, "wavelength_m": self.wavelength_m, "kind": self.kind,
                "amplitude_n": self.amplitude_n, "amplitude_std_n": self.amplitude_std_n,
                "phase_rad": self.phase_rad}


@dataclass(frozen=True)
class ValidationJoint:
    """One joint's cross-validation figures (identify/validate/cross_validation.py): residual
    and measured rms (N or N·m), their ratio, the residual over the current noise; None where
    the joint has no figure, ``note`` saying why."""

    joint: str
    residual_rms: float | None
    measured_rms: float | None
    relative_error: float | None
    noise_ratio: float | None
    note: str = ""

    def to_json(self) -> dict:
        return {"joint": self.joint, "residual_rms": self.residual_rms,
                "measured_rms": self.measured_rms, "relative_error": self.relative_error,
                "noise_ratio": self.noise_ratio, **({"note": self.note} if self.note else {})}


@dataclass(frozen=True)
class ValidationRow:
    """The cross-validation of the answer on one record not used to identify it (Fig. 5)."""

    bag: str
    joints: tuple[ValidationJoint, ...]
    warnings: tuple[str, ...] = ()

    def to_json(self) -> dict:
        return {"bag": self.bag, "joints": [j.to_json() for j in self.joints],
                "warnings": list(self.warnings)}

    def figures(self, units: Sequence[str], none: str = "-") -> str:
        """Each joint's residual rms (in ``units``) and relative error, ``none`` where a joint
        has no figure: the text report's and the Markdown summary's line."""
        units = list(units) or ["N"] * len(self.joints)
        return ", ".join(
            f"{j.joint} {j.residual_rms:.3g} {u} rms ({100 * j.relative_error:.1f} %)"
            if j.residual_rms is not None and j.relative_error is not None
            else f"{j.joint} {none} ({j.note or 'no figure'})"
            for j, u in zip(self.joints, units))


class ToJson(Protocol):
    """A part of the result that writes its own JSON and is read by no one else here (e.g. the
    IV cross-check's rows, identify/solve/iv_answer.py)."""

    def to_json(self) -> dict: ...


@dataclass(frozen=True)
class SolverInfo:
    """What the solve reports of itself (the JSON's ``diagnostics.solver``): each method fills
    its own fields (identify/solve/answer.py, iv_answer.py); None is absent from the JSON."""

    tls_noisy_columns: str | None = None  # TLS: which columns of W_tot it takes as noisy
    singular_ratio: float | None = None  # TLS: s_c / s_c-1 (eq. 37)
    smallest_singular_values: tuple[float, ...] | None = None
    iv_iterations: int | None = None  # IV: its iterations, from its start
    iv_start: str | None = None
    joint_sigma: tuple[float, ...] | None = None  # per joint, the residual's σ (N or N·m)
    joints_solved: tuple[str, ...] | None = None  # a partial answer: the joints it solved
    lambda_scale: float | None = None  # TLS: the scale λ of the payload column ("lambda")

    def to_json(self) -> dict:
        out = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        out["lambda"] = out.pop("lambda_scale")
        return {k: list(v) if isinstance(v, tuple) else v for k, v in out.items()
                if v is not None}


@dataclass(frozen=True)
class RecordReport:
    """One record's entry of ``diagnostics.bags`` (identify/diagnostics.bag_report): what
    pairing and segmenting kept and dropped (identify/records/segments.SegmentReport's figures,
    field for field, as they were when the record was observed), which topics and fields
    carried q and the current, and the equations it gave each joint."""

    period_s: float
    steps: StepStats | None
    velocity: str
    current_sampling: str
    current_sampling_why: str
    current_shift_ms: float
    filter_cutoff_hz: float
    decimation: int
    decimation_cutoff_hz: float
    n_joint_states: int
    n_current_reference: int
    n_paired: int
    n_unpaired_joint_states: int
    n_unpaired_current_reference: int
    n_duplicate_stamps: int
    n_nonfinite_dropped: int
    n_missing_ticks: int
    n_gaps: int
    n_segments: int
    n_short_segments_dropped: int
    n_samples_in_short_segments: int
    n_used: int
    n_reversal_bridged: int
    n_reversal_unbridged: int
    n_not_repeating: int
    reordered: tuple[str, ...]
    bag: str
    condition: str | None
    payload_mass: float
    equations_per_joint: tuple[int, ...]
    sources: str = ""  # the topics and fields q and the current came from ("" not said)

    def to_json(self) -> dict:
        out = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        out["steps"] = None if self.steps is None else dataclasses.asdict(self.steps)
        out["reordered"], out["equations_per_joint"] = list(self.reordered), \
            list(self.equations_per_joint)
        if not self.sources:
            del out["sources"]
        return out


@dataclass(frozen=True)
class SpectrumPeak:
    """The strongest position-periodic component of a joint's residual
    (identify/solve/uncertainty.spectrum_peaks): amplitude and the spectrum's median, N."""

    joint: str
    wavelength_m: float
    amplitude_n: float
    median_n: float
    sign_modulated: bool  # a friction ripple (turns with the velocity) rather than a force ripple

    @property
    def kind(self) -> str:
        return "friction (sign of velocity)" if self.sign_modulated else "force"

    def to_json(self) -> dict:
        return {"joint": self.joint, "wavelength_m": self.wavelength_m,
                "amplitude_n": self.amplitude_n, "median_n": self.median_n, "kind": self.kind}


@dataclass(frozen=True)
class ResidualDiagnostics:
    """What the honest σ saw in the residual (identify/solve/uncertainty.diagnose; the JSON's
    ``diagnostics.uncertainty``): its autocorrelation per joint against white noise after the
    decimation filter, the gains' σ over eqs. (38)-(39)'s, the residual at current reversals
    over elsewhere, the position-periodic peaks. Per joint by name."""

    method: str
    blocks: int
    block_s: float
    lags: int
    autocorrelation: dict[str, list[float]]  # lags 1..lags
    autocorrelation_white: tuple[float, ...]
    notes: tuple[str, ...]
    slow_ratio: dict[str, float]
    gain_sigma_inflation: dict[str, float] | None = None  # gains identified (not WLS)
    reversal_residual_ratio: dict[str, float | None] | None = None
    position_spectrum_peaks: tuple[SpectrumPeak, ...] = ()

    def to_json(self) -> dict:
        out = {"method": self.method, "blocks": self.blocks, "block_s": self.block_s,
               "lags": self.lags, "autocorrelation": self.autocorrelation,
               "autocorrelation_white": list(self.autocorrelation_white),
               "notes": list(self.notes), "slow_ratio": self.slow_ratio}
        if self.gain_sigma_inflation is not None:
            out["gain_sigma_inflation"] = self.gain_sigma_inflation
        if self.reversal_residual_ratio is not None:
            out["reversal_residual_ratio"] = self.reversal_residual_ratio
        out["position_spectrum_peaks"] = [p.to_json() for p in self.position_spectrum_peaks]
        return out


@dataclass(frozen=True)
class Diagnostics:
    """What an identification reports beside its numbers (the JSON's ``diagnostics``,
    identify/diagnostics.finish_result): samples and equations, the solver's figures, each
    record's report, the time each step took and the options it ran with."""

    samples_used: int
    samples_dropped: int
    segments: int
    rows: int
    solver: SolverInfo
    decimation: int
    bags: tuple[RecordReport, ...]
    timings_s: dict[str, float]  # by step name; the offline path adds its reading's
    options: dict[str, Any]  # the options document (identify/options.py's keys)

    def to_json(self) -> dict:
        return {"samples_used": self.samples_used, "samples_dropped": self.samples_dropped,
                "segments": self.segments, "rows": self.rows, "solver": self.solver.to_json(),
                "decimation": self.decimation, "bags": [b.to_json() for b in self.bags],
                "timings_s": self.timings_s, "options": self.options}


@dataclass
class EssentialStep:
    """One cancellation of the essential reduction (identify/solve/essential.py) tried: the base
    parameter, its %σ then, and what cancelling it cost."""

    index: int  # base-parameter index
    name: str
    rel_std: float  # its relative std (fraction) in the model it was cancelled from
    accepted: bool
    residual_change: float  # weighted residual norm vs the base model's, fraction (cumulative)
    residual_rms: list[float]  # per joint, N, with the cancellation
    shift: list[float]  # protected quantities (gains or payload masses) vs base, fraction
    reason: str = ""

    def to_json(self) -> dict:
        return {"parameter": self.name, "rel_std": float(self.rel_std) if math.isfinite(
                self.rel_std) else None, "cancelled": self.accepted,
                "residual_change": float(self.residual_change),
                "residual_rms": [float(x) for x in self.residual_rms],
                "shift": [float(x) for x in self.shift], "reason": self.reason}


@dataclass(frozen=True)
class EssentialReduction:
    """How the essential parameters were reached (Sect. 5.2): the essential result's
    ``diagnostics`` in the JSON."""

    method: str  # options.essential_method
    stopped_because: str
    ratios: tuple[float, ...]  # max/min %σ at each step
    tolerance: tuple[float, ...]  # of the protected quantities, fraction
    steps: tuple[EssentialStep, ...]

    def to_json(self) -> dict:
        return {"method": self.method, "stopped_because": self.stopped_because,
                "ratios": list(self.ratios), "tolerance": list(self.tolerance),
                "steps": [st.to_json() for st in self.steps]}


def lag_text(current_lag: Sequence[LagEstimate]) -> str:
    """The identified current-loop lags (``IdentificationResult.current_lag``) as one line:
    "q11 0.102 ms (σ 0.032), ..." (the text table, the log and the identify service's reply)."""
    return ", ".join(f"{x.joint} {x.tau_ms:.3f} ms (σ {x.tau_std_ms:.2g})" for x in current_lag)


def _unit(units: list[str], default: str) -> str | list[str]:
    """One unit when every joint shares it (the Orthoglide's N/A), else the list per joint."""
    if not units:
        return default
    return units[0] if len(set(units)) == 1 else list(units)


def _pct(x: float | None) -> str:
    """A relative std as a 7-wide percentage; - when unknown, >1000% when meaningless."""
    if x is None or not math.isfinite(x):
        return "      -"
    return f"{100 * x:7.3g}" if x < 10 else " >1000%"


@dataclass
class Estimate:
    """One identified quantity: value, relative std (fraction), the expression it stands for."""

    name: str
    value: float
    rel_std: float  # honest (covers correlated residuals)
    expression: str = ""
    rel_std_paper: float | None = None  # eqs. (38)-(39)
    # a drive gain the data do not fix (a partial answer): value and σ NaN, and why / what to record
    determined: bool = True
    reason: str = ""

    def to_json(self) -> dict[str, Any]:
        return {"name": self.name, "value": _num(self.value), "rel_std": _num(self.rel_std),
                "rel_std_paper": None if self.rel_std_paper is None else _num(self.rel_std_paper),
                "expression": self.expression}


@dataclass
class PayloadMass:
    """Payload mass m_7: known (weighed, TLS scale) or estimated (WLS)."""

    value: float
    rel_std: float
    known: bool
    tagged: float | None = None  # the mass written in the bag tag, kg
    bags: list[str] = field(default_factory=list)
    rel_std_paper: float | None = None  # estimated (WLS): eq. (27)'s, next to the honest rel_std

    def to_json(self) -> dict[str, Any]:
        return {"value": _num(self.value), "rel_std": _num(self.rel_std),
                "rel_std_paper": None if self.rel_std_paper is None else _num(self.rel_std_paper),
                "known": self.known,
                "tagged": None if self.tagged is None else _num(self.tagged), "bags": self.bags}


@dataclass
class PayloadParameters:
    """A payload whose CoM and inertia were identified with the robot (paper Sect. 4.3): its
    identified combinations (σ in their units), and the CoM / inertia about it where the data
    determine them (None where not), in ``frame``'s axes; ``known``: what was known of it."""

    frame: str
    mass: float  # kg, weighed (TLS) or estimated (WLS)
    known: str  # "mass" | "com"
    parameters: list[Estimate]  # χ_ul: name, value, rel_std, expression
    std: list[float]  # σ of each parameter, in its unit
    com: list[float | None]  # m
    com_std: list[float | None]
    inertia: list[float] | None = None  # Ixx Ixy Ixz Iyy Iyz Izz about the CoM, kg·m²
    inertia_std: list[float] | None = None

    def to_json(self) -> dict[str, Any]:
        return {"frame": self.frame, "mass": _num(self.mass), "known": self.known,
                "parameters": [dict(p.to_json(), std=_num(s))
                               for p, s in zip(self.parameters, self.std)],
                "com": [None if c is None else _num(c) for c in self.com],
                "com_std": [None if c is None else _num(c) for c in self.com_std],
                "inertia": None if self.inertia is None else [_num(x) for x in self.inertia],
                "inertia_std": None if self.inertia_std is None
                else [_num(x) for x in self.inertia_std]}

    def summary(self) -> str:
        """One line: the identified CoM (mm, σ) at the frame, "-" where not determined."""
        com = ", ".join("-" if c is None else f"{1e3 * c:+.1f} ± {1e3 * s:.1f}"
                        for c, s in zip(self.com, self.com_std))
        what = f"CoM ({com}) mm" if self.known == "mass" else "inertia"
        return f"payload at {self.frame}: {what} identified ({len(self.parameters)} parameters)"

    def text_lines(self) -> list[str]:
        what = {"mass": "its mass known, CoM and inertia identified",
                "com": "its mass and CoM known, inertia identified"}[self.known]
        out = [f"payload at {self.frame} ({what}, Sect. 4.3):"]
        com = ", ".join(f"{a} {1e3 * c:+.2f} ± {1e3 * s:.2f}" if c is not None else f"{a} -"
                        for a, c, s in zip("xyz", self.com, self.com_std))
        if self.known == "mass":
            out.append(f"  centre of mass (mm, not determined: -): {com}")
        if self.inertia is not None and self.inertia_std is not None:
            out.append("  inertia about it (kg·m²): " + ", ".join(
                f"{n} {v:.4g} ± {e:.2g}" for n, v, e in
                zip(("Ixx", "Ixy", "Ixz", "Iyy", "Iyz", "Izz"), self.inertia, self.inertia_std)))
        out.append(
            f"  identified (first moments kg·m, inertia kg·m² at the origin of {self.frame}):"
        )
        for p, sd in zip(self.parameters, self.std):
            expr = f" = {p.expression}" if p.expression and p.expression != p.name else ""
            out.append(f"    {p.name:<8} {p.value:+.6g} ± {sd:.3g}{expr}")
        return out


@dataclass
class IdentificationResult:
    """What ``identify`` found; ``to_json()`` is the document of docs/design/interfaces.md."""

    method: str  # a name of identify/solve/methods.METHODS (its row names the result)
    joint_names: list[str]
    drive_gains: list[Estimate]  # name = joint name
    # the method's gains_given (identify/solve/methods.METHODS): True for WLS (gains were an
    # input, rel_std 0, the payload masses estimated)
    drive_gains_given: bool
    parameters: list[Estimate]
    payload_mass: PayloadMass | None
    payloads: list[PayloadMass]
    condition_number: float
    residual_rms: list[float]  # per joint (per motor behind a transmission), N or N·m
    bags: list[str]
    robot: str  # RobotModel.name: every result is of the robot it was identified on
    # the first line of the text report: the method's title in methods.METHODS (set with method)
    title: str = ""
    gain_units: list[str] = field(default_factory=list)  # per joint: N/A or N·m/A (empty: N/A)
    effort_units: list[str] = field(default_factory=list)  # per joint: N or N·m (empty: N)
    nominal_gains: list[float] = field(default_factory=list)  # the manufacturer's, per joint
    # joints of the description fixed before anything else (model/locked_joints.py)
    locked_joints: list[LockedJoint] = field(default_factory=list)
    # what the identification reports beside its numbers (identify/diagnostics.finish_result)
    diagnostics: Diagnostics | None = None
    # the honest σ's figures (identify/solve/uncertainty.diagnose): "uncertainty" in diagnostics
    uncertainty: ResidualDiagnostics | None = None
    # the IV cross-check of a TLS answer, per joint (identify/solve/iv_answer.py): "cross_check_iv"
    cross_check: list[ToJson] | None = None
    # an essential result: how the reduction got there (its JSON's "diagnostics")
    reduction: EssentialReduction | None = None
    essential: IdentificationResult | None = None
    removed: list[str] = field(default_factory=list)  # cancelled base parameters (essential)
    # position-periodic forces found in the residual and modelled (identify/drive_terms.py)
    ripple: list[RippleEstimate] = field(default_factory=list)
    # the current loops' lags, identified from periodic records (identify/current_lag.py)
    current_lag: list[LagEstimate] = field(default_factory=list)
    validation: list[ValidationRow] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    # In-memory extras for plots (report.py); not serialised.
    validation_details: list[Any] = field(default_factory=list, repr=False, compare=False)
    observations: list[Any] = field(default_factory=list, repr=False, compare=False)
    # χ over the observations' columns: with the drive terms' coefficients in them (lag, ripple)
    observations_chi: Any = field(default=None, repr=False, compare=False)
    # covariance over [base parameters, gains (TLS) or payload masses (WLS)], honest (in memory)
    covariance: Any = field(default=None, repr=False, compare=False)
    covariance_paper: Any = field(default=None, repr=False, compare=False)  # eqs. (39), (27)
    # behind a transmission: the residual of each joint, joint-side (Nᵀ ε), and their names
    residual_rms_joint_side: list[float] | None = None
    residual_joint_names: list[str] = field(default_factory=list)
    # physically consistent standard parameters (identify/consistency.ConsistencyResult)
    consistency: Any = field(default=None, repr=False, compare=False)
    # the payload's identified CoM and inertia when only its mass was known (Sect. 4.3)
    payload: PayloadParameters | None = None

    @property
    def residual_rms_total(self) -> float:
        """Over the joints with a residual (not those whose gain is not determined)."""
        rs = [r for r in self.residual_rms if math.isfinite(r)]
        return math.sqrt(sum(r * r for r in rs) / max(len(rs), 1))

    @property
    def record_reports(self) -> tuple[RecordReport, ...]:
        """Each record's report (``diagnostics.bags``); none before the result is finished."""
        return () if self.diagnostics is None else self.diagnostics.bags

    @property
    def complete(self) -> bool:
        """Every drive gain determined: what the CTC path takes (a partial answer is not)."""
        return all(g.determined for g in self.drive_gains)

    def not_determined_text(self) -> str:
        """The gains a partial answer leaves out and why, one line (the reply, the log)."""
        return "; ".join(f"{g.name} not determined: {g.reason}" for g in self.drive_gains
                         if not g.determined)

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "method": self.method,
            "robot": self.robot,
            "joint_names": list(self.joint_names),
            **({"locked_joints": [lj.to_json() for lj in self.locked_joints]}
               if self.locked_joints else {}),
            "drive_gains": [{"joint": g.name, "value": _num(g.value), "rel_std": _num(g.rel_std),
                             "rel_std_paper": None if g.rel_std_paper is None
                             else _num(g.rel_std_paper), **self._nominal(i),
                             "determined": g.determined,
                             **({} if g.determined else {"reason": g.reason})}
                            for i, g in enumerate(self.drive_gains)],
            "complete": self.complete,
            "drive_gains_given": self.drive_gains_given,
            "parameters": [p.to_json() for p in self.parameters],
            "payload_mass": None if self.payload_mass is None else self.payload_mass.to_json(),
            "payloads": [p.to_json() for p in self.payloads],
            **({"payload": self.payload.to_json()} if self.payload is not None else {}),
            "condition_number": _num(self.condition_number),
            "residual_rms": _num(self.residual_rms_total),
            # joint-side (Nᵀ ε behind a transmission), motor-side beside it (DESIGN §10)
            "residual_rms_per_joint": [_num(r) for r in (self.residual_rms
                                                         if self.residual_rms_joint_side is None
                                                         else self.residual_rms_joint_side)],
            "residual_rms_per_actuator": [_num(r) for r in self.residual_rms],
            **({"residual_joint_names": self.residual_joint_names}
               if self.residual_joint_names else {}),
            "bags": list(self.bags),
            "units": {"drive_gains": _unit(self.gain_units, "N/A"), "payload_mass": "kg",
                      "residual_rms": _unit(self.effort_units, "N"),
                      "rel_std": "fraction (0.01 = 1 %)"},
            "rel_std": "honest: covers residuals correlated from row to row (largest of eqs. "
                       "(38)-(39), a stationary-correlation and a block sandwich); rel_std_paper: "
                       "eqs. (38)-(39), independent errors",
            "warnings": list(self.warnings),
        }
        if self.ripple:
            out["ripple"] = [r.to_json() for r in self.ripple]
        if self.current_lag:
            out["current_lag"] = [x.to_json() for x in self.current_lag]

        if self.removed:
            out["removed"] = list(self.removed)
        if self.essential is not None:
            out["essential"] = self.essential.to_json()
        if self.validation:
            out["validation"] = [v.to_json() for v in self.validation]
        if self.consistency is not None:
            out["standard_parameters"] = self.consistency.standard_parameters()
            out["consistency"] = self.consistency.to_json()
        diagnostics = self._diagnostics_json()
        if diagnostics:
            out["diagnostics"] = diagnostics
        return out

    def _diagnostics_json(self) -> dict[str, Any]:
        if self.reduction is not None:
            return self.reduction.to_json()
        out = {} if self.diagnostics is None else self.diagnostics.to_json()
        if self.uncertainty is not None:
            out["uncertainty"] = self.uncertainty.to_json()
        if self.cross_check is not None:
            out["cross_check_iv"] = [c.to_json() for c in self.cross_check]
        return out

    def _nominal(self, i: int) -> dict[str, Any]:
        """The manufacturer's gain of joint i and the identified one's ratio to it."""
        if i >= len(self.nominal_gains):
            return {}
        g0 = self.nominal_gains[i]
        return {"nominal": _num(g0), "ratio_to_nominal": _num(self.drive_gains[i].value / g0)}

    def write_json(self, path: str | Path) -> None:
        Path(path).write_text(json_text(self.to_json()))

    def message_fields(self) -> dict[str, Any]:
        """The fields of orthoglide_msgs/IdentifiedParameters (header and stamp excluded)."""
        return {
            "method": self.method,
            "joint_names": list(self.joint_names),
            "drive_gains": [float(g.value) for g in self.drive_gains],  # NaN: not determined
            "drive_gains_rel_std": [float(g.rel_std) for g in self.drive_gains],
            "drive_gains_determined": [bool(g.determined) for g in self.drive_gains],
            "drive_gains_reason": [g.reason for g in self.drive_gains],
            "names": [p.name for p in self.parameters],
            "values": [float(p.value) for p in self.parameters],
            "rel_std": [float(p.rel_std) if math.isfinite(p.rel_std) else -1.0
                        for p in self.parameters],
            "payload_mass": float(self.payload_mass.value) if self.payload_mass else 0.0,
            "residual_rms": float(self.residual_rms_total),
            "condition_number": float(self.condition_number)
            if math.isfinite(self.condition_number) else -1.0,
            "source_bags": list(self.bags),
        }

    # ------------------------------------------------------------------ text
    def to_text(self) -> str:
        """A readable table; with essential parameters, base and essential side by side."""
        ess = self.essential
        lines = self._header_lines()
        lines.extend(self._table_lines())
        lines.append(
            "%σ: covers residuals correlated from row to row (the largest of eqs. (38)-(39), "
            "a stationary-correlation and a block sandwich); %σ eq39: the paper's eqs. "
            "(38)-(39), independent errors"
        )
        lines.extend(self._payload_lines())
        lines.append(f"condition number (scaled W): {self.condition_number:.4g}")
        lines.append(f"residual rms ({self._units(self.effort_units, 'N')}): " + ", ".join(
            f"{j} {r:.4g}" if math.isfinite(r) else f"{j} -"
            for j, r in zip(self.joint_names, self.residual_rms)))
        lines.extend(self._drive_and_input_lines())
        lines.extend(self._residual_lines())
        if ess is not None:
            lines.extend(self._essential_lines(ess))
        if self.consistency is not None:
            lines.extend(self.consistency.text_lines(self._units(self.effort_units, "N")))
        lines.extend(self._record_lines())
        for wmsg in self.warnings:
            lines.append(f"warning: {wmsg}")
        return "\n".join(lines)

    def _payload_lines(self) -> list[str]:
        """The payload masses (known or estimated) and a payload's identified unknowns."""
        lines: list[str] = []
        for pm in self.payloads:
            what = "known (weighed)" if pm.known else "estimated"
            tag = "" if pm.tagged is None or pm.known else f", tagged {pm.tagged:.4g} kg"
            paper = (
                ""
                if pm.rel_std_paper is None
                else f" (eq. 27: ± {_pct(pm.rel_std_paper).strip()} %)"
            )
            lines.append(
                f"payload mass m_7: {pm.value:.5g} kg ± {_pct(pm.rel_std).strip()} %{paper} "
                f"({what}{tag})"
            )
        if self.payload is not None:
            lines.extend(self.payload.text_lines())
        return lines

    def _drive_and_input_lines(self) -> list[str]:
        """The drive terms modelled (lag, ripple), the locked joints, and how the inputs were
        read (a torque effort, the recorded sources)."""
        lines: list[str] = []
        d = self.diagnostics
        if self.current_lag:
            lines.append("current-loop lag modelled: " + lag_text(self.current_lag))
        if self.locked_joints:  # model/locked_joints.py
            lines.append("locked joints: " + ", ".join(
                f"{lj.name} = {lj.value:.6g} {lj.unit} ({lj.reason()})"
                for lj in self.locked_joints))
        d = self.diagnostics
        if d is not None and d.options.get("effort_unit") == "torque":
            lines.append("the recorded effort is a torque/force, turned into a current with the "
                         "nominal gains: the gains' ratio to them (the effort's calibration) is "
                         + ", ".join(f"{g.name} {g.value / g0:.5f}" for g, g0
                                     in zip(self.drive_gains, self.nominal_gains)))
        sources = sorted({b.sources for b in self.record_reports if b.sources})
        for src in sources:
            lines.append(f"recorded: {src}")
        for r in self.ripple:
            lines.append(
                f"ripple modelled: {r.joint} ±{r.amplitude_n:.3g} N (σ "
                f"{r.amplitude_std_n:.2g} N) at a {1e3 * r.wavelength_m:.1f} mm period of "
                f"its position, {r.kind}"
            )
        return lines

    def _record_lines(self) -> list[str]:
        """Cross-validation, the samples used and each record's uneven time base or recorded
        velocity."""
        lines: list[str] = []
        d = self.diagnostics
        for v in self.validation:
            lines.append(f"cross-validation on {v.bag}: " + v.figures(self.effort_units))
        if d is not None:
            lines.append(f"samples: {d.samples_used} used, {d.samples_dropped} dropped,"
                         f" {d.segments} segments, {d.rows} equations after "
                         f"decimation by {d.decimation}")
        for b in self.record_reports:  # what was done with an uneven clock, a recorded velocity
            mean_s, off_grid = (b.steps.mean_s, b.steps.off_grid) if b.steps else (0.0, 0.0)
            if off_grid > UNEVEN_SHARE or b.velocity.startswith("rec"):
                lines.append(
                    f"time base {b.bag}: {mean_s and 1 / mean_s:.1f} "
                    f"Hz mean, {100 * off_grid:.1f} % of the steps off "
                    "the median grid: derivatives, filters and the zero-order hold on "
                    f"each sample's stamp; filter {b.filter_cutoff_hz:.4g} Hz, "
                    f"decimation by {b.decimation}; velocity {b.velocity}"
                )
        return lines

    @staticmethod
    def _units(units: list[str], default: str) -> str:
        """The units of a per-joint column for a heading: "N/A", or "N/A/N·m/A" when mixed."""
        u = _unit(units, default)
        return u if isinstance(u, str) else "/".join(dict.fromkeys(u))

    def _header_lines(self) -> list[str]:
        lines = [self.title or self.method]
        variant = None if self.diagnostics is None else self.diagnostics.solver.tls_noisy_columns
        if variant:  # only a TLS solve says which columns it takes as noisy
            lines.append({"currents": "mixed LS-TLS: W exact, errors in the current references",
                          "all": "TLS of eqs. (35)-(36): errors in every column of W_tot",
                          "per-joint": "mixed LS-TLS, each current column scaled to its noise"}
                         .get(variant, variant))
        lines.append(f"bags: {', '.join(self.bags)}")
        lines.append("")
        return lines

    def _table_lines(self) -> list[str]:
        """Gains and base parameters, with the essential model's column when there is one."""
        ess = self.essential
        w = max([len(p.name) for p in self.parameters] + [12]
                + [len(f"g_tau {g.name}") for g in self.drive_gains])
        hdr = (f"  {'parameter':<{w}} {'value' if ess is None else 'base':>12} {'%σ':>7} "
               f"{'%σ eq39':>7}")
        if ess is not None:
            hdr += f"   {'essential':>12} {'%σ':>7}"
        lines = [f"drive gains ({self._units(self.gain_units, 'N/A')})"
                 + (" — given" if self.drive_gains_given else ""), hdr]
        eg = {g.name: g for g in ess.drive_gains} if ess else {}
        for g in self.drive_gains:
            if not g.determined:
                lines.append(f"  g_tau {g.name:<{w - 6}} not determined: {g.reason}")
                continue
            row = (f"  g_tau {g.name:<{w - 6}} {g.value:12.6g} {_pct(g.rel_std)} "
                   f"{_pct(g.rel_std_paper)}")
            if ess is not None:
                e = eg[g.name]
                row += f"   {e.value:12.6g} {_pct(e.rel_std)}"
            lines.append(row)
        lines.append("")
        lines.append("base parameters" + (" (— = cancelled as non-essential)" if ess else ""))
        lines.append(hdr + "   expression")
        ep = {p.name: p for p in ess.parameters} if ess else {}
        for p in self.parameters:
            row = f"  {p.name:<{w}} {p.value:12.6g} {_pct(p.rel_std)} {_pct(p.rel_std_paper)}"
            if ess is not None:
                e = ep.get(p.name)
                row += (f"   {e.value:12.6g} {_pct(e.rel_std)}" if e else f"   {'—':>12} {'':>7}")
            lines.append(row + (f"   {p.expression}" if p.expression else ""))
        lines.append("")
        return lines

    def _residual_lines(self) -> list[str]:
        u = self.uncertainty
        if u is None:
            return []
        ac, white = u.autocorrelation, u.autocorrelation_white
        out = []
        if ac and white:
            out.append("residual autocorrelation at lags 1-3 (rows): " + "; ".join(
                f"{j} " + " ".join(f"{x:.2f}" for x in v[:3]) for j, v in ac.items())
                + "  (white noise after the decimation filter: "
                + " ".join(f"{x:.2f}" for x in white[:3]) + ")")
        inf = u.gain_sigma_inflation
        if inf:
            out.append("σ of the gains / eqs. (38)-(39): " + ", ".join(
                f"{j} {x:.2f}" for j, x in inf.items())
                + f"  ({u.blocks} blocks of {u.block_s:g} s)")
        where = " (of the model without the ripple columns)" if self.ripple else ""
        for pk in u.position_spectrum_peaks:
            out.append(
                f"residual vs position{where}: {pk.joint} ±{pk.amplitude_n:.2g} N at a "
                f"{1e3 * pk.wavelength_m:.1f} mm period ({pk.kind}; spectrum median "
                f"{pk.median_n:.2g} N)"
            )
        return out

    def _essential_lines(self, ess: IdentificationResult) -> list[str]:
        d = ess.reduction or EssentialReduction("paper", "", (), (), ())
        out = [f"essential parameters ({d.method}): {len(ess.parameters)} kept of "
               f"{len(self.parameters)} ({d.stopped_because}); residual rms "
               f"({self._units(self.effort_units, 'N')}): "
               + ", ".join(f"{j} {r:.4g}" for j, r in zip(ess.joint_names, ess.residual_rms))]
        steps = d.steps
        if not steps:
            return out
        prot = "m_7" if self.drive_gains_given else "g_tau"
        n_prot = len(steps[0].shift) or 3
        labels = ([f"{p.tagged:g}kg" for p in self.payloads] if self.drive_gains_given
                  else list(self.joint_names))[:n_prot]
        tol = d.tolerance
        out.append(f"what each cancellation cost (cumulative from the base model; tolerance on "
                   f"{prot}: " + ", ".join(f"{100 * t:.2f} %" for t in tol) + "):")
        w = max(len(s.name) for s in steps)
        out.append(f"  {'':<4} {'parameter':<{w}} {'%σ':>7} {'residual':>9} "
                   + " ".join(f"{'Δ' + prot + ' ' + lab:>14}" for lab in labels) + "  ")
        for st in steps:
            mark = "x" if st.accepted else "kept"
            res = st.residual_change
            rtxt = f"{100 * res:+8.2f}%" if res is not None and math.isfinite(res) else f"{'-':>9}"
            shifts = " ".join(f"{100 * x:+13.3f}%" for x in st.shift) if st.shift else ""
            why = "" if st.accepted else f"  {st.reason}"
            out.append(f"  {mark:<4} {st.name:<{w}} {_pct(st.rel_std)} {rtxt} "
                       f"{shifts}{why}")
        return out
