"""A serial arm as the simulator reads it: the URDF's joints, limits and inertials, and the robot
YAML's actuated joints, nominal drive gains and payload frame.

    arm = load_arm("ur5")          # a bundled robot name, a robot YAML or a URDF
    arm.joint_names, arm.urdf_text, arm.inertials["upper_arm_link"].mass

A robot YAML's ``locked_joints: {joint: value}`` (a gripper's fingers) and the URDF mimic joints
that follow them are held at those values (``ArmDescription.locked``): the plant welds them there.

The URDF is read here with the standard library's XML parser, apart from both dynamics engines
that load it too (MuJoCo for the plant, Pinocchio for the check and the regressor). Only the
robot YAML's location rules come from the product (``orthoglide_ident.model.registry``).

Units: m, rad, kg, kg·m²; gains N·m/A (revolute) or N/A (prismatic).
"""
from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.model import registry

MOVABLE = ("revolute", "continuous", "prismatic")


def rpy_matrix(rpy) -> np.ndarray:
    """URDF's fixed-axis roll-pitch-yaw rotation R = Rz(yaw) Ry(pitch) Rx(roll)."""
    r, p, y = (float(v) for v in rpy)
    cr, sr, cp, sp, cy, sy = (
        math.cos(r),
        math.sin(r),
        math.cos(p),
        math.sin(p),
        math.cos(y),
        math.sin(y),
    )
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]])


@dataclass(frozen=True)
class LinkInertial:
    """A link's URDF inertial: mass (kg), centre of mass (3,) m in the link frame, inertia (3, 3)
    kg·m² about the centre of mass in the link's axes."""

    mass: float
    com: np.ndarray
    inertia: np.ndarray


@dataclass(frozen=True)
class ArmJoint:
    """An actuated joint: its child link, URDF limits (m or rad, m/s or rad/s, N or N·m) and the
    manufacturer's drive gain."""

    name: str
    kind: str  # "revolute" | "prismatic" ("continuous" is revolute without position limits)
    child: str
    lower: float
    upper: float
    velocity: float
    effort: float
    nominal_gain: float


@dataclass(frozen=True)
class ArmDescription:
    """A serial arm: every movable joint actuated, in chain order from the base."""

    name: str
    urdf_path: Path
    urdf_text: str
    joints: tuple[ArmJoint, ...]
    inertials: dict[str, LinkInertial]  # link name -> URDF inertial (links without one: absent)
    payload_frame: str
    locked: dict[str, float] = field(default_factory=dict)  # joint -> value held (m or rad)

    @property
    def joint_names(self) -> tuple[str, ...]:
        return tuple(j.name for j in self.joints)

    @property
    def n(self) -> int:
        return len(self.joints)

    @property
    def nominal_gains(self) -> np.ndarray:
        """(n,) the manufacturer's drive gains, N·m/A or N/A."""
        return np.array([j.nominal_gain for j in self.joints])


def _floats(text: str | None, n: int, where: str) -> np.ndarray:
    try:
        v = np.array([float(x) for x in (text or " ".join(["0"] * n)).split()])
    except ValueError:
        raise ConfigError(f"{where}: expected {n} numbers, got {text!r}") from None
    if v.shape != (n,) or not np.all(np.isfinite(v)):
        raise ConfigError(f"{where}: expected {n} finite numbers, got {text!r}")
    return v


def _inertial(link: ET.Element, where: str) -> LinkInertial | None:
    el = link.find("inertial")
    if el is None:
        return None
    mass = float(el.find("mass").get("value"))
    origin = el.find("origin")
    xyz = _floats(None if origin is None else origin.get("xyz"), 3, f"{where} origin xyz")
    rpy = _floats(None if origin is None else origin.get("rpy"), 3, f"{where} origin rpy")
    i = el.find("inertia")
    xx, xy, xz, yy, yz, zz = (
        float(i.get(k, "0")) for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
    )
    R = rpy_matrix(rpy)
    I_origin = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
    return LinkInertial(mass, xyz, R @ I_origin @ R.T)


def parse_urdf(text: str, where: str) -> tuple[list[tuple[str, str, str, str, ET.Element]],
                                                dict[str, LinkInertial]]:
    """The URDF's joints (name, type, parent, child, element) and link inertials."""
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise ConfigError(f"{where}: not a valid URDF ({exc})") from None
    if root.tag != "robot":
        raise ConfigError(f"{where}: not a URDF (root element <{root.tag}>, expected <robot>)")
    inertials = {}
    for link in root.findall("link"):
        inertial = _inertial(link, f"{where}: link {link.get('name')}")
        if inertial is not None:
            inertials[link.get("name")] = inertial
    joints = [
        (j.get("name"), j.get("type"), j.find("parent").get("link"), j.find("child").get("link"), j)
        for j in root.findall("joint")
    ]
    return joints, inertials


def arm_joint(el: ET.Element, kind: str, child: str, gain: float) -> ArmJoint:
    lim = el.find("limit")
    get = (lambda k, d: float(lim.get(k, d))) if lim is not None else (lambda k, d: float(d))
    lower, upper = (
        (get("lower", "-inf"), get("upper", "inf"))
        if kind != "continuous"
        else (-math.inf, math.inf)
    )
    return ArmJoint(el.get("name"), "prismatic" if kind == "prismatic" else "revolute", child,
                    lower, upper, get("velocity", "inf"), get("effort", "inf"), gain)


def locked_values(joints, listed: dict, where: str) -> dict[str, float]:
    """The robot file's ``locked_joints`` and the URDF mimic joints following them (r·v + o)."""
    kinds = {j[0]: j[1] for j in joints}
    locked = {}
    for name, value in (listed or {}).items():
        if kinds.get(name) not in MOVABLE:
            raise ConfigError(f"{where}: locked joint {name!r} is not a movable joint of the URDF")
        locked[str(name)] = float(value)
    for name, _, _, _, el in joints:
        mimic = el.find("mimic")
        if mimic is not None and mimic.get("joint") in locked and name not in locked:
            locked[name] = (float(mimic.get("multiplier", "1")) * locked[mimic.get("joint")]
                            + float(mimic.get("offset", "0")))
    return locked


def _serial_joints(
    joints, actuated: list[str], gains: list[float], where: str, locked: dict[str, float]
) -> tuple[ArmJoint, ...]:
    """The movable joints in chain order, the locked ones left out; ConfigError unless they form
    one chain, all actuated."""
    movable = [j for j in joints if j[1] in MOVABLE and j[0] not in locked]
    names = [j[0] for j in movable]
    if sorted(names) != sorted(actuated):
        raise ConfigError(f"{where}: the arm simulator needs every movable joint actuated; movable "
                          f"{names}, actuated {actuated}")
    parent_of = {j[3]: (j[2], j) for j in joints}
    order = []
    for name, kind, parent, child, el in movable:  # depth of each movable joint along its chain
        depth, link = 0, parent
        while link in parent_of:
            link, depth = parent_of[link][0], depth + 1
        order.append((depth, name, kind, child, el))
    order.sort()
    for (_, n0, _, c0, _), (_, n1, _, _, el1) in zip(order, order[1:]):
        link = el1.find("parent").get("link")  # up from joint n1 through fixed joints only
        while link != c0 and link in parent_of and parent_of[link][1][1] == "fixed":
            link = parent_of[link][0]
        if link != c0:
            raise ConfigError(f"{where}: joint {n1} does not follow {n0} in one serial chain "
                              "(the arm simulator takes serial arms only)")
    gain_of = dict(zip(actuated, gains))
    return tuple(arm_joint(el, kind, child, gain_of[name]) for _, name, kind, child, el in order)


def load_arm(spec: str | Path = "ur5") -> ArmDescription:
    """The arm ``spec`` names: a bundled robot (``ur5``), a robot YAML or a URDF (then every movable
    joint is actuated with gain 1 and the payload frame is the last link). ConfigError on a file
    that does not parse or a robot that is not a serial arm."""
    path = registry.resolve(spec)
    if path is None:
        raise ConfigError(
            "the Orthoglide has its own simulator (orthoglide_sim.orthoglide.record); "
            "give the arm simulator a serial arm (e.g. ur5, a URDF or a robot YAML)"
        )
    data = ({"description": path.name} if path.suffix.lower() == ".urdf"
            else registry.read_yaml(path))
    urdf_path = (path.parent / str(data.get("description", ""))).resolve()
    if urdf_path.suffix.lower() != ".urdf" or not urdf_path.is_file():
        raise ConfigError(
            f"robot file {path}: description {data.get('description')!r} is not a URDF file"
        )
    text = urdf_path.read_text()
    joints, inertials = parse_urdf(text, str(urdf_path))
    movable = [j[0] for j in joints if j[1] in MOVABLE]
    actuated = [str(a) for a in data.get("actuated_joints") or movable]
    given = data.get("nominal_gains") or 1.0
    gains = [float(g) for g in (given if isinstance(given, list) else [given] * len(actuated))]
    if len(gains) != len(actuated):
        raise ConfigError(
            f"robot file {path}: {len(gains)} nominal gains for {len(actuated)} joints"
        )
    locked = locked_values(joints, data.get("locked_joints"), str(path))
    arm_joints = _serial_joints(joints, actuated, gains, str(path), locked)
    name = str(data.get("name") or urdf_path.stem)
    frame = str(data.get("payload_frame") or arm_joints[-1].child)
    return ArmDescription(name, urdf_path, text, arm_joints, inertials, frame, locked)
