"""The consistency step's report (fit.py holds its numerics): the JSON's ``consistency`` and
``standard_parameters``, the text table beside the unconstrained answer, the message fields of
the consistent set, and the direct-dynamic validation's figures (validate/direct_dynamics.py).
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from orthoglide_ident.identify.consistency.pseudo_inertia import (
    AT_PRIOR_TOL,
    MARGIN,
    RELAXATION_TOL,
    min_eigenvalues,
)
from orthoglide_ident.model.inertia import at_com


@dataclass(frozen=True)
class DirectDynamicsJoint:
    """One joint's position error of the forward-simulated model, its drift, their ratio."""

    joint: str
    unit: str  # m or rad
    rms_error: float
    drift_rms: float
    relative: float  # rms_error / drift_rms (inf with no drift)

    def to_json(self) -> dict:
        return {"joint": self.joint, "unit": self.unit, "rms_error": self.rms_error,
                "drift_rms": self.drift_rms, "relative": self.relative}


@dataclass(frozen=True)
class DirectDynamics:
    """The consistent model forward-simulated on one record under its recorded currents:
    ``windows`` windows of ``horizon_s`` (None: no window ran, ``engine`` says why)."""

    bag: str
    engine: str
    windows: int
    joints: tuple[DirectDynamicsJoint, ...] = ()
    horizon_s: float | None = None

    def to_json(self) -> dict:
        return {"bag": self.bag, "engine": self.engine, "windows": self.windows,
                **({} if self.horizon_s is None else {"horizon_s": self.horizon_s}),
                "joints": [j.to_json() for j in self.joints]}

    def text(self) -> str:
        """One line of the text output."""
        joints = ", ".join(f"{j.joint} {j.rms_error:.3g} {j.unit} ({100 * j.relative:.1f} %"
                           f" of the drift)" for j in self.joints)
        return (f"  direct dynamics on {self.bag} ({self.engine}, {self.windows} windows of "
                f"{self.horizon_s or 0:g} s from the measured state under the recorded "
                f"currents): position error rms {joints}")


@dataclass(frozen=True)
class BodyInertial:
    """A body of the consistent answer: mass kg, centre of mass (3,) m and inertia about it
    (Ixx Ixy Ixz Iyy Iyz Izz) kg·m², in the body's frame (the JSON's ``standard_parameters``)."""

    body: str
    frame: str
    mass: float
    com: tuple[float, ...]
    inertia: tuple[float, ...]

    def to_json(self) -> dict:
        return {"body": self.body, "frame": self.frame, "mass": self.mass,
                "com": list(self.com), "inertia": list(self.inertia)}


@dataclass(frozen=True)
class BodyConsistency:
    """A body: whether the unconstrained answer was consistent (its pseudo-inertia's least
    relaxation t_k, scaled), the consistent answer's least eigenvalue, the parameters the data
    left at the prior."""

    body: str
    consistent_unconstrained: bool
    relaxation: float
    min_eigenvalue: float
    at_prior: tuple[str, ...]

    def to_json(self) -> dict:
        return {"body": self.body, "consistent_unconstrained": self.consistent_unconstrained,
                "relaxation": self.relaxation, "min_eigenvalue": self.min_eigenvalue,
                "at_prior": list(self.at_prior)}


@dataclass(frozen=True)
class BoundConsistency:
    """An inequality (ia, fv, fs ≥ 0, a bounding sphere): its value at the answer (scaled,
    ≥ 0) and whether the unconstrained answer needed it relaxed."""

    name: str
    value: float
    relaxation: float
    consistent_unconstrained: bool

    def to_json(self) -> dict:
        return {"name": self.name, "value": self.value, "relaxation": self.relaxation,
                "consistent_unconstrained": self.consistent_unconstrained}


class FitFigures(Protocol):
    """What the report reads of one consistent answer (fit.Fit)."""

    chi_b: np.ndarray
    solve_s: float
    status: str


class ConsistencyReport:
    """The formatting of a consistency step's answer: the base of fit.ConsistencyResult, whose
    fields it reads (the fit's numerics there, their report here)."""

    def inertials(self) -> list[BodyInertial]:
        """Per body of the answer: its mass, centre of mass and inertia about it."""
        out = []
        for body in self.lay.bodies:
            m, c, I_c = at_com(self.answer.chi_st[list(body.inertial)])
            out.append(BodyInertial(body.name, body.frame, m, tuple(float(x) for x in c),
                                    tuple(float(x) for x in I_c)))
        return out

    def standard_parameters(self) -> list[dict]:
        """The JSON's ``standard_parameters``: :meth:`inertials`."""
        return [b.to_json() for b in self.inertials()]

    def bodies(self) -> list[BodyConsistency]:
        chi = self.answer.chi_st
        eig = min_eigenvalues(self.lay, chi)
        r = self.lay.B_s @ (chi / self.lay.scale) - self.lay.b_s
        out = []
        for k, body in enumerate(self.lay.bodies):
            idx = list(body.inertial)
            stayed = tuple(self.lay.names[i] for i in idx
                           if not self.identifiable[i] and abs(r[i]) < AT_PRIOR_TOL)
            out.append(BodyConsistency(body.name,
                                       bool(self.findings.relaxation[k] <= RELAXATION_TOL),
                                       float(self.findings.relaxation[k]), float(eig[k]), stayed))
        return out

    def bounds(self) -> list[BoundConsistency]:
        """The inequalities at the answer."""
        C, what = self.lay.inequalities()
        value = C @ (self.answer.chi_st / self.lay.scale)
        return [BoundConsistency(w, float(v), float(u), bool(u <= RELAXATION_TOL))
                for w, v, u in zip(what, value, self.findings.bound_relaxation)]

    def summary(self) -> str:
        """One line: consistent or not (which bodies, which bounds), what enforcing it cost."""
        bad = [b.body for b in self.bodies() if not b.consistent_unconstrained]
        bad += [b.name for b in self.bounds() if not b.consistent_unconstrained]
        head = ("the unconstrained answer is physically consistent" if not bad else
                "the unconstrained answer is not physically consistent (" + ", ".join(bad) + ")")
        rms = self.residual_rms
        out = (f"{head}; projection: d² {self.projection_d2:.3g} over {len(self.base_names)} "
               f"base parameters, residual "
               f"{100 * _increase(rms['projection'], rms['unconstrained']):+.2f} %")
        if self.identified is not None:
            out += (f"; identified under the constraints: residual "
                    f"{100 * _increase(rms['identification'], rms['unconstrained']):+.2f} %, "
                    f"d² {self.identified_d2:.3g}")
        return out + f" ({self.seconds:.2f} s)"

    def text_lines(self, effort_unit: str = "N") -> list[str]:
        """The side-by-side table of the text output: base parameters unconstrained and
        consistent, the gains, the residuals, and the bodies of the consistent answer."""
        proj = self._fit_json(self.projection, self.projection_d2, self.residual_rms["projection"])
        lines = ["", "physical consistency (pseudo-inertias ⪰ 0, ia, fv, fs ≥ 0): "
                 + self.summary(),
                 f"  prior: {self.lay.prior_source} (elsewhere 0.05 m spheres), "
                 f"weight {self.prior_weight:g}; projection moved the gains " + ", ".join(
                     f"{j} {v:+.2f}σ" for j, v in zip(self.joint_names, (
                         (gp - g) / s if s > 0 else 0.0 for g, gp, s in
                         zip(self.gains, self.gains_projected, self.gains_sigma)))),
                 f"  residual rms ({effort_unit}): unconstrained " + self._rms("unconstrained")
                 + "; projection " + self._rms("projection")
                 + (("; identified under the constraints " + self._rms("identification"))
                    if self.identified is not None else "")]
        fit = self.answer
        what = "identified under the constraints, gains held" if self.identified is not None \
            else "projection"
        w = max(len(n) for n in self.base_names + ["parameter"])
        lines.append(f"  {'parameter':<{w}} {'unconstrained':>13} {'σ':>10} {'consistent':>13} "
                     f"{'Δ/σ':>7}   ({what}; largest shift {proj['max_shift_sigma']:.2f}σ in the "
                     "projection)")
        for n, u, s, v in zip(self.base_names, self.chi_hat, self.sigma_b, fit.chi_b):
            lines.append(f"  {n:<{w}} {u:13.6g} {s:10.3g} {v:13.6g} {(v - u) / s:+7.2f}")
        lines.append(f"  {'body':<20} {'mass kg':>9} {'com (mm, body frame)':>26} "
                     f"{'min eig':>8}  unconstrained  at prior")
        for sp, b in zip(self.inertials(), self.bodies()):
            com = " ".join(f"{1e3 * x:8.2f}" for x in sp.com)
            ok = "consistent" if b.consistent_unconstrained else f"relaxed {b.relaxation:.2g}"
            lines.append(f"  {sp.body:<20} {sp.mass:9.4g} {com:>26} "
                         f"{b.min_eigenvalue:8.2g}  {ok:<13}  {', '.join(b.at_prior) or '-'}")
        for d in self.direct_dynamics:
            lines.append(d.text())
        return lines

    def message_fields(self, fields: dict[str, Any]) -> dict[str, Any]:
        """orthoglide_msgs/IdentifiedParameters fields of the consistent set, from the result's
        own (``IdentificationResult.message_fields()``): values = K χ_st of the answer (every base
        parameter), method "<method> consistent"; the gains are the held ones, rel_std the
        unconstrained answer's."""
        out = dict(fields)
        rel = dict(zip(fields["names"], fields["rel_std"]))
        out.update(method=f"{fields['method']} consistent", names=list(self.base_names),
                   values=[float(x) for x in self.answer.chi_b],
                   rel_std=[float(rel.get(n, -1.0)) for n in self.base_names])
        return out

    def _rms(self, key: str) -> str:
        return "/".join(f"{x:.4g}" for x in self.residual_rms[key])

    def _fit_json(self, fit: FitFigures, d2: float, residual: list[float]) -> dict[str, Any]:
        shift = (fit.chi_b - self.chi_hat) / self.sigma_b
        k = int(np.argmax(np.abs(shift)))
        base = self.residual_rms["unconstrained"]
        return {"mahalanobis_d2": d2, "n_base": len(self.base_names),
                "max_shift_sigma": float(abs(shift[k])), "max_shift_parameter": self.base_names[k],
                "residual_rms_per_joint": residual,
                "residual_increase": _increase(residual, base),
                "solve_s": fit.solve_s, "solver_status": fit.status,
                "parameters": [{"name": n, "unconstrained": float(u), "consistent": float(v),
                                "shift_sigma": float(s)}
                               for n, u, v, s in zip(self.base_names, self.chi_hat, fit.chi_b,
                                                     shift)]}

    def to_json(self) -> dict[str, Any]:
        bodies, bounds = self.bodies(), self.bounds()
        out: dict[str, Any] = {
            "constraints": "pseudo-inertia of every body ⪰ 0 (Wensing, Kim & Slotine 2018), "
                           f"ia, fv, fs ≥ 0; scaled pseudo-inertias ⪰ {MARGIN:g} 1",
            "prior": self.lay.prior_source + ("; elsewhere a weak default: a solid sphere of "
                                              "radius 0.05 m at each body frame's origin with "
                                              "the body's mass, no rotor inertia or friction"),
            "prior_weight": self.prior_weight,
            "unconstrained_consistent": self.findings.consistent,
            "inconsistent_bodies": [b.body for b in bodies if not b.consistent_unconstrained],
            "violated_bounds": [b.name for b in bounds if not b.consistent_unconstrained],
            "bodies": [b.to_json() for b in bodies], "bounds": [b.to_json() for b in bounds],
            "residual_rms_unconstrained": self.residual_rms["unconstrained"],
            "projection": self._fit_json(self.projection, self.projection_d2,
                                         self.residual_rms["projection"]),
            "answer": "identification" if self.identified is not None else "projection",
            "standard": self.values(), "seconds": self.seconds,
        }
        out["projection"]["gains_moved_sigma"] = {
            j: (float((gp - g) / s) if s > 0 else 0.0) for j, g, gp, s in
            zip(self.joint_names, self.gains, self.gains_projected, self.gains_sigma)}
        if self.identified is not None:
            out["identification"] = self._fit_json(self.identified, float(self.identified_d2),
                                                   self.residual_rms["identification"])
            out["identification"]["gains_held"] = [float(g) for g in self.gains]
        if self.direct_dynamics:
            out["direct_dynamics"] = [d.to_json() for d in self.direct_dynamics]
        return out


def _increase(residual: Sequence[float], base: Sequence[float]) -> float:
    """Relative increase of the total rms (all joints)."""
    a, b = math.sqrt(sum(x * x for x in residual)), math.sqrt(sum(x * x for x in base))
    return a / b - 1.0 if b > 0 else 0.0
