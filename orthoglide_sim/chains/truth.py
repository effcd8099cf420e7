"""The simulated closed chain's truth: the arm's (arm_truth) for its links, actuated drives,
payloads and noise, and the friction of its passive joints. What the identification is meant
to find, kept apart from it.

Each link is its URDF inertial perturbed into another physically consistent rigid body (mass,
centre of mass in all three axes, principal moments and the tilt of the principal axes:
``arm_truth.perturbed``), so every standard parameter is non-zero and off the URDF's. Every
tree joint has viscous damping, Coulomb friction (MuJoCo frictionloss: smooth through zero
velocity) and a constant offset torque, actuated and passive alike: the product's model has
fv, fs, tauoff columns on a closed chain's passive joints. Only the actuated joints have a
rotor inertia (MuJoCo armature) and a drive gain g_tau a few % off the manufacturer's: a passive
elbow has no rotor, and the model has no ia column there (an armature on joint_3 of the five-bar
leaves 4 % of its column outside the span of the model's 54 standard columns: it is not a
parameter the model could absorb, it would be a model error).

The five-bar's values are the tables below; another closed chain gets arm_truth's seeded rule
for its links and actuated joints, and a fifth of that friction on its passive ones. Both are
overridable from YAML (config/five_bar_plant.yaml): arm_truth's keys, and ``passive_joints``.

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
from orthoglide_sim.arms.truth import (
    DEFAULT_SEED,
    ArmPayload,
    ArmTruth,
    JointDrive,
    RigidBody,
    apply_overrides,
    checked_number,
    perturbed,
    seeded_joint,
    seeded_link,
)
from orthoglide_sim.chains.description import ChainDescription

# Five-bar links: (mass factor, centre-of-mass shift (3,) m, principal-moment factors (3,) in
# ascending order of the URDF's moments, tilt of the principal axes (3,) rad). The links are
# slender (Iyy ~ Ixx + Izz): the factors keep the largest moment 3-7 % inside the triangle
# inequality.
FIVE_BAR_LINKS: dict[str, tuple[float, tuple, tuple, tuple]] = {
    "proximal_1": (1.043, (0.004, 0.003, 0.005), (1.06, 1.04, 1.03), (0.04, -0.03, 0.05)),
    "distal_1": (0.962, (-0.005, -0.002, -0.004), (0.95, 1.05, 1.04), (-0.03, 0.05, 0.04)),
    "proximal_2": (1.036, (0.003, -0.003, 0.004), (1.05, 0.96, 0.95), (0.05, 0.04, -0.03)),
    "distal_2": (0.958, (-0.004, 0.003, -0.004), (1.07, 1.03, 1.02), (-0.04, -0.05, 0.03)),
}
# Five-bar actuated joints: (armature kg·m², damping N·m·s/rad, frictionloss N·m, offset N·m,
# g_tau / nominal gain): a 0.05 N·m/A motor behind a 10:1 gearbox (rotor 6e-6 kg·m² x 100),
# true gains 0.519 and 0.5135 N·m/A of the nominal 0.5: both above it, as the paper's were
# (Sect. 5.3), so that the nominal gains visibly bias the WLS payload check (gains off in
# opposite directions would cancel in the payload's torque shared by both joints).
FIVE_BAR_JOINTS: dict[str, tuple[float, float, float, float, float]] = {
    "joint_1": (6.0e-4, 0.045, 0.12, 0.025, 1.038),
    "joint_2": (5.5e-4, 0.040, 0.10, -0.018, 1.027),
}
# Five-bar passive elbows (damping N·m·s/rad, frictionloss N·m, offset N·m): ball bearings and
# a cable across the joint.
FIVE_BAR_PASSIVE: dict[str, tuple[float, float, float]] = {
    "joint_3": (0.008, 0.025, 0.006),
    "joint_4": (0.007, 0.022, -0.005),
}
# Payloads on the tip (mass kg, centre of mass m in the tip frame, principal moments kg·m²,
# tilt rad): "1.0" the loaded TLS record's, "0.5" the WLS check's. Off-centre, with inertia.
FIVE_BAR_PAYLOADS: dict[str, tuple[float, tuple, tuple, tuple]] = {
    "1.0": (1.0, (0.012, -0.008, 0.020), (8.0e-4, 6.0e-4, 5.0e-4), (0.10, -0.12, 0.15)),
    "0.5": (0.5, (-0.010, 0.012, -0.015), (3.0e-4, 2.5e-4, 2.0e-4), (-0.08, 0.10, 0.06)),
}
PASSIVE_FRACTION = 0.2  # seeded rule: passive friction / the seeded actuated joint's


@dataclass(frozen=True)
class JointFriction:
    """A passive joint's friction: damping (N·m·s/rad), frictionloss = Coulomb level (N·m) and
    offset torque (N·m), against the joint coordinate."""

    damping: float
    frictionloss: float
    offset: float


@dataclass(frozen=True)
class ChainTruth(ArmTruth):
    """The arm's truth of a closed chain (``arm`` a ChainDescription, ``drives`` its actuated
    joints), and the passive joints' friction."""

    passive: dict[str, JointFriction] = field(default_factory=dict)

    def passive_array(self, key: str) -> np.ndarray:
        """(n_p,) one JointFriction field over the passive joints in URDF order."""
        return np.array([getattr(self.passive[j], key) for j in self.arm.passive_names])


def _seeded_passive(effort: float, rng: np.random.Generator) -> JointFriction:
    d = seeded_joint(effort, 1.0, rng)
    return JointFriction(PASSIVE_FRACTION * d.damping, PASSIVE_FRACTION * d.frictionloss,
                         PASSIVE_FRACTION * d.offset)


def default_chain_truth(chain: ChainDescription, seed: int = DEFAULT_SEED) -> ChainTruth:
    """The chain's truth: the five-bar's tables for its links and joints, the seeded rule else."""
    rng = np.random.default_rng(seed)
    bodies = {link: (perturbed(nom, *FIVE_BAR_LINKS[link]) if link in FIVE_BAR_LINKS
                     else seeded_link(nom, rng))
              for link, nom in chain.inertials.items() if nom.mass > 0}
    drives = {}
    for j in chain.joints:
        effort = j.effort if math.isfinite(j.effort) else 100.0
        if j.name in FIVE_BAR_JOINTS:
            ia, fv, fs, off, factor = FIVE_BAR_JOINTS[j.name]
            drives[j.name] = JointDrive(ia, fv, fs, off, j.nominal_gain * factor)
        else:
            drives[j.name] = seeded_joint(effort, j.nominal_gain, rng)
    passive = {j.name: (JointFriction(*FIVE_BAR_PASSIVE[j.name]) if j.name in FIVE_BAR_PASSIVE
                        else _seeded_passive(j.effort if math.isfinite(j.effort) else 100.0, rng))
               for j in chain.passive}
    table = FIVE_BAR_PAYLOADS if chain.name == "five_bar" else {}
    payloads = {
        k: ArmPayload(k, chain.payload_frame, RigidBody.from_principal(*v))
        for k, v in table.items()
    }
    for link, body in bodies.items():
        body.check(f"link {link}")
    return ChainTruth(chain, bodies, drives, payloads, gravity=float(np.linalg.norm(chain.gravity)),
                      passive=passive)


# --- YAML overrides (config/five_bar_plant.yaml) -------------------------------------------
_PASSIVE_KEYS = ("damping", "frictionloss", "offset")


def apply_chain_overrides(
    truth: ChainTruth, data: Mapping[str, Any], source: str = "overrides"
) -> ChainTruth:
    """``truth`` with a YAML mapping applied: arm_truth's keys, and ``passive_joints``."""
    if not isinstance(data, Mapping):
        raise ConfigError(f"{source}: expected a mapping")
    rest = {k: v for k, v in data.items() if k != "passive_joints"}
    passive = dict(truth.passive)
    for joint, d in (data.get("passive_joints") or {}).items():
        if joint not in passive:
            raise ConfigError(f"{source}: passive_joints.{joint}: not a passive joint "
                              f"({', '.join(passive)})")
        if not isinstance(d, Mapping) or set(d) - set(_PASSIVE_KEYS):
            raise ConfigError(f"{source}: passive_joints.{joint}: expected a mapping of "
                              f"{', '.join(_PASSIVE_KEYS)}")
        values = {k: checked_number(v, f"{source}: passive_joints.{joint}.{k}",
                             -math.inf if k == "offset" else 0.0) for k, v in d.items()}
        passive[joint] = replace(passive[joint], **values)
    return replace(apply_overrides(truth, rest, source), passive=passive)


def load_chain_truth(chain: ChainDescription, yaml_path: str | Path | None = None) -> ChainTruth:
    """The default truth of ``chain``, with a YAML file's overrides (a ``chain_plant`` mapping, or
    its content). ConfigError with a one-line reason on a bad file."""
    if yaml_path is None:
        return default_chain_truth(chain)
    path = Path(yaml_path)
    data = unwrap_section(load_yaml(path, "chain plant"), "chain_plant") or {}
    if not isinstance(data, Mapping):
        raise ConfigError(f"{path}: expected a mapping")
    if "robot" in data and str(data["robot"]) != chain.name:
        raise ConfigError(f"{path}: describes robot {data['robot']!r}, not {chain.name!r}")
    seed = data.get("seed", DEFAULT_SEED)
    if isinstance(seed, bool) or not isinstance(seed, int):
        raise ConfigError(f"{path}: seed must be an integer, got {seed!r}")
    return apply_chain_overrides(default_chain_truth(chain, seed), data, str(path))
