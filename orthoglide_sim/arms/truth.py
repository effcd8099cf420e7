"""The simulated serial arm's truth: every link's rigid body, every joint's drive and friction,
the payloads, the noise. What the identification is meant to find, kept apart from it.

Each link is its URDF inertial perturbed into another physically consistent rigid body: mass
scaled, centre of mass moved in all three axes, principal moments scaled and the principal axes
tilted (so the inertia about the centre of mass has off-diagonal terms), checked to be positive
definite and to satisfy the triangle inequality. Every standard parameter of every moving body
is then non-zero and differs from the URDF's (tests/sim/arms/test_mujoco_plant.py). Each actuated
joint has a rotor inertia (MuJoCo armature), viscous damping, Coulomb friction (MuJoCo
frictionloss, a soft constraint: it turns smoothly through zero velocity, as a real joint's),
a constant offset torque and a drive gain g_tau a few % off the manufacturer's.

The UR5's values are the table below; another arm gets a seeded rule of the same sizes. Both are
overridable from YAML (config/arm_plant.yaml).

Units: kg, m, kg·m², N·m·s/rad, N·m, N·m/A (prismatic joints: kg, N·s/m, N, N/A).
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
from orthoglide_sim.arms.description import ArmDescription, LinkInertial, rpy_matrix

# m/s² along -z of the URDF's world: standard gravity, as the product's robot files
GRAVITY = 9.80665
CURRENT_NOISE_FRACTION = 0.005  # std of the current noise / each joint's rms current (issue 24)
ENCODER_COUNTS = 2**19  # counts per revolution of a revolute joint's encoder
LINEAR_ENCODER_RESOLUTION = 1.0e-6  # m, a prismatic joint's encoder step

# UR5 links: (mass factor, centre-of-mass shift (3,) m, principal-moment factors (3,),
# tilt of the principal axes (3,) rad, x-y-z angles). The wrist links' URDF moments sit near the
# triangle inequality (Izz ~ Ixx + Iyy), the arm links' too (slender: Ixx ~ Iyy + Izz): their
# factors keep them on the physical side.
UR5_LINKS: dict[str, tuple[float, tuple, tuple, tuple]] = {
    "base_link": (1.030, (0.003, 0.002, 0.004), (1.05, 0.97, 1.02), (0.02, 0.03, 0.01)),
    "shoulder_link": (1.045, (0.004, -0.012, 0.009), (1.06, 0.95, 1.08), (0.06, -0.04, 0.09)),
    "upper_arm_link": (0.968, (0.011, 0.007, -0.015), (1.06, 1.09, 1.10), (-0.05, 0.03, 0.07)),
    "forearm_link": (1.052, (-0.006, 0.010, 0.013), (0.97, 1.02, 0.92), (0.04, 0.06, -0.05)),
    "wrist_1_link": (0.957, (0.005, -0.008, 0.004), (1.06, 1.04, 1.03), (0.07, -0.05, 0.04)),
    "wrist_2_link": (1.061, (-0.007, 0.004, 0.006), (1.03, 1.05, 1.02), (-0.06, 0.08, 0.05)),
    "wrist_3_link": (0.936, (0.003, 0.006, -0.005), (1.05, 1.04, 1.02), (0.05, 0.07, -0.06)),
}
# UR5 joints: (armature kg·m², damping N·m·s/rad, frictionloss N·m, offset N·m, g_tau / nominal
# gain): the true gains 13.546, 12.584, 13.403, 8.900, 9.746, 9.068 N·m/A of the nominal
# 13.0 / 9.3 (the factor applies to whatever nominal gain the robot file gives).
UR5_JOINTS: dict[str, tuple[float, float, float, float, float]] = {
    "shoulder_pan_joint": (0.35, 2.4, 5.1, 0.42, 1.042),
    "shoulder_lift_joint": (0.33, 2.9, 5.8, -0.55, 0.968),
    "elbow_joint": (0.27, 1.9, 4.2, 0.31, 1.031),
    "wrist_1_joint": (0.098, 0.62, 1.45, -0.12, 0.957),
    "wrist_2_joint": (0.091, 0.55, 1.32, 0.09, 1.048),
    "wrist_3_joint": (0.087, 0.51, 1.21, -0.07, 0.975),
}
# Payloads fixed to the payload frame (tool0): (mass, centre of mass, principal moments, tilt).
# "2.0": the 2 kg off-centre payload of the loaded TLS record; "1.0": the WLS check's.
PAYLOADS: dict[str, tuple[float, tuple, tuple, tuple]] = {
    "2.0": (2.0, (0.035, -0.025, 0.060), (4.2e-3, 3.6e-3, 2.4e-3), (0.10, -0.15, 0.20)),
    "1.0": (1.0, (-0.020, 0.030, 0.045), (1.6e-3, 1.3e-3, 0.9e-3), (-0.08, 0.12, 0.05)),
}
DEFAULT_SEED = 24  # the seeded rule of an arm without a table


def _symmetric(I: np.ndarray) -> np.ndarray:
    """I made exactly symmetric (R diag Rᵀ is only symmetric to round-off)."""
    return 0.5 * (I + I.T)


def tilt_matrix(tilt) -> np.ndarray:
    """Rotation Rx(a) Ry(b) Rz(c) of the principal axes for tilt (a, b, c) rad."""
    a, b, c = tilt
    return rpy_matrix((a, 0, 0)) @ rpy_matrix((0, b, 0)) @ rpy_matrix((0, 0, c))


@dataclass(frozen=True)
class RigidBody:
    """Mass (kg), centre of mass (3,) m in the link frame, inertia (3, 3) kg·m² about the centre
    of mass in the link's axes."""

    mass: float
    com: np.ndarray
    inertia: np.ndarray

    def check(self, where: str) -> None:
        """ConfigError unless physically consistent: m > 0, inertia symmetric positive definite
        with principal moments meeting the triangle inequality (pseudo-inertia ⪰ 0)."""
        I = np.asarray(self.inertia)
        if not (
            self.mass > 0 and np.all(np.isfinite(I)) and np.allclose(I, I.T, rtol=0, atol=1e-15)
        ):
            raise ConfigError(f"{where}: needs a positive mass and a symmetric inertia")
        lam = np.linalg.eigvalsh(I)
        if lam[0] <= 0 or lam[2] > lam[0] + lam[1]:
            raise ConfigError(
                f"{where}: principal moments {lam.tolist()} kg·m² are not positive or "
                "break the triangle inequality (Ia <= Ib + Ic)"
            )

    def standard(self) -> np.ndarray:
        """(10,) standard parameters xx, xy, xz, yy, yz, zz (at the link origin), mx, my, mz, m."""
        c = np.asarray(self.com, float)
        I_O = self.inertia + self.mass * (c @ c * np.eye(3) - np.outer(c, c))  # Huygens-Steiner
        return np.array([I_O[0, 0], I_O[0, 1], I_O[0, 2], I_O[1, 1], I_O[1, 2], I_O[2, 2],
                         *(self.mass * c), self.mass])

    @classmethod
    def from_principal(cls, mass: float, com, principal, tilt) -> RigidBody:
        R = tilt_matrix(tilt)
        return cls(float(mass), np.asarray(com, float), _symmetric(R @ np.diag(principal) @ R.T))


def perturbed(nominal: LinkInertial, mass_factor: float, shift, moment_factors, tilt) -> RigidBody:
    """The URDF inertial ``nominal`` made another rigid body: mass × factor, centre of mass +
    shift, principal moments × factors, principal axes tilted (in the URDF's own axes when its
    inertia is diagonal)."""
    I = np.asarray(nominal.inertia, float)
    if np.count_nonzero(I - np.diag(np.diag(I))) == 0:
        lam, axes = np.diag(I).copy(), np.eye(3)
    else:
        lam, axes = np.linalg.eigh(I)
    R = tilt_matrix(tilt) @ axes
    return RigidBody(nominal.mass * mass_factor, nominal.com + np.asarray(shift, float),
                     _symmetric(R @ np.diag(lam * np.asarray(moment_factors)) @ R.T))


@dataclass(frozen=True)
class JointDrive:
    """One actuated joint's drive and friction: armature (kg·m²), damping (N·m·s/rad),
    frictionloss = Coulomb level (N·m), offset torque (N·m), true drive gain g_tau (N·m/A)."""

    armature: float
    damping: float
    frictionloss: float
    offset: float
    g_tau: float


@dataclass(frozen=True)
class ArmPayload:
    """A payload fixed to ``frame``: its rigid body (centre of mass and inertia in that frame)."""

    name: str
    frame: str
    body: RigidBody

    @property
    def mass(self) -> float:
        return self.body.mass

    def tag(self) -> dict[str, Any]:
        """The payload's frame, centre of mass (m) and inertia about it (kg·m², Ixx Ixy Ixz Iyy
        Iyz Izz): write_bag's ``payload``, which tags the bag with them
        (docs/design/interfaces.md)."""
        I = self.body.inertia
        return {"payload_frame": self.frame,
                "payload_com": tuple(float(v) for v in self.body.com),
                "payload_inertia": (float(I[0, 0]), float(I[0, 1]), float(I[0, 2]),
                                    float(I[1, 1]), float(I[1, 2]), float(I[2, 2]))}


@dataclass(frozen=True)
class ArmTruth:
    """Everything the arm plant is made of, by link and joint name."""

    arm: ArmDescription
    bodies: dict[str, RigidBody]  # link -> true rigid body (links of positive URDF mass)
    drives: dict[str, JointDrive]  # actuated joint -> drive
    payloads: dict[str, ArmPayload] = field(default_factory=dict)
    current_noise_fraction: float = CURRENT_NOISE_FRACTION
    encoder_counts: int = ENCODER_COUNTS
    gravity: float = GRAVITY

    def drive_array(self, key: str) -> np.ndarray:
        """(n,) one JointDrive field over the actuated joints in order, e.g. "g_tau"."""
        return np.array([getattr(self.drives[j], key) for j in self.arm.joint_names])

    @property
    def encoder_resolution(self) -> np.ndarray:
        """(n,) encoder step per joint, rad or m."""
        return np.array([2.0 * math.pi / self.encoder_counts if j.kind == "revolute"
                         else LINEAR_ENCODER_RESOLUTION for j in self.arm.joints])

    def payload(self, name: str | float | None) -> ArmPayload | None:
        """A payload by name ("2.0", "1.0"), None for "none"/0; ConfigError if unknown."""
        if name is None or str(name) in ("none", "0", "0.0"):
            return None
        key = str(name)
        if key not in self.payloads:
            raise ConfigError(
                f"unknown payload {key!r}: use none or one of {', '.join(sorted(self.payloads))}"
            )
        return self.payloads[key]


OFFSET_PAYLOAD = "off"  # with_offset_payload's name
OFFSET_COM = (0.03, 0.0, 0.04)  # m in the payload frame: 5 cm from the flange, 3 cm off its axis


def with_offset_payload(truth: ArmTruth, mass: float = 2.0, com=OFFSET_COM,
                        principal=(4.2e-3, 3.6e-3, 2.4e-3), tilt=(0.10, -0.15, 0.20),
                        name: str = OFFSET_PAYLOAD) -> ArmTruth:
    """``truth`` with one more payload ``name`` at the robot's payload frame: ``mass`` kg, its
    centre of mass at ``com`` (m), principal moments (kg·m²) on axes tilted by ``tilt`` (rad):
    a weighed payload whose CoM the identification is not told (paper Sect. 4.3)."""
    body = RigidBody.from_principal(mass, com, principal, tilt)
    body.check(f"payload {name}")
    return replace(truth, payloads={**truth.payloads,
                                    name: ArmPayload(name, truth.arm.payload_frame, body)})


def seeded_link(nominal: LinkInertial, rng: np.random.Generator) -> RigidBody:
    """An arm without a table: mass ±3-7 %, centre of mass ±3-12 mm per axis, moments ±3-8 %,
    tilt ±0.03-0.1 rad; the largest moment kept 2 % inside the triangle inequality."""
    sign = lambda k: rng.choice([-1.0, 1.0], k)  # noqa: E731
    body = perturbed(
        nominal,
        1 + sign(1)[0] * rng.uniform(0.03, 0.07),
        sign(3) * rng.uniform(3e-3, 12e-3, 3),
        1 + sign(3) * rng.uniform(0.03, 0.08, 3),
        sign(3) * rng.uniform(0.03, 0.1, 3),
    )
    lam, axes = np.linalg.eigh(body.inertia)
    lam[2] = min(lam[2], 0.98 * (lam[0] + lam[1]))
    return replace(body, inertia=_symmetric(axes @ np.diag(lam) @ axes.T))


def seeded_joint(effort: float, nominal_gain: float, rng: np.random.Generator) -> JointDrive:
    """An arm without a table: sizes of the UR5's per N·m of the joint's effort limit."""
    sign = rng.choice([-1.0, 1.0], 2)
    return JointDrive(2.2e-3 * effort, 0.016 * effort, 0.035 * effort, sign[0] * 0.0025 * effort,
                      nominal_gain * (1 + sign[1] * rng.uniform(0.02, 0.06)))


def default_truth(arm: ArmDescription, seed: int = DEFAULT_SEED) -> ArmTruth:
    """The arm's truth: the UR5 table for the UR5's links and joints, the seeded rule otherwise."""
    rng = np.random.default_rng(seed)
    bodies = {
        link: (perturbed(nom, *UR5_LINKS[link]) if link in UR5_LINKS else seeded_link(nom, rng))
        for link, nom in arm.inertials.items()
        if nom.mass > 0
    }
    drives = {}
    for j in arm.joints:
        if j.name in UR5_JOINTS:
            ia, fv, fs, off, factor = UR5_JOINTS[j.name]
            drives[j.name] = JointDrive(ia, fv, fs, off, j.nominal_gain * factor)
        else:
            drives[j.name] = seeded_joint(
                j.effort if math.isfinite(j.effort) else 100.0, j.nominal_gain, rng
            )
    payloads = {
        k: ArmPayload(k, arm.payload_frame, RigidBody.from_principal(*v))
        for k, v in PAYLOADS.items()
    }
    truth = ArmTruth(arm, bodies, drives, payloads)
    for link, body in bodies.items():
        body.check(f"link {link}")
    return truth


# --- YAML overrides (config/arm_plant.yaml) ------------------------------------------------
_TOP_KEYS = {"robot", "seed", "joints", "bodies", "payloads", "current_noise", "encoder_counts"}
_DRIVE_KEYS = ("armature", "damping", "frictionloss", "offset", "g_tau")


def checked_number(v: Any, where: str, lo: float = -math.inf, hi: float = math.inf) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise ConfigError(f"{where}: expected a finite number, got {v!r}")
    if not lo <= v <= hi:
        raise ConfigError(f"{where} = {v:g} is out of range [{lo:g}, {hi:g}]")
    return float(v)


def _vector(v: Any, n: int, where: str) -> np.ndarray:
    if not isinstance(v, (list, tuple)) or len(v) != n:
        raise ConfigError(f"{where}: expected a list of {n} numbers, got {v!r}")
    return np.array([checked_number(x, f"{where}[{k}]") for k, x in enumerate(v)])


def _rigid_body(data: Any, base: RigidBody | None, where: str) -> RigidBody:
    """A rigid body from YAML {mass, com [3], inertia [Ixx Ixy Ixz Iyy Iyz Izz] about the CoM}."""
    if not isinstance(data, Mapping) or set(data) - {"mass", "com", "inertia"}:
        raise ConfigError(f"{where}: expected a mapping of mass (kg), com [x, y, z] (m) and "
                          "inertia [Ixx, Ixy, Ixz, Iyy, Iyz, Izz] (kg·m² about the centre of mass)")
    if base is None and set(data) != {"mass", "com", "inertia"}:
        raise ConfigError(f"{where}: a new body needs mass, com and inertia")
    mass = checked_number(data["mass"], f"{where}.mass", 0.0) if "mass" in data else base.mass
    com = _vector(data["com"], 3, f"{where}.com") if "com" in data else base.com
    if "inertia" in data:
        xx, xy, xz, yy, yz, zz = _vector(data["inertia"], 6, f"{where}.inertia")
        inertia = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
    else:
        inertia = base.inertia
    body = RigidBody(mass, com, inertia)
    body.check(where)
    return body


def apply_overrides(
    truth: ArmTruth, data: Mapping[str, Any], source: str = "overrides"
) -> ArmTruth:
    """``truth`` with the YAML mapping ``data`` (layout of config/arm_plant.yaml) applied."""
    if not isinstance(data, Mapping) or set(data) - _TOP_KEYS:
        raise ConfigError(f"{source}: expected a mapping with keys among {sorted(_TOP_KEYS)}")
    bodies, drives, payloads = dict(truth.bodies), dict(truth.drives), dict(truth.payloads)
    for link, d in (data.get("bodies") or {}).items():
        if link not in bodies:
            raise ConfigError(f"{source}: bodies.{link}: no link of positive mass named so "
                              f"(links: {', '.join(bodies)})")
        bodies[link] = _rigid_body(d, bodies[link], f"{source}: bodies.{link}")
    for joint, d in (data.get("joints") or {}).items():
        if joint not in drives:
            raise ConfigError(
                f"{source}: joints.{joint}: not an actuated joint ({', '.join(drives)})"
            )
        if not isinstance(d, Mapping) or set(d) - set(_DRIVE_KEYS):
            raise ConfigError(
                f"{source}: joints.{joint}: expected a mapping of {', '.join(_DRIVE_KEYS)}"
            )
        values = {
            k: checked_number(
                v, f"{source}: joints.{joint}.{k}", -math.inf if k == "offset" else 0.0
            )
            for k, v in d.items()
        }
        if values.get("g_tau", 1.0) <= 0:
            raise ConfigError(f"{source}: joints.{joint}.g_tau must be positive")
        drives[joint] = replace(drives[joint], **values)
    for name, d in (data.get("payloads") or {}).items():
        name, old = str(name), payloads.get(str(name))
        d = dict(d) if isinstance(d, Mapping) else {"": d}  # a non-mapping: _rigid_body says so
        frame = str(d.pop("frame", old.frame if old else truth.arm.payload_frame))
        payloads[name] = ArmPayload(name, frame, _rigid_body(d, old.body if old else None,
                                                             f"{source}: payloads.{name}"))
    noise = checked_number(
        data.get("current_noise", truth.current_noise_fraction),
        f"{source}: current_noise",
        0.0,
        1.0,
    )
    counts = data.get("encoder_counts", truth.encoder_counts)
    if isinstance(counts, bool) or not isinstance(counts, int) or counts < 2:
        raise ConfigError(f"{source}: encoder_counts must be an integer >= 2, got {counts!r}")
    return replace(truth, bodies=bodies, drives=drives, payloads=payloads,
                   current_noise_fraction=noise, encoder_counts=counts)


def load_truth(arm: ArmDescription, yaml_path: str | Path | None = None) -> ArmTruth:
    """The default truth of ``arm``, with a YAML file's overrides (config/arm_plant.yaml layout:
    an ``arm_plant`` mapping, or its content). ConfigError with a one-line reason on a bad file."""
    if yaml_path is None:
        return default_truth(arm)
    path = Path(yaml_path)
    data = unwrap_section(load_yaml(path, "arm plant"), "arm_plant") or {}
    if isinstance(data, Mapping) and "robot" in data and str(data["robot"]) != arm.name:
        raise ConfigError(f"{path}: describes robot {data['robot']!r}, not {arm.name!r}")
    seed = data.get("seed", DEFAULT_SEED) if isinstance(data, Mapping) else DEFAULT_SEED
    if isinstance(seed, bool) or not isinstance(seed, int):
        raise ConfigError(f"{path}: seed must be an integer, got {seed!r}")
    return apply_overrides(default_truth(arm, seed), data, str(path))
