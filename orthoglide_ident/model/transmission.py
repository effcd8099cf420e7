"""Drive chains between motors and joints: a linear transmission q̇_m = N q̇_j (issue 33).

A :class:`Transmission` holds the reduction matrix N (n_a × n_j, square and regular here), the
motor-side position offset and which side the hardware publishes positions and efforts on:

    q_m = N q_j + offset,   q̇_m = N q̇_j,   q̈_m = N q̈_j,   τ_j = Nᵀ τ_m   (virtual work)

It is read from a robot YAML's ``transmission:`` key (docs/guide/robot_files.md) or from the
``<transmission>`` elements of a URDF's ``<ros2_control>`` blocks, with ros2_control's
transmission_interface formulas (joint → actuator):

- SimpleTransmission, reduction n (may be negative), joint offset o:
  q_a = n (q_j − o), q̇_a = n q̇_j, τ_a = τ_j / n;
- DifferentialTransmission, actuator reductions a1, a2, joint reductions j1, j2:
  q̇_a1 = a1 (j1 q̇_j1 + j2 q̇_j2), q̇_a2 = a2 (j1 q̇_j1 − j2 q̇_j2);
- FourBarLinkageTransmission: q̇_a1 = j1 a1 q̇_j1, q̇_a2 = a2 (q̇_j1 + j2 q̇_j2).

The effort map is always τ_j = Nᵀ τ_m (power in = power out). For the simple and differential
transmissions this is ros2_control's own effort formula; for the four-bar linkage ros2_control's
effort formula is not the transpose of its velocity map (it does not conserve power), and the
identification follows the kinematics (tests/model/test_transmission.py shows both).
"""
from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from orthoglide_ident.errors import ConfigError

POSITION_SIDES = ("joint", "actuator")  # where the hardware publishes positions
EFFORT_SIDES = ("actuator", "joint")  # where a current (or effort) acts
MAX_CONDITION = 1e12  # N beyond this condition number is singular for identification
PLUGINS = ("transmission_interface/SimpleTransmission",
           "transmission_interface/DifferentialTransmission",
           "transmission_interface/FourBarLinkageTransmission")
TRANSMISSION_KEYS = ("actuators", "reduction", "offset", "position_side", "effort_side")


@dataclass(frozen=True)
class Transmission:
    """q̇_m = N q̇_j over ``joints`` (columns) and ``actuators`` (rows); see the module docstring.

    Samples are rows (m, n) as everywhere in the product: ``to_actuator_position(q_j)`` is
    q_j Nᵀ + offset for every sample at once."""

    joints: tuple[str, ...]
    actuators: tuple[str, ...]
    N: np.ndarray  # (n_a, n_j)
    offset: np.ndarray  # (n_a,) rad or m, motor side
    position_side: str = "joint"
    effort_side: str = "actuator"
    where: str = "transmission"  # the file, for messages

    def __post_init__(self) -> None:
        N = np.asarray(self.N, float)
        n_a, n_j = len(self.actuators), len(self.joints)
        if N.shape != (n_j, n_j):
            raise ConfigError(f"{self.where}: transmission: reduction must be {n_j} × {n_j} (a "
                              f"row per motor, a column per actuated joint), got {N.shape}")
        if n_a != n_j:
            raise ConfigError(f"{self.where}: transmission: {n_a} actuators for {n_j} joints")
        if not np.all(np.isfinite(N)) or np.linalg.cond(N) > MAX_CONDITION:
            raise ConfigError(f"{self.where}: transmission: reduction {N.tolist()} is singular "
                              "(a motor velocity must give back the joint velocities)")
        for names, what in ((self.actuators, "actuators"), (self.joints, "joints")):
            if len(set(names)) != len(names):
                raise ConfigError(f"{self.where}: transmission: {what} lists a name twice: "
                                  f"{list(names)}")
        off = np.asarray(self.offset, float).reshape(-1)
        if off.shape != (n_a,) or not np.all(np.isfinite(off)):
            raise ConfigError(f"{self.where}: transmission: offset needs {n_a} finite numbers "
                              f"(motor side), got {self.offset!r}")
        if self.position_side not in POSITION_SIDES or self.effort_side not in EFFORT_SIDES:
            raise ConfigError(f"{self.where}: transmission: position_side is joint|actuator and "
                              f"effort_side actuator|joint, got {self.position_side!r}, "
                              f"{self.effort_side!r}")
        object.__setattr__(self, "N", N)
        object.__setattr__(self, "offset", off)
        object.__setattr__(self, "N_inv", np.linalg.inv(N))

    # --- joint ↔ actuator, samples as rows ---------------------------------------------------
    def to_actuator_position(self, q_j: np.ndarray) -> np.ndarray:
        return np.asarray(q_j, float) @ self.N.T + self.offset

    def to_joint_position(self, q_m: np.ndarray) -> np.ndarray:
        return (np.asarray(q_m, float) - self.offset) @ self.N_inv.T

    def to_actuator_rate(self, qd_j: np.ndarray) -> np.ndarray:
        """q̇_m = N q̇_j (velocities and accelerations alike)."""
        return np.asarray(qd_j, float) @ self.N.T

    def to_joint_rate(self, qd_m: np.ndarray) -> np.ndarray:
        return np.asarray(qd_m, float) @ self.N_inv.T

    def to_joint_effort(self, tau_m: np.ndarray) -> np.ndarray:
        """τ_j = Nᵀ τ_m."""
        return np.asarray(tau_m, float) @ self.N

    def to_actuator_effort(self, tau_j: np.ndarray) -> np.ndarray:
        """τ_m = N⁻ᵀ τ_j."""
        return np.asarray(tau_j, float) @ self.N_inv

    @property
    def is_diagonal(self) -> bool:
        return not np.any(self.N - np.diag(np.diag(self.N)))

    def describe(self) -> str:
        rows = "; ".join(" ".join(f"{x:g}" for x in r) for r in self.N)
        return (f"transmission over {', '.join(self.joints)}: motors {', '.join(self.actuators)}, "
                f"q̇_m = N q̇_j with N = [{rows}], positions {self.position_side}-side, "
                f"efforts {self.effort_side}-side")


def _matrix(where: str, value: Any) -> np.ndarray:
    if not isinstance(value, list) or not value or \
            not all(isinstance(r, list) and r for r in value):
        raise ConfigError(f"{where}: transmission: reduction: expected a list of rows of numbers "
                          f"(N, actuators × joints), got {value!r}")
    if len({len(r) for r in value}) != 1:
        raise ConfigError(f"{where}: transmission: reduction: rows of different lengths "
                          f"{[len(r) for r in value]}")
    if not all(isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)
               for r in value for x in r):
        raise ConfigError(f"{where}: transmission: reduction: every entry must be a number")
    return np.array(value, float)


def read_transmission(value: Any, joints: Sequence[str], where: str) -> Transmission:
    """The robot YAML's ``transmission:`` mapping over the actuated ``joints`` (N's columns in
    that order)."""
    if not isinstance(value, dict):
        raise ConfigError(
            f"{where}: transmission: expected a mapping ({', '.join(TRANSMISSION_KEYS)})"
            f", got {value!r}"
        )
    unknown = sorted(set(value) - set(TRANSMISSION_KEYS))
    if unknown or "reduction" not in value:
        raise ConfigError(
            f"{where}: transmission: "
            f"{'unknown keys ' + str(unknown) if unknown else 'reduction is missing'}"
            f" (known: {', '.join(TRANSMISSION_KEYS)})"
        )
    N = _matrix(where, value["reduction"])
    actuators = value.get("actuators", [f"motor_{k + 1}" for k in range(N.shape[0])])
    if isinstance(actuators, str) or not isinstance(actuators, list) or \
            not all(isinstance(a, str) and a for a in actuators):
        raise ConfigError(f"{where}: transmission: actuators: expected a list of names, got "
                          f"{actuators!r}")
    offset = value.get("offset", [0.0] * N.shape[0])
    if not isinstance(offset, list) or not all(isinstance(x, (int, float)) for x in offset):
        raise ConfigError(f"{where}: transmission: offset: expected a list of numbers (rad or m, "
                          f"motor side), got {offset!r}")
    return Transmission(tuple(joints), tuple(actuators), N, np.array(offset, float),
                        str(value.get("position_side", "joint")),
                        str(value.get("effort_side", "actuator")), where)


# --- URDF <ros2_control> -------------------------------------------------------------------------
@dataclass(frozen=True)
class _Block:
    """One ``<transmission>``: its joints, actuators, N block and joint-side offsets."""

    joints: tuple[str, ...]
    actuators: tuple[str, ...]
    N: np.ndarray
    joint_offset: np.ndarray


def _number(el: ET.Element | None, tag: str, default: float, where: str) -> float:
    child = None if el is None else el.find(tag)
    if child is None or not (child.text or "").strip():
        return default
    try:
        return float(child.text)
    except ValueError:
        raise ConfigError(f"{where}: <{tag}> {child.text!r} is not a number") from None


def _roles(elements: list[ET.Element], kind: str, count: int, where: str) -> list[ET.Element]:
    """Joint or actuator elements in role order (joint1, joint2 ...; document order if none)."""
    if len(elements) != count:
        raise ConfigError(f"{where}: needs {count} <{kind}> element(s), has {len(elements)}")
    if all(e.get("role") for e in elements):
        return sorted(elements, key=lambda e: e.get("role"))
    return elements


def _block(t: ET.Element, where: str) -> _Block:
    plugin = (t.findtext("plugin") or t.findtext("type") or "").strip()
    name = f"{where}: transmission {t.get('name', '?')!r}"
    if plugin not in PLUGINS:
        raise ConfigError(f"{name}: type {plugin!r} is not supported ({', '.join(PLUGINS)})")
    n = 1 if plugin.endswith("SimpleTransmission") else 2
    joints = _roles(t.findall("joint"), "joint", n, name)
    acts = _roles(t.findall("actuator"), "actuator", n, name)
    jr = [_number(j, "mechanical_reduction", 1.0, name) for j in joints]
    ar = [_number(a, "mechanical_reduction", 1.0, name) for a in acts]
    if n == 1:  # ros2_control reads the joint's reduction; a ROS 1 file puts it on the actuator
        has_joint = joints[0].find("mechanical_reduction") is not None
        N = np.array([[jr[0] if has_joint else ar[0]]])
    elif plugin.endswith("DifferentialTransmission"):
        N = np.array([[ar[0] * jr[0], ar[0] * jr[1]], [ar[1] * jr[0], -ar[1] * jr[1]]])
    else:
        N = np.array([[jr[0] * ar[0], 0.0], [ar[1], ar[1] * jr[1]]])
    if not np.all(N[np.nonzero(N)] != 0) or np.any(np.array(jr + ar) == 0):
        raise ConfigError(f"{name}: a mechanical_reduction is zero")
    names = [e.get("name") or "" for e in joints + acts]
    if not all(names):
        raise ConfigError(f"{name}: every <joint> and <actuator> needs a name")
    off = np.array([_number(j, "offset", 0.0, name) for j in joints])
    return _Block(tuple(names[:n]), tuple(names[n:]), N, off)


def urdf_transmission(path: Path, joints: Sequence[str]) -> Transmission | None:
    """The transmission of a URDF's ``<ros2_control>`` ``<transmission>`` elements over the
    actuated ``joints`` (a joint no transmission names keeps a unit one, its motor named after
    it), or None when it has none."""
    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, OSError):
        return None  # the tree loader has said what is wrong with the file
    where = f"URDF {path.name}"
    elements = [t for rc in root.iter("ros2_control") for t in rc.findall("transmission")]
    if not elements:
        return None
    index = {j: k for k, j in enumerate(joints)}
    n = len(joints)
    N, offset, actuators = np.eye(n), np.zeros(n), list(joints)
    for t in elements:
        b = _block(t, where)
        bad = [j for j in b.joints if j not in index]
        if bad:
            raise ConfigError(f"{where}: transmission {t.get('name', '?')!r} names {bad}, not "
                              f"actuated joints (actuated: {', '.join(joints)})")
        cols = [index[j] for j in b.joints]
        for r, c in enumerate(cols):  # a block's motors take its joints' rows
            N[c] = 0.0
            N[c, cols] = b.N[r]
            actuators[c] = b.actuators[r]
        offset[cols] = -b.N @ b.joint_offset  # q_a = N (q_j − o): motor-side offset −N o
    return Transmission(tuple(joints), tuple(actuators), N, offset, where=where)
