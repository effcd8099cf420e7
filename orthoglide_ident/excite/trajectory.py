"""The exciting-trajectory file: a finite Fourier series per actuated joint (paper Sect. 3.2,
refs [24, 25]), one run unloaded and one loaded, each repeating its period several times and
starting and ending at rest.

Per joint j of a run (Swevers' form, ω_f = 2π / period):

    q_j(t) = q0_j + Σ_{l=1..L} a_jl / (l ω_f) sin(l ω_f t) − b_jl / (l ω_f) cos(l ω_f t)

so q̇_j(0) = Σ_l a_jl and q̈_j(0) = ω_f Σ_l l b_jl. A run is at rest at t = 0 and at every whole
period when both sums vanish (``rest_projection`` enforces it); its start pose is then
q(0) = q0 − Σ_l b_l / (l ω_f), also its end pose. Outside [0, duration] a run holds its start pose.

File (YAML, ``orthoglide-ident excite design --out FILE``): ``format``, ``robot``, ``joints`` (the
actuated joints, rows of ``a`` and ``b``), ``period_s``, ``periods``, ``runs: {unloaded: {q0, a, b},
loaded: {q0, a, b, payload: {mass, frame, com, inertia}}}``; ``design``, ``limits``, ``margins``,
``prediction`` and ``locked_joints`` (the robot's, model/locked_joints.py) are written by the
design and the check and kept as they are. SI units: rad or m, s, kg.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.yaml_files import load_yaml

FORMAT = "orthoglide_ident.excitation/1"
RUN_NAMES = ("unloaded", "loaded")
REST_TOL = 1e-9  # |q̇(0)|, |q̈(0)| below which a run starts at rest (rad/s, rad/s²)


def rest_projection(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The nearest coefficients (least squares, per joint) with Σ_l a_jl = 0 and Σ_l l b_jl = 0:
    at rest at t = 0 and at every whole period."""
    a, b = np.array(a, float), np.array(b, float)
    L = a.shape[1]
    one, ell = np.ones(L), np.arange(1, L + 1, dtype=float)
    a -= np.outer(a @ one, one) / (one @ one)
    b -= np.outer(b @ ell, ell) / (ell @ ell)
    return a, b


@dataclass(frozen=True)
class FourierSeries:
    """The finite Fourier series of the module docstring, one per joint, periodic in t: the one
    trajectory type of the product's designs and of the simulator's stored references."""

    q0: np.ndarray  # (n,) rad or m
    a: np.ndarray  # (n, L) rad/s or m/s
    b: np.ndarray  # (n, L)
    w_f: float  # rad/s, ω_f

    @property
    def period(self) -> float:
        return 2.0 * math.pi / self.w_f

    def evaluate(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """q, q̇, q̈ at times ``t`` (s): each (m, n)."""
        t = np.atleast_1d(np.asarray(t, float))
        kw = self.w_f * np.arange(1, self.a.shape[1] + 1)
        s, c = np.sin(np.outer(t, kw)), np.cos(np.outer(t, kw))
        q = self.q0 + s @ (self.a / kw).T - c @ (self.b / kw).T
        qd = c @ self.a.T + s @ self.b.T
        qdd = -s @ (self.a * kw).T + c @ (self.b * kw).T
        return q, qd, qdd

    def to_dict(self) -> dict[str, Any]:
        return {"kind": "fourier", "q0": self.q0.tolist(), "a": self.a.tolist(),
                "b": self.b.tolist(), "w_f": self.w_f}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> FourierSeries:
        return cls(np.array(d["q0"], float), np.array(d["a"], float), np.array(d["b"], float),
                   float(d["w_f"]))


@dataclass(frozen=True)
class ExcitationRun:
    """One run: its Fourier coefficients (n joints × L harmonics) and, when loaded, the payload
    the user mounts (``mass`` kg, ``frame``, and ``com`` m / ``inertia`` kg·m² when known)."""

    name: str  # "unloaded" | "loaded"
    q0: np.ndarray  # (n,)
    a: np.ndarray  # (n, L) rad/s or m/s
    b: np.ndarray  # (n, L)
    payload: dict[str, Any] | None = None

    def to_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {"q0": self.q0.tolist(), "a": self.a.tolist(), "b": self.b.tolist()}
        if self.payload is not None:
            d["payload"] = dict(self.payload)
        return d


@dataclass(frozen=True)
class ExcitationTrajectory:
    """Both runs of a design, for one robot: evaluate, start pose, duration."""

    robot: str
    joints: tuple[str, ...]
    period_s: float
    periods: int
    runs: dict[str, ExcitationRun]
    extra: dict[str, Any] = field(default_factory=dict)  # design, limits, margins, prediction

    @property
    def w_f(self) -> float:
        return 2.0 * math.pi / self.period_s

    @property
    def duration(self) -> float:
        """s, one run: ``periods`` whole periods."""
        return self.period_s * self.periods

    def run(self, name: str) -> ExcitationRun:
        if name not in self.runs:
            raise ConfigError(f"the trajectory has no {name!r} run (has {', '.join(self.runs)})")
        return self.runs[name]

    def series(self, name: str) -> FourierSeries:
        """Run ``name`` as a periodic Fourier series (what a plant tracks over its duration)."""
        r = self.run(name)
        return FourierSeries(r.q0, r.a, r.b, self.w_f)

    def evaluate(self, name: str, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """q, q̇, q̈ of run ``name`` at times ``t`` (s from its start): each (m, n); outside
        [0, duration] the start pose at rest."""
        t = np.atleast_1d(np.asarray(t, float))
        inside = (t >= 0.0) & (t <= self.duration)
        q, qd, qdd = self.series(name).evaluate(np.where(inside, t, 0.0))
        return q, qd * inside[:, None], qdd * inside[:, None]

    def start_pose(self, name: str) -> np.ndarray:
        """(n,) q(0) = q(duration) of run ``name``: where it starts and ends at rest."""
        return self.evaluate(name, np.zeros(1))[0][0]

    def rest_error(self, name: str) -> float:
        """max |q̇(0)|, |q̈(0)| of run ``name`` (0 for a run that starts and ends at rest)."""
        _, qd, qdd = self.evaluate(name, np.zeros(1))
        return float(max(np.abs(qd).max(), np.abs(qdd).max()))

    def to_dict(self) -> dict[str, Any]:
        return {"format": FORMAT, "robot": self.robot, "joints": list(self.joints),
                "period_s": self.period_s, "periods": self.periods,
                "runs": {k: r.to_dict() for k, r in self.runs.items()}, **self.extra}


def save_trajectory(traj: ExcitationTrajectory, path: str | Path) -> None:
    """Write ``traj`` as YAML (plain floats, readable by any YAML reader)."""
    Path(path).write_text(yaml.safe_dump(traj.to_dict(), sort_keys=False, width=100))


def _run_from(name: str, d: Any, n: int, where: str) -> ExcitationRun:
    if not isinstance(d, dict):
        raise ConfigError(f"{where}: run {name!r} must be a mapping with q0, a, b")
    try:
        q0, a, b = (np.array(d[k], float) for k in ("q0", "a", "b"))
    except KeyError as exc:
        raise ConfigError(f"{where}: run {name!r} lacks {exc.args[0]!r}") from None
    except (TypeError, ValueError):
        raise ConfigError(f"{where}: run {name!r}: q0, a, b must be numbers") from None
    if q0.shape != (n,) or a.ndim != 2 or a.shape[0] != n or b.shape != a.shape:
        raise ConfigError(f"{where}: run {name!r}: q0 needs {n} values and a, b {n} rows of one "
                          f"length each (got {q0.shape}, {a.shape}, {b.shape})")
    if not (np.isfinite(q0).all() and np.isfinite(a).all() and np.isfinite(b).all()):
        raise ConfigError(f"{where}: run {name!r} holds a non-finite coefficient")
    payload = d.get("payload")
    if payload is not None and not isinstance(payload, dict):
        raise ConfigError(f"{where}: run {name!r}: payload must be a mapping (mass, frame, ...)")
    return ExcitationRun(name, q0, a, b, payload)


def load_trajectory(path: str | Path) -> ExcitationTrajectory:
    """Read a trajectory file; ConfigError naming the file for anything malformed."""
    doc = load_yaml(path, "excitation trajectory")
    where = str(path)
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        raise ConfigError(f"{where}: not an exciting-trajectory file (format: {FORMAT} expected)")
    try:
        joints = tuple(str(j) for j in doc["joints"])
        period, periods = float(doc["period_s"]), int(doc["periods"])
        runs_doc = doc["runs"]
        robot = str(doc["robot"])
    except (KeyError, TypeError, ValueError) as exc:
        raise ConfigError(
            f"{where}: needs robot, joints, period_s, periods and runs ({exc})"
        ) from None
    if not (period > 0 and periods >= 1 and joints and isinstance(runs_doc, dict) and runs_doc):
        raise ConfigError(f"{where}: period_s must be > 0, periods >= 1, joints and runs non-empty")
    unknown = sorted(set(runs_doc) - set(RUN_NAMES))
    if unknown:
        raise ConfigError(f"{where}: unknown runs {unknown} (runs are {', '.join(RUN_NAMES)})")
    runs = {k: _run_from(k, v, len(joints), where) for k, v in runs_doc.items()}
    keys = ("format", "robot", "joints", "period_s", "periods", "runs")
    extra = {k: v for k, v in doc.items() if k not in keys}
    return ExcitationTrajectory(robot, joints, period, periods, runs, extra)
