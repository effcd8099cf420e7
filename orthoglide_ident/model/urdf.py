"""The identified model as a URDF that Pinocchio and MuJoCo load (``identify --urdf-out``).

- A robot described by a URDF: its own URDF with every body's ``<inertial>`` replaced by the
  identified one (mass, centre of mass, inertia about it, axes of the link), the links merged
  into a body (fixed to it, not bodies themselves) emptied of theirs — Pinocchio merges them, and
  the identified body holds them — and each joint's ``<dynamics damping friction>`` set to its
  fv, fs; rotor inertia ia and offset tauoff, which URDF has no element for, in a comment at
  the joint; the drive gains in a comment at the top.
- The Orthoglide: a URDF of its open tree, written from the MDH frames of docs/conventions.md:
  per leg a prismatic foot (q1i) and four pivots (q2i..q5i), link ``body_<j><i>`` in frame j_i,
  the platform fixed to body 5 of leg 1 at P; the loops are **not** in the file (URDF has no
  closed chains): the product's model closes them (body 5 of legs 2 and 3 welded to the
  platform: links ``platform_on_leg2``, ``platform_on_leg3`` mark where).

A ``<mujoco><compiler .../></mujoco>`` element keeps MuJoCo from merging fixed links or
rebalancing the inertias (Pinocchio ignores it). Every number is written with 17 significant
digits: loaded back, the inertials are the identified ones to round-off.
"""
from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.model.inertia import at_com
from orthoglide_ident.model.robot import RobotModel

MUJOCO_COMPILER = {"discardvisual": "true", "fusestatic": "false", "balanceinertia": "false"}
EFFORT_LIMIT, SPEED_LIMIT = "1e4", "100"  # URDF requires limits; the identification sets none


def _num(x: float) -> str:
    return repr(float(x)) if math.isfinite(x) else "0"


def _vec(v: Sequence[float]) -> str:
    return " ".join(_num(x) for x in v)


def rpy(R: np.ndarray) -> np.ndarray:
    """Roll, pitch, yaw of a rotation matrix (URDF: R = Rz(yaw) Ry(pitch) Rx(roll))."""
    pitch = math.atan2(-R[2, 0], math.hypot(R[0, 0], R[1, 0]))
    if abs(math.cos(pitch)) < 1e-12:  # gimbal lock: yaw 0
        return np.array([math.atan2(-R[1, 2], R[1, 1]), pitch, 0.0])
    return np.array([math.atan2(R[2, 1], R[2, 2]), pitch, math.atan2(R[1, 0], R[0, 0])])


def inertial_element(chi10: np.ndarray) -> ET.Element:
    """``<inertial>`` of a body from its 10 parameters at the link origin (INERTIAL_KINDS)."""
    m, c, I = at_com(chi10)
    el = ET.Element("inertial")
    ET.SubElement(el, "origin", xyz=_vec(c), rpy="0 0 0")
    ET.SubElement(el, "mass", value=_num(m))
    ET.SubElement(el, "inertia", **{k: _num(v) for k, v in
                                    zip(("ixx", "ixy", "ixz", "iyy", "iyz", "izz"), I)})
    return el


def body_label(robot: RobotModel, body) -> str:
    """The suffix of a body's parameter names (``m_21`` → ``21``): its joint's drive terms are
    ``fv_<label>``... (docs/conventions.md; the general model names them the same way)."""
    return robot.standard_names[body.inertial[-1]].split("_", 1)[1]


def joint_comment(name: str, values: Mapping[str, float], label: str, unit: str) -> str:
    """The drive terms a URDF has no element for, as text."""
    parts = [f"{k}_{label} = {values[f'{k}_{label}']:.6g}" for k in ("ia", "fv", "fs", "tauoff")
             if f"{k}_{label}" in values]
    return (f" joint {name}: " + ", ".join(parts) + f" ({unit}; ia is the rotor inertia "
            "(armature), fv/fs are also in <dynamics> as damping/friction, tauoff is a constant "
            "offset against the joint coordinate) ")


def header_comment(robot: RobotModel, gains: Sequence[float], what: str) -> str:
    units = robot.gain_units
    g = ", ".join(f"{j} {x:.6g} {u}" for j, x, u in zip(robot.joint_names, gains, units))
    return (f" Identified by orthoglide-ident (IDIM-TLS, Briot & Gautier 2013) with physically "
            f"consistent standard parameters (pseudo-inertias positive semidefinite). {what} "
            f"Drive gains (actuator effort = g_tau x current reference): {g}. ")


def _dynamics(joint: ET.Element, values: Mapping[str, float], label: str) -> None:
    fv, fs = values.get(f"fv_{label}"), values.get(f"fs_{label}")
    if fv is None and fs is None:
        return
    dyn = joint.find("dynamics")
    if dyn is None:
        dyn = ET.SubElement(joint, "dynamics")
    dyn.set("damping", _num(fv or 0.0))
    dyn.set("friction", _num(fs or 0.0))


def _mujoco(root: ET.Element) -> None:
    mj = root.find("mujoco")
    if mj is None:
        mj = ET.Element("mujoco")
        root.insert(0, mj)
    comp = mj.find("compiler")
    if comp is None:
        comp = ET.SubElement(mj, "compiler")
    for k, v in MUJOCO_COMPILER.items():
        comp.set(k, v)


def _text(root: ET.Element) -> str:
    ET.indent(root, space="  ")
    return '<?xml version="1.0"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


def _unit(robot: RobotModel, joint_name: str) -> str:
    kinds = {j.name: j.kind for j in robot.joints}
    return "kg, N·s/m, N, N" if kinds.get(joint_name, "revolute") == "prismatic" else \
        "kg·m², N·m·s/rad, N·m, N·m"


# ------------------------------------------------------------------ a URDF robot's own file
def source_urdf(robot: RobotModel) -> Path:
    """The URDF a general robot was built from (its description); ConfigError otherwise."""
    path = getattr(getattr(robot, "description", None), "path", None)
    if path is None or Path(path).suffix.lower() != ".urdf":
        raise ConfigError(f"--urdf-out: robot {robot.name} is not described by a URDF "
                          f"({path or 'no description file'}); write the standard parameters "
                          "from the JSON instead")
    return Path(path)


def _merged_links(root: ET.Element, bodies: set[str]) -> set[str]:
    """Links fixed (through fixed joints) under a body link and not bodies themselves."""
    children: dict[str, list[tuple[str, str]]] = {}
    for j in root.findall("joint"):
        children.setdefault(j.find("parent").get("link"), []).append(
            (j.get("type"), j.find("child").get("link")))
    out: set[str] = set()
    stack = list(bodies)
    while stack:
        for kind, child in children.get(stack.pop(), []):
            if kind == "fixed" and child not in bodies:
                out.add(child)
                stack.append(child)
    return out


def replace_inertials(urdf_text: str, robot: RobotModel, chi_st: np.ndarray,
                      gains: Sequence[float]) -> str:
    """``urdf_text`` with the bodies' inertials and the joints' drive terms of ``chi_st``."""
    root = ET.fromstring(urdf_text, parser=ET.XMLParser(target=ET.TreeBuilder(
        insert_comments=True)))
    links = {el.get("name"): el for el in root.findall("link")}
    values = dict(zip(robot.standard_names, (float(x) for x in chi_st)))
    frames = {b.frame or b.name for b in robot.bodies}
    missing = sorted(frames - set(links))
    if missing:
        raise ConfigError(f"--urdf-out: bodies {missing} are not links of the URDF")
    for link in _merged_links(root, frames):
        for el in links[link].findall("inertial"):
            links[link].remove(el)
    parent_joint = {j.find("child").get("link"): j for j in root.findall("joint")}
    for body in robot.bodies:
        link = links[body.frame or body.name]
        for el in link.findall("inertial"):
            link.remove(el)
        link.insert(0, inertial_element(np.asarray(chi_st)[list(body.inertial)]))
        joint = parent_joint.get(body.frame or body.name)
        label = body_label(robot, body)
        if joint is not None and joint.get("type") != "fixed":
            _dynamics(joint, values, label)
            joint.insert(0, ET.Comment(joint_comment(joint.get("name"), values, label,
                                                     _unit(robot, joint.get("name")))))
    root.insert(0, ET.Comment(header_comment(robot, gains, "The robot's own URDF with the "
                                             "identified inertials.")))
    _mujoco(root)
    return _text(root)


# ------------------------------------------------------------------ the Orthoglide's open tree
# MDH α of the pivot frames 2..5 of every leg (docs/conventions.md, Table 2; θ = q_ji, d = d4
# for frame 4, 0 otherwise)
PIVOT_ALPHA = {2: -0.5 * math.pi, 3: -0.5 * math.pi, 4: 0.0, 5: 0.5 * math.pi}
PLATFORM_LINK = "platform"


def _rx(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def platform_in_body5(leg: int) -> tuple[np.ndarray, np.ndarray]:
    """(R, p) of the platform frame (base axes, origin P) in body 5 of ``leg`` (0..2) on the
    closed loop: body 5 has the axes R_1i Rot(x, −π/2) (q5 = −q2, q4 = −q3) and origin
    C_i = P − d6 e_i."""
    from orthoglide_ident.model.orthoglide.geometry import D6, E_AXIS, R_LEG

    R5 = R_LEG[leg] @ _rx(-0.5 * math.pi)
    return R5.T, R5.T @ (D6 * E_AXIS[leg])


def _joint(root: ET.Element, name: str, kind: str, parent: str, child: str, xyz, R) -> ET.Element:
    j = ET.SubElement(root, "joint", name=name, type=kind)
    ET.SubElement(j, "origin", xyz=_vec(xyz), rpy=_vec(rpy(R)))
    ET.SubElement(j, "parent", link=parent)
    ET.SubElement(j, "child", link=child)
    if kind != "fixed":
        ET.SubElement(j, "axis", xyz="0 0 1")
        lim = 1.0 if kind == "prismatic" else math.pi
        ET.SubElement(j, "limit", lower=_num(-lim), upper=_num(lim), effort=EFFORT_LIMIT,
                      velocity=SPEED_LIMIT)
    return j


def orthoglide_urdf(robot: RobotModel, chi_st: np.ndarray, gains: Sequence[float]) -> str:
    """The Orthoglide's open tree with the inertials and drive terms of ``chi_st`` (208)."""
    from orthoglide_ident.model.orthoglide.geometry import D4, FOOT_OFFSET, G0, R_LEG

    values = dict(zip(robot.standard_names, (float(x) for x in chi_st)))
    inertial = {b.frame: np.asarray(chi_st)[list(b.inertial)] for b in robot.bodies}
    root = ET.Element("robot", name="orthoglide_identified")
    root.append(ET.Comment(header_comment(robot, gains, (
        "Open tree of the Orthoglide: per leg i a prismatic foot q1i and pivots q2i..q5i in the "
        "MDH frames of docs/conventions.md (link body_<j><i> = frame j_i), the platform fixed to "
        "body 5 of leg 1 at P. The loops are closed by the product's model, not by this file: "
        "body 5 of legs 2 and 3 is welded to the platform (links platform_on_leg2/3 coincide "
        f"with platform on the robot). Gravity: {G0} m/s² along +y of base_link (y0 down)."))))
    ET.SubElement(root, "link", name="base_link")
    for i in range(3):
        parent = "base_link"
        for j in range(1, 6):
            link, name = f"body_{j}{i + 1}", f"q{j}{i + 1}"
            el = ET.SubElement(root, "link", name=link)
            el.append(inertial_element(inertial[f"{j}_{i + 1}"]))
            if j == 1:
                jt = _joint(root, name, "prismatic", parent, link, R_LEG[i] @ FOOT_OFFSET[i],
                            R_LEG[i])
            else:
                jt = _joint(root, name, "revolute", parent, link,
                            (D4 if j == 4 else 0.0, 0.0, 0.0), _rx(PIVOT_ALPHA[j]))
            label = f"{j}{i + 1}"
            _dynamics(jt, values, label)
            jt.insert(0, ET.Comment(joint_comment(name, values, label, "kg, N·s/m, N, N" if j == 1
                                                  else "N·m·s/rad, N·m, N·m")))
            parent = link
    el = ET.SubElement(root, "link", name=PLATFORM_LINK)
    el.append(inertial_element(inertial["platform"]))
    R, p = platform_in_body5(0)
    _joint(root, "platform_fixed", "fixed", "body_51", PLATFORM_LINK, p, R)
    for leg in (1, 2):
        ET.SubElement(root, "link", name=f"platform_on_leg{leg + 1}")
        R, p = platform_in_body5(leg)
        _joint(root, f"platform_on_leg{leg + 1}_fixed", "fixed", f"body_5{leg + 1}",
               f"platform_on_leg{leg + 1}", p, R)
    _mujoco(root)
    return _text(root)


def identified_urdf(robot: RobotModel, chi_st: np.ndarray, gains: Sequence[float]) -> str:
    """The URDF of the identified model: the Orthoglide's open tree, or a URDF robot's own file
    with its inertials replaced (module docstring)."""
    from orthoglide_ident.model.orthoglide.base import BaseModel

    if isinstance(robot, BaseModel):
        return orthoglide_urdf(robot, chi_st, gains)
    path = source_urdf(robot)
    try:
        text = path.read_text()
    except OSError as exc:
        raise ConfigError(f"--urdf-out: cannot read {path}: {exc.strerror or exc}") from None
    return replace_inertials(text, robot, chi_st, gains)


def joint_labels(robot: RobotModel, urdf_text: str) -> dict[str, str]:
    """URDF joint name -> the label of the drive terms of the body it moves (``fv_<label>``)."""
    from orthoglide_ident.model.orthoglide.base import BaseModel

    if isinstance(robot, BaseModel):
        return {f"q{j}{i}": f"{j}{i}" for i in (1, 2, 3) for j in range(1, 6)}
    root = ET.fromstring(urdf_text)
    by_child = {j.find("child").get("link"): j.get("name") for j in root.findall("joint")
                if j.get("type") != "fixed"}
    return {by_child[b.frame or b.name]: body_label(robot, b) for b in robot.bodies
            if (b.frame or b.name) in by_child}
