"""The simulated Orthoglide's true parameters: every standard parameter of every body, drive gains,
payloads and the plant's unmodelled effects. One readable table, overridable from YAML.

Inertial parameters are not typed in directly: each body is described as a rigid body (mass, centre
of mass in its MDH frame, principal moments about the centre of mass, small tilt of the principal
axes), and its 10 standard inertial parameters (inertia at the frame origin, first moments, mass)
are derived from that. This keeps every body physically consistent (positive mass, positive-definite
inertia satisfying the triangle inequalities) while every parameter is non-zero.

Plant profiles (:class:`PlantProfile`) add what a real drive has and the IDIM lacks: a first-order
current loop, Stribeck breakaway friction, ball-screw friction ripple at the screw lead, and set
the current and encoder noise. "nominal" (the default) has none of the unmodelled effects;
"realistic" switches them on. Both are overridable, and more can be named, in YAML.

This table is the plant's own truth, kept apart from the identification model on purpose
(docs/design/architecture.md
§5): nothing here is derived from orthoglide_ident's regressor. Only interface facts are imported
from it: joint names and the manufacturer's gain 637π N/A that a controller is configured with.

Units: kg, m, kg·m²; prismatic joints N, N·s/m, kg (ia); revolute joints N·m, N·m·s/rad.
Names follow docs/design/conventions.md: ``<p>_<j><i>`` for body j of leg i, ``<p>_6`` platform,
``<p>_7`` payload.
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.yaml_files import load_yaml, unwrap_section

INERTIAL = ("xx", "xy", "xz", "yy", "yz", "zz", "mx", "my", "mz", "m")

# --------------------------------------------------------------------------------------------
# The table.  Rigid bodies: (mass kg, centre of mass in the body's MDH frame m,
# principal moments about the centre of mass kg·m², tilt of the principal axes rad (x-y-z Euler)).
# Leg i body j frames: 1 foot (z along the actuator), 2 pivot yoke at the foot, 3 equivalent bar
# (x along the bar, length d4 = 0.31 m), 4 and 5 pivot blocks at the platform end (origin C_i).
# The legs were built alike but not identical: each leg has its own row.
# --------------------------------------------------------------------------------------------
LEG_BODIES: dict[int, dict[int, tuple[float, tuple, tuple, tuple]]] = {
    # leg 1
    1: {
        1: (3.60, (0.012, 0.021, -0.048), (0.0112, 0.0095, 0.0068), (0.05, -0.03, 0.08)),
        2: (0.26, (0.006, -0.011, 0.018), (2.1e-4, 1.7e-4, 1.2e-4), (0.10, 0.04, -0.06)),
        3: (0.31, (0.1550, 0.0035, 0.0042), (2.9e-4, 2.55e-3, 2.60e-3), (0.02, -0.01, 0.03)),
        4: (0.055, (0.004, 0.003, 0.009), (1.9e-5, 1.6e-5, 1.1e-5), (0.07, 0.05, -0.04)),
        5: (0.062, (0.005, -0.004, 0.007), (2.2e-5, 1.8e-5, 1.3e-5), (-0.06, 0.03, 0.05)),
    },
    # leg 2
    2: {
        1: (3.52, (0.010, 0.019, -0.051), (0.0109, 0.0097, 0.0066), (0.04, -0.02, 0.07)),
        2: (0.25, (0.007, -0.010, 0.017), (2.0e-4, 1.8e-4, 1.1e-4), (0.09, 0.05, -0.05)),
        3: (0.30, (0.1545, 0.0031, 0.0047), (2.8e-4, 2.50e-3, 2.56e-3), (0.03, -0.02, 0.02)),
        4: (0.052, (0.005, 0.002, 0.008), (1.8e-5, 1.5e-5, 1.2e-5), (0.06, 0.04, -0.05)),
        5: (0.060, (0.004, -0.005, 0.006), (2.1e-5, 1.9e-5, 1.2e-5), (-0.05, 0.02, 0.06)),
    },
    # leg 3 (vertical actuator: a slightly heavier carriage with a brake)
    3: {
        1: (3.85, (0.011, 0.023, -0.046), (0.0118, 0.0101, 0.0071), (0.06, -0.04, 0.09)),
        2: (0.27, (0.005, -0.012, 0.019), (2.2e-4, 1.6e-4, 1.3e-4), (0.11, 0.03, -0.07)),
        3: (0.32, (0.1556, 0.0038, 0.0039), (3.0e-4, 2.61e-3, 2.66e-3), (0.01, -0.02, 0.04)),
        4: (0.057, (0.003, 0.004, 0.010), (2.0e-5, 1.7e-5, 1.0e-5), (0.08, 0.06, -0.03)),
        5: (0.064, (0.006, -0.003, 0.008), (2.3e-5, 1.7e-5, 1.4e-5), (-0.07, 0.04, 0.04)),
    },
}
PLATFORM_BODY = (0.42, (0.003, 0.011, -0.006), (4.1e-4, 3.6e-4, 5.2e-4), (0.05, -0.08, 0.12))

# Drive chain and joint friction, per leg: ia (kg, rotor + screw inertia seen at the foot),
# then (fv, fs, tauoff) for joints 1 (prismatic: N·s/m, N, N) and 2..5 (pivots: N·m·s/rad, N·m,
# N·m).
ACTUATOR_INERTIA = {1: 4.85, 2: 4.62, 3: 5.05}
JOINT_FRICTION: dict[int, dict[int, tuple[float, float, float]]] = {
    1: {1: (85.7, 35.2, 1.30), 2: (0.120, 0.210, 0.021), 3: (0.095, 0.180, -0.017),
        4: (0.105, 0.165, 0.012), 5: (0.140, 0.240, -0.019)},
    2: {1: (86.7, 41.7, -0.90), 2: (0.110, 0.230, -0.015), 3: (0.090, 0.170, 0.014),
        4: (0.115, 0.175, -0.011), 5: (0.130, 0.220, 0.016)},
    3: {1: (84.0, 24.1, 2.60), 2: (0.125, 0.200, 0.018), 3: (0.100, 0.190, -0.013),
        4: (0.098, 0.160, 0.010), 5: (0.135, 0.250, -0.021)},
}

# True drive gains (N/A), unlike the manufacturer's 637 pi ~ 2001 (the paper found these).
G_TAU = (2170.0, 2100.0, 2070.0)

# Payloads (body 7, frame parallel to the base at P): weighed masses of Sect. 5.2, as steel
# cylinders (mass, centre of mass, principal moments, tilt).  A custom mass scales the 1.983 kg
# cylinder's shape (same centre of mass, inertia proportional to mass).
PAYLOADS: dict[str, tuple[float, tuple, tuple, tuple]] = {
    "1.983": (1.983, (0.004, 0.032, -0.007), (1.30e-3, 1.05e-3, 1.30e-3), (0.03, 0.02, -0.04)),
    "1.136": (1.136, (-0.006, 0.027, 0.005), (6.2e-4, 4.9e-4, 6.2e-4), (-0.02, 0.05, 0.03)),
}

# The plant's Coulomb friction turns smoothly through zero: fs * tanh(qdot / v_s).
COULOMB_VELOCITY = {"prismatic": 1.0e-3, "revolute": 5.0e-3}  # m/s, rad/s



@dataclass(frozen=True)
class PlantProfile:
    """What lies between the controller and the ideal plant, beyond the IDIM
    (docs/design/simulator.md).

    Units: s, A, m, m/s; friction terms are fractions of each actuator's Coulomb level fs_1i.
    """

    name: str = "nominal"
    current_noise_std: float = 1.0e-3  # A, white, held with the reference over the tick
    encoder_resolution: float = 1.0e-6  # m, quantisation step of the position
    encoder_noise_std: float = 0.0  # m, white, added to the position before quantisation
    current_lag_s: float = 0.0  # s, time constant of the first-order current loop (0: ideal)
    stribeck_breakaway: float = 0.0  # fraction of fs_1i added at zero velocity (0: none)
    stribeck_velocity: float = 3.0e-3  # m/s, Stribeck velocity scale (Gaussian)
    ripple_amplitude: float = 0.0  # fraction of fs_1i, friction ripple of the ball screw
    ripple_lead: float = 0.01  # m, screw lead = ripple period in q1i

    @property
    def unmodelled(self) -> list[str]:
        """The effects switched on that the IDIM does not model, in words."""
        out = []
        if self.current_lag_s > 0:
            out.append(f"current-loop lag {1e3 * self.current_lag_s:.3g} ms")
        if self.stribeck_breakaway > 0:
            out.append(f"Stribeck +{100 * self.stribeck_breakaway:.3g} % fs at "
                       f"{1e3 * self.stribeck_velocity:.3g} mm/s")
        if self.ripple_amplitude > 0:
            out.append(f"screw friction ripple ±{100 * self.ripple_amplitude:.3g} % fs at "
                       f"{1e3 * self.ripple_lead:.3g} mm")
        return out


# The profiles known by name. "realistic": a drive as the issue measured it on a real one — 2 mA
# current noise, a 0.12 ms current loop, +30 % breakaway within a few mm/s, ±1.5 % screw friction
# ripple at a 10 mm lead.
PROFILES: dict[str, PlantProfile] = {
    "nominal": PlantProfile("nominal"),
    "realistic": PlantProfile("realistic", current_noise_std=2.0e-3, current_lag_s=1.2e-4,
                              stribeck_breakaway=0.3, stribeck_velocity=3.0e-3,
                              ripple_amplitude=0.015, ripple_lead=0.01),
}
DEFAULT_PROFILE = "nominal"


def inertial_from_rigid_body(mass: float, com, principal, tilt) -> np.ndarray:
    """10 standard inertial parameters (xx..zz at the frame origin, mx, my, mz, m) of a rigid
    body."""
    c = np.asarray(com, dtype=float)
    rx, ry, rz = tilt
    Rx = np.array([[1, 0, 0], [0, math.cos(rx), -math.sin(rx)], [0, math.sin(rx), math.cos(rx)]])
    Ry = np.array([[math.cos(ry), 0, math.sin(ry)], [0, 1, 0], [-math.sin(ry), 0, math.cos(ry)]])
    Rz = np.array([[math.cos(rz), -math.sin(rz), 0], [math.sin(rz), math.cos(rz), 0], [0, 0, 1]])
    R = Rx @ Ry @ Rz
    I_G = R @ np.diag(principal) @ R.T
    I_O = I_G + mass * (c @ c * np.eye(3) - np.outer(c, c))  # Huygens-Steiner
    return np.array([I_O[0, 0], I_O[0, 1], I_O[0, 2], I_O[1, 1], I_O[1, 2], I_O[2, 2],
                     *(mass * c), mass])


def _body_kinds(body: int) -> tuple[str, ...]:
    return INERTIAL + (("ia", "fv", "fs", "tauoff") if body == 1 else ("fv", "fs", "tauoff"))


STANDARD_NAMES: tuple[str, ...] = tuple(
    f"{kind}_{body}{leg}" for leg in (1, 2, 3) for body in range(1, 6) for kind in _body_kinds(body)
) + tuple(f"{kind}_6" for kind in INERTIAL)
PAYLOAD_NAMES: tuple[str, ...] = tuple(f"{kind}_7" for kind in INERTIAL)
assert len(STANDARD_NAMES) == 208


def _table_values() -> dict[str, float]:
    values: dict[str, float] = {}
    for leg in (1, 2, 3):
        for body in range(1, 6):
            inertial = inertial_from_rigid_body(*LEG_BODIES[leg][body])
            for kind, v in zip(INERTIAL, inertial):
                values[f"{kind}_{body}{leg}"] = float(v)
            if body == 1:
                values[f"ia_1{leg}"] = ACTUATOR_INERTIA[leg]
            fv, fs, tauoff = JOINT_FRICTION[leg][body]
            values[f"fv_{body}{leg}"] = fv
            values[f"fs_{body}{leg}"] = fs
            values[f"tauoff_{body}{leg}"] = tauoff
    for kind, v in zip(INERTIAL, inertial_from_rigid_body(*PLATFORM_BODY)):
        values[f"{kind}_6"] = float(v)
    return values


@dataclass(frozen=True)
class TrueParameters:
    """Everything the plant needs that the identification is meant to find (and a bit more)."""

    values: dict[str, float]  # the 208 standard robot parameters by name
    g_tau: tuple[float, float, float] = G_TAU
    payloads: dict[str, np.ndarray] = field(default_factory=dict)  # name -> (10,) inertial
    coulomb_velocity: dict[str, float] = field(default_factory=lambda: dict(COULOMB_VELOCITY))
    profiles: dict[str, PlantProfile] = field(default_factory=lambda: dict(PROFILES))
    profile: str = DEFAULT_PROFILE  # the profile used when none is asked for

    def plant_profile(self, name: str | None = None) -> PlantProfile:
        """The profile ``name`` (default: ``self.profile``); ConfigError if unknown."""
        key = self.profile if name is None else str(name)
        if key not in self.profiles:
            raise ConfigError(
                f"unknown plant profile {key!r}: use one of {', '.join(sorted(self.profiles))}"
            )
        return self.profiles[key]

    @property
    def names(self) -> tuple[str, ...]:
        return STANDARD_NAMES

    def standard_vector(self) -> np.ndarray:
        """The 208 robot standard parameters in canonical order (docs/design/conventions.md)."""
        return np.array([self.values[n] for n in STANDARD_NAMES])

    def payload_vector(self, payload: str | float | None) -> np.ndarray:
        """(10,) inertial parameters xx_7..m_7 of a payload: "none", "1.983", "1.136" or a mass in
        kg."""
        if payload is None or payload == "none" or payload == 0 or payload == "0":
            return np.zeros(10)
        key = str(payload)
        if key in self.payloads:
            return self.payloads[key].copy()
        try:
            mass = float(payload)
        except (TypeError, ValueError):
            raise ConfigError(
                f"unknown payload {payload!r}: use none, 1.983, 1.136 or a mass in kg"
            ) from None
        if not (0.0 < mass < 20.0):
            raise ConfigError(f"payload mass {mass} kg out of range (0, 20) kg")
        base = self.payloads.get("1.983", np.array(inertial_from_rigid_body(*PAYLOADS["1.983"])))
        return base * (mass / base[9])

    @property
    def m_7(self) -> dict[str, float]:
        return {k: float(v[9]) for k, v in self.payloads.items()}


def default_parameters() -> TrueParameters:
    payloads = {k: inertial_from_rigid_body(*v) for k, v in PAYLOADS.items()}
    return TrueParameters(values=_table_values(), payloads=payloads)


_TOP_KEYS = {"g_tau", "parameters", "payloads", "coulomb_velocity", "profile", "profiles"}
# YAML layout of a profile: key -> (PlantProfile field, lower bound, upper bound, unit)
_PROFILE_KEYS: dict[str, tuple[str, float, float, str]] = {
    "current_noise": ("current_noise_std", 0.0, 1.0, "A"),
    "encoder_resolution": ("encoder_resolution", 1e-9, 1e-3, "m"),
    "encoder_noise": ("encoder_noise_std", 0.0, 1e-3, "m"),
    "current_lag": ("current_lag_s", 0.0, 1e-3, "s"),
}
_PROFILE_GROUPS: dict[str, dict[str, tuple[str, float, float, str]]] = {
    "stribeck": {"breakaway": ("stribeck_breakaway", 0.0, 5.0, "fraction of fs"),
                 "velocity": ("stribeck_velocity", 1e-5, 1.0, "m/s")},
    "screw_ripple": {"amplitude": ("ripple_amplitude", 0.0, 1.0, "fraction of fs"),
                     "lead": ("ripple_lead", 1e-4, 1.0, "m")},
}


def _number(value: Any, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ConfigError(f"{where}: expected a number, got {value!r}")
    if not math.isfinite(value):
        raise ConfigError(f"{where}: expected a finite number, got {value!r}")
    return float(value)


def apply_overrides(
    params: TrueParameters, data: Mapping[str, Any], source: str = "overrides"
) -> TrueParameters:
    """Return ``params`` with the entries of ``data`` (same layout as config/plant.yaml) applied."""
    if not isinstance(data, Mapping):
        raise ConfigError(f"{source}: top level must be a mapping with keys {sorted(_TOP_KEYS)}")
    if "screw_ripple" in data:
        raise ConfigError(f"{source}: screw_ripple is now a setting of a plant profile: "
                          "profiles.<name>.screw_ripple {amplitude: fraction of fs, lead: m}")
    unknown = set(data) - _TOP_KEYS
    if unknown:
        raise ConfigError(
            f"{source}: unknown key(s) {sorted(unknown)}; allowed: {sorted(_TOP_KEYS)}"
        )
    values = dict(params.values)
    g_tau = params.g_tau
    payloads = {k: v.copy() for k, v in params.payloads.items()}
    coulomb = dict(params.coulomb_velocity)
    profiles = dict(params.profiles)
    if "g_tau" in data:
        g = data["g_tau"]
        if not isinstance(g, (list, tuple)) or len(g) != 3:
            raise ConfigError(f"{source}: g_tau must be a list of 3 drive gains in N/A, got {g!r}")
        g_tau = tuple(_number(v, f"{source}: g_tau[{k}]") for k, v in enumerate(g))
        if min(g_tau) <= 0:
            raise ConfigError(f"{source}: g_tau must be positive, got {g_tau}")
    for name, v in (data.get("parameters") or {}).items():
        if name not in values:
            raise ConfigError(
                f"{source}: unknown standard parameter {name!r} (e.g. xx_11, ia_12, m_6)"
            )
        values[name] = _number(v, f"{source}: parameters.{name}")
    for pname, pdata in (data.get("payloads") or {}).items():
        pname = str(pname)
        if not isinstance(pdata, Mapping):
            raise ConfigError(f"{source}: payloads.{pname} must map xx_7..m_7 to numbers")
        vec = payloads.get(pname, np.zeros(10)).copy()
        for name, v in pdata.items():
            if name not in PAYLOAD_NAMES:
                raise ConfigError(
                    f"{source}: payloads.{pname}: unknown parameter {name!r} (xx_7..m_7)"
                )
            vec[PAYLOAD_NAMES.index(name)] = _number(v, f"{source}: payloads.{pname}.{name}")
        if vec[9] <= 0:
            raise ConfigError(f"{source}: payloads.{pname}: m_7 must be positive")
        payloads[pname] = vec
    for name, v in (data.get("coulomb_velocity") or {}).items():
        if name not in coulomb:
            raise ConfigError(
                f"{source}: coulomb_velocity: unknown key {name!r} (prismatic, revolute)"
            )
        coulomb[name] = _number(v, f"{source}: coulomb_velocity.{name}")
        if coulomb[name] <= 0:
            raise ConfigError(f"{source}: coulomb_velocity.{name} must be positive")
    pdata = data.get("profiles") or {}
    if not isinstance(pdata, Mapping):
        raise ConfigError(f"{source}: profiles must map profile names to their settings")
    for pname, pd in pdata.items():
        pname = str(pname)
        profiles[pname] = _profile(profiles.get(pname, PlantProfile(pname)), pd,
                                   f"{source}: profiles.{pname}")
    profile = params.profile
    if "profile" in data:
        profile = str(data["profile"])
        if profile not in profiles:
            raise ConfigError(f"{source}: profile {profile!r} is not defined; "
                              f"known: {', '.join(sorted(profiles))}")
    return replace(params, values=values, g_tau=g_tau, payloads=payloads,
                   coulomb_velocity=coulomb, profiles=profiles, profile=profile)


def _profile(base: PlantProfile, data: Any, where: str) -> PlantProfile:
    """``base`` with the YAML settings ``data`` (layout of config/plant.yaml's profiles) applied."""
    if data is None:
        return base
    if not isinstance(data, Mapping):
        raise ConfigError(f"{where} must be a mapping of settings")
    known = sorted(set(_PROFILE_KEYS) | set(_PROFILE_GROUPS))
    changes: dict[str, float] = {}

    def one(spec: tuple[str, float, float, str], v: Any, at: str) -> None:
        attr, lo, hi, unit = spec
        x = _number(v, at)
        if not (lo <= x <= hi):
            raise ConfigError(f"{at} = {x:g} {unit} is out of range [{lo:g}, {hi:g}] {unit}")
        changes[attr] = x

    for key, v in data.items():
        if key in _PROFILE_KEYS:
            one(_PROFILE_KEYS[key], v, f"{where}.{key}")
        elif key in _PROFILE_GROUPS:
            group = _PROFILE_GROUPS[key]
            if not isinstance(v, Mapping):
                raise ConfigError(f"{where}.{key} must map {', '.join(group)} to numbers")
            for k2, v2 in v.items():
                if k2 not in group:
                    raise ConfigError(f"{where}.{key}: unknown key {k2!r} ({', '.join(group)})")
                one(group[k2], v2, f"{where}.{key}.{k2}")
        else:
            raise ConfigError(f"{where}: unknown key {key!r}; allowed: {', '.join(known)}")
    return replace(base, **changes)


def load_parameters(yaml_path: str | Path | None = None) -> TrueParameters:
    """Default table, with any subset overridden from a YAML file (layout of config/plant.yaml).

    Raises ConfigError with a one-line reason on a missing/unparsable file, unknown keys or
    non-numeric values.
    """
    params = default_parameters()
    if yaml_path is None:
        return params
    path = Path(yaml_path)
    data = unwrap_section(load_yaml(path, "plant parameters"), "plant")
    if data is None:
        return params
    return apply_overrides(params, data, source=str(path))
