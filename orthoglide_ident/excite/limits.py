"""The actuated joints' limits an exciting trajectory must keep, from the user's own description.

Per actuated joint, the first source that gives a value wins:

1. a ros2_control joint_limits YAML (``--joint-limits FILE``: ``joint_limits: {<joint>:
   {has_position_limits, min_position, max_position, has_velocity_limits, max_velocity,
   has_acceleration_limits, max_acceleration, has_effort_limits, max_effort}}``, also found
   under a node's ``ros__parameters`` or MoveIt's ``robot_description_planning``);
2. the robot YAML's ``excitation`` mapping (docs/guide/robot_files.md): ``position_limits``,
   ``velocity_limits``, ``acceleration_limits``, ``effort_limits`` or ``current_limits`` (A, times
   the nominal gain: the torque at the joint through the transmission);
3. the URDF's ``<limit lower upper velocity effort>`` (a URDF has no acceleration limit);
4. an acceleration limit none of them gives is derived: ACCEL_SAFETY · τ_max / M_jj at the home
   pose (``derived_acceleration``; ``derive_acceleration=False`` refuses instead).

A joint left without a finite position range, velocity, acceleration or effort is a ConfigError
naming the joint and where to give it. Units: m or rad, per s, per s², N or N·m.

A URDF ``<mimic>`` joint (q_m = r q_l + o) keeps its own position and velocity limits (its URDF
<limit>) and acceleration limit (a joint_limits file naming it): ``JointLimits.mimics``; the
check verifies them on the mimic's own motion, and ``through_mimics`` maps them onto the leader
for the design (r q̇_l within the mimic's limit is |q̇_l| ≤ v_m / |r|, and so on).
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.model.robot_file import excitation_section, per_joint
from orthoglide_ident.yaml_files import load_yaml

# self-collision bodies of a design (excite/collision.py): here, so that the CLI's parser needs
# no Pinocchio
COLLISION_MODES = ("mesh", "primitives", "skip")

KINDS = ("lower", "upper", "velocity", "acceleration", "effort")
ROS2_KEYS = {"lower": ("has_position_limits", "min_position"),
             "upper": ("has_position_limits", "max_position"),
             "velocity": ("has_velocity_limits", "max_velocity"),
             "acceleration": ("has_acceleration_limits", "max_acceleration"),
             "effort": ("has_effort_limits", "max_effort")}
ACCEL_SAFETY = 0.5  # the fraction of the effort limit a derived acceleration limit spends
DERIVED_SOURCE = f"derived: {ACCEL_SAFETY:g} × effort limit / the joint's inertia at home"


@dataclass(frozen=True)
class MimicLimits:
    """A mimic joint's own limits (inf where none is given) and how it follows its leader."""

    joint: str
    leader: int  # the leader's actuated index
    multiplier: float
    offset: float
    kind: str  # revolute | prismatic
    lower: float
    upper: float
    velocity: float
    acceleration: float

    def motion(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The mimic's (q, q̇, q̈) (m,) from the actuated samples (m, n)."""
        r, a = self.multiplier, self.leader
        return r * q[:, a] + self.offset, r * qd[:, a], r * qdd[:, a]


@dataclass(frozen=True)
class JointLimits:
    """Limits of the actuated joints (n,) each, in the model's joint order, and where each kind
    came from (``sources``: kind -> file)."""

    joints: tuple[str, ...]
    lower: np.ndarray
    upper: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    effort: np.ndarray
    sources: dict[str, str]
    mimics: tuple[MimicLimits, ...] = ()

    def through_mimics(self, margin: np.ndarray, mimic_margin: dict[str, float]
                       ) -> JointLimits:
        """These limits, each leader's range less ``margin`` (n,) and narrowed to what keeps
        its mimic joints within theirs less ``mimic_margin`` (joint -> m or rad), its velocity
        and acceleration to what keeps theirs: the bounds a design meets by construction."""
        lo, hi = self.lower + margin, self.upper - margin
        vel, acc = self.velocity.copy(), self.acceleration.copy()
        for m in self.mimics:
            a, r, pm = m.leader, m.multiplier, mimic_margin.get(m.joint, 0.0)
            if r == 0:
                continue
            ends = sorted(((m.lower + pm - m.offset) / r, (m.upper - pm - m.offset) / r))
            lo[a], hi[a] = max(lo[a], ends[0]), min(hi[a], ends[1])  # ±inf: no range given
            vel[a] = min(vel[a], m.velocity / abs(r))
            acc[a] = min(acc[a], m.acceleration / abs(r))
        return dataclasses.replace(self, lower=lo, upper=hi, velocity=vel, acceleration=acc)

    def to_dict(self) -> dict[str, Any]:
        """``limits.joints`` of the trajectory file: joint -> {lower, upper, velocity, ...}."""
        return {"joints": {j: {k: float(getattr(self, k)[i]) for k in KINDS}
                           for i, j in enumerate(self.joints)},
                "sources": dict(self.sources)}

    @classmethod
    def from_dict(cls, d: Any, joints: tuple[str, ...], where: str) -> JointLimits:
        try:
            rows = d["joints"]
            vals = {k: np.array([float(rows[j][k]) for j in joints]) for k in KINDS}
        except (KeyError, TypeError, ValueError) as exc:
            raise ConfigError(f"{where}: limits.joints needs {', '.join(KINDS)} for every joint "
                              f"({exc})") from None
        return cls(joints, sources=dict(d.get("sources") or {}), **vals)


def ros2_joint_limits(path: str | Path, joints: tuple[str, ...]) -> dict[str, dict[str, float]]:
    """kind -> {joint: value} from a ros2_control (or MoveIt) joint_limits YAML."""
    doc = load_yaml(path, "joint limits file")
    table = _find_joint_limits(doc)
    if table is None:
        raise ConfigError(
            f"joint limits file {path}: no joint_limits mapping (ros2_control's "
            "joint_limits: {<joint>: {has_velocity_limits: true, max_velocity: ...}})"
        )
    out: dict[str, dict[str, float]] = {k: {} for k in KINDS}
    for joint, entry in table.items():
        if joint not in joints or not isinstance(entry, dict):
            continue
        for kind, (flag, key) in ROS2_KEYS.items():
            if entry.get(flag) and key in entry:
                try:
                    out[kind][joint] = float(entry[key])
                except (TypeError, ValueError):
                    raise ConfigError(f"joint limits file {path}: {joint}.{key} is not a number "
                                      f"({entry[key]!r})") from None
    return out


def _find_joint_limits(doc: Any, depth: int = 0) -> dict | None:
    if not isinstance(doc, dict) or depth > 3:
        return None
    if isinstance(doc.get("joint_limits"), dict):
        return doc["joint_limits"]
    for v in doc.values():
        found = _find_joint_limits(v, depth + 1)
        if found is not None:
            return found
    return None


def _robot_file_limits(model, section: dict[str, Any]) -> dict[str, dict[str, float]]:
    names = model.joint_names
    out: dict[str, dict[str, float]] = {k: {} for k in KINDS}
    where = f"robot {model.name}: excitation"
    if "position_limits" in section:
        for j, (lo, hi) in per_joint(section["position_limits"], names,
                                     f"{where}.position_limits", 2).items():
            out["lower"][j], out["upper"][j] = lo, hi
    for kind in ("velocity", "acceleration", "effort"):
        key = f"{kind}_limits"
        if key in section:
            out[kind].update(per_joint(section[key], names, f"{where}.{key}"))
    if "current_limits" in section:
        gains = dict(zip(names, model.nominal_gains))
        for j, amps in per_joint(section["current_limits"], names,
                                 f"{where}.current_limits").items():
            out["effort"].setdefault(j, amps * gains[j])
    return out


def _urdf_limits(model) -> dict[str, dict[str, float]]:
    """What the URDF's <limit> elements say (0 velocity or effort: not given)."""
    out: dict[str, dict[str, float]] = {k: {} for k in KINDS}
    by_name = {j.name: j for j in model.actuated}
    for name in model.joint_names:
        j = by_name[name]
        out["lower"][name], out["upper"][name] = j.lower, j.upper
        out["velocity"][name] = j.velocity if j.velocity > 0 else math.inf
        effort = float(model.model.effortLimit[j.iv])
        out["effort"][name] = effort if effort > 0 else math.inf
    return out


def read_limits(model, joint_limits_file: str | Path | None = None,
                derive_acceleration: bool = True) -> JointLimits:
    """The actuated joints' limits (module docstring: joint_limits YAML, robot file, URDF);
    a joint no source gives an acceleration limit gets the derived one (``derived_acceleration``)
    unless ``derive_acceleration`` is False (then a ConfigError says where to give it)."""
    section, _ = excitation_section(model)
    names = model.joint_names
    layers = [(str(model.description.path.name), _urdf_limits(model)),
              (f"robot file ({model.name})", _robot_file_limits(model, section))]
    mimic_file = {}
    if joint_limits_file:
        both = ros2_joint_limits(joint_limits_file, names + _mimic_names(model))
        mimic_file = {k: {j: v for j, v in d.items() if j not in names} for k, d in both.items()}
        layers.append((str(joint_limits_file), {k: {j: v for j, v in d.items() if j in names}
                                                for k, d in both.items()}))
    values = {k: np.full(len(names), math.nan) for k in KINDS}
    sources: dict[str, str] = {}
    for where, layer in layers:  # later layers override earlier ones
        for kind, by_joint in layer.items():
            for j, v in by_joint.items():
                if math.isfinite(v) or math.isnan(values[kind][names.index(j)]):
                    values[kind][names.index(j)] = v
                    if math.isfinite(v):
                        sources[kind] = where
    missing = ~(np.isfinite(values["acceleration"]) & (values["acceleration"] > 0))
    if derive_acceleration and missing.any():
        _require(model, {k: v for k, v in values.items() if k != "acceleration"})
        derived = derived_acceleration(model, values["effort"],
                                       start_pose(model, values["lower"], values["upper"]))
        values["acceleration"] = np.where(missing, derived, values["acceleration"])
        sources["acceleration"] = DERIVED_SOURCE
    _require(model, values)
    return JointLimits(names, sources=sources, mimics=_mimic_limits(model, mimic_file), **values)


def _mimic_names(model) -> tuple[str, ...]:
    return tuple(j.name for j, *_ in model.mimic_rows)


def _mimic_limits(model, from_file: dict[str, dict[str, float]]) -> tuple[MimicLimits, ...]:
    """Each mimic joint's own limits: the URDF's range and velocity, the joint_limits file's
    range, velocity and acceleration over them (inf where neither gives one)."""
    out = []
    for j, a, r, o in model.mimic_rows:
        own = {"lower": j.lower, "upper": j.upper,
               "velocity": j.velocity if j.velocity > 0 else math.inf, "acceleration": math.inf}
        own.update({k: from_file[k][j.name] for k in own if j.name in from_file.get(k, {})})
        out.append(MimicLimits(j.name, a, r, o, j.unit_kind, **own))
    return tuple(out)


def start_pose(model, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """The robot file's ``excitation.home`` (joints it names), else the middle of each range."""
    section, _ = excitation_section(model)
    home = dict(per_joint(section["home"], model.joint_names,
                          f"robot {model.name}: excitation.home")) if "home" in section else {}
    return np.array([home.get(j, 0.5 * (lo + hi))
                     for j, lo, hi in zip(model.joint_names, lower, upper)])


def derived_acceleration(model, effort: np.ndarray, q_home: np.ndarray) -> np.ndarray:
    """(n,) a_j = ACCEL_SAFETY · τ_max,j / M_jj(q_home): the acceleration that half the
    effort limit gives the joint's own inertia at the home pose (M of the description's
    parameters, armature included, no payload: τ(q, 0, e_j) − τ(q, 0, 0) = M e_j, eq. 15),
    the other half left for gravity, the other joints' coupling and the payload."""
    from orthoglide_ident.excite.check import nominal_efforts  # Pinocchio: not at import

    n = len(q_home)
    q = np.tile(q_home, (n + 1, 1))
    qdd = np.vstack([np.zeros(n), np.eye(n)])
    tau = nominal_efforts(model, None, q, np.zeros_like(q), qdd)
    m_jj = np.diag(tau[1:] - tau[0])
    if np.any(~(m_jj > 0)):
        j = model.joint_names[int(np.argmax(~(m_jj > 0)))]
        raise ConfigError(f"robot {model.name}: joint {j} moves no inertia at the home pose, so "
                          "no acceleration limit can be derived: give one (excitation."
                          "acceleration_limits or --joint-limits)")
    return ACCEL_SAFETY * effort / m_jj


def _require(model, values: dict[str, np.ndarray]) -> None:
    hint = {"lower": "a finite <limit lower upper> in the URDF or excitation.position_limits",
            "velocity": "<limit velocity> in the URDF or excitation.velocity_limits",
            "acceleration": "excitation.acceleration_limits in the robot file or --joint-limits "
                            "FILE (ros2_control joint_limits: has_acceleration_limits, "
                            "max_acceleration)",
            "effort": "<limit effort> in the URDF, excitation.effort_limits or current_limits"}
    for kind in ("lower", "upper", "velocity", "acceleration", "effort"):
        if kind not in values:
            continue
        v = values[kind]
        bad = ~np.isfinite(v) if kind in ("lower", "upper") else ~(np.isfinite(v) & (v > 0))
        if bad.any():
            j = model.joint_names[int(np.argmax(bad))]
            name = "position" if kind in ("lower", "upper") else kind
            raise ConfigError(f"robot {model.name}: joint {j} has no {name} limit: give "
                              f"{hint['lower' if kind == 'upper' else kind]}")
    if np.any(values["lower"] >= values["upper"]):
        j = model.joint_names[int(np.argmax(values["lower"] >= values["upper"]))]
        raise ConfigError(f"robot {model.name}: joint {j}: lower position limit is not below "
                          "the upper one")


def home_pose(model, limits: JointLimits, pose: dict[str, float] | None = None) -> np.ndarray:
    """(n,) where the runs start and end at rest: ``pose`` (joint -> value, the others from the
    robot file's ``excitation.home``), else the middle of each joint's range; ConfigError
    outside the limits."""
    q = start_pose(model, limits.lower, limits.upper)
    for j, v in (pose or {}).items():
        if j not in model.joint_names:
            raise ConfigError(f"--pose names {j!r}, not an actuated joint of robot {model.name} "
                              f"({', '.join(model.joint_names)})")
        q[model.joint_names.index(j)] = float(v)
    out = (q < limits.lower) | (q > limits.upper)
    if out.any():
        k = int(np.argmax(out))
        raise ConfigError(f"start pose of {model.joint_names[k]} ({q[k]:g}) is outside its limits "
                          f"[{limits.lower[k]:g}, {limits.upper[k]:g}]")
    return q
