"""The identified model as a URDF that Pinocchio and MuJoCo load (``identify --urdf-out``).

- A robot described by a URDF: its own URDF with every body's ``<inertial>`` replaced by the
  identified one (mass, centre of mass, inertia about it, axes of the link), the links merged
  into a body (fixed to it, not bodies themselves) emptied of theirs — Pinocchio merges them, and
  the identified body holds them — and each joint's ``<dynamics damping friction>`` set to its
  fv, fs; rotor inertia ia and offset tauoff, which URDF has no element for, in a comment at
  the joint; the drive gains in a comment at the top.
- A robot that writes its own (the Orthoglide's open tree, model/orthoglide/urdf.py) uses the
  elements here: ``inertial_element``, ``set_dynamics``, the comments, ``mujoco_compiler``.

``RobotModel.identified_urdf`` is the one door: callers never ask which robot it is.

A ``<mujoco><compiler .../></mujoco>`` element keeps MuJoCo from merging fixed links or
rebalancing the inertias (Pinocchio ignores it). Every number is written with 17 significant
digits: loaded back, the inertials are the identified ones to round-off.
"""
from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.model.inertia import at_com

RobotModel = Any  # a model/robot.RobotModel: its methods call this module, which does not import it

MUJOCO_COMPILER = {"discardvisual": "true", "fusestatic": "false", "balanceinertia": "false"}
EFFORT_LIMIT, SPEED_LIMIT = "1e4", "100"  # URDF requires limits; the identification sets none


def fmt_num(x: float) -> str:
    return repr(float(x)) if math.isfinite(x) else "0"


def fmt_vec(v: Sequence[float]) -> str:
    return " ".join(fmt_num(x) for x in v)


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
    ET.SubElement(el, "origin", xyz=fmt_vec(c), rpy="0 0 0")
    ET.SubElement(el, "mass", value=fmt_num(m))
    ET.SubElement(el, "inertia", **{k: fmt_num(v) for k, v in
                                    zip(("ixx", "ixy", "ixz", "iyy", "iyz", "izz"), I)})
    return el


def body_label(robot: RobotModel, body) -> str:
    """The suffix of a body's parameter names (``m_21`` → ``21``): its joint's drive terms are
    ``fv_<label>``... (docs/design/conventions.md; the general model names them the same way)."""
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


def set_dynamics(joint: ET.Element, values: Mapping[str, float], label: str) -> None:
    fv, fs = values.get(f"fv_{label}"), values.get(f"fs_{label}")
    if fv is None and fs is None:
        return
    dyn = joint.find("dynamics")
    if dyn is None:
        dyn = ET.SubElement(joint, "dynamics")
    dyn.set("damping", fmt_num(fv or 0.0))
    dyn.set("friction", fmt_num(fs or 0.0))


def mujoco_compiler(root: ET.Element) -> None:
    mj = root.find("mujoco")
    if mj is None:
        mj = ET.Element("mujoco")
        root.insert(0, mj)
    comp = mj.find("compiler")
    if comp is None:
        comp = ET.SubElement(mj, "compiler")
    for k, v in MUJOCO_COMPILER.items():
        comp.set(k, v)


def xml_text(root: ET.Element) -> str:
    ET.indent(root, space="  ")
    return '<?xml version="1.0"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


def _unit(robot: RobotModel, joint_name: str) -> str:
    kinds = {j.name: j.kind for j in robot.joints}
    return "kg, N·s/m, N, N" if kinds.get(joint_name, "revolute") == "prismatic" else \
        "kg·m², N·m·s/rad, N·m, N·m"


# ------------------------------------------------------------------ a URDF robot's own file
def source_urdf(robot: RobotModel) -> Path:
    """The URDF a general robot was built from (its description); ConfigError otherwise."""
    path = None if robot.description is None else robot.description.path
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


def _vec(el: ET.Element | None, key: str, default: str) -> np.ndarray:
    return np.array([float(x) for x in (el.get(key, default) if el is not None
                                        else default).split()])


def lock_joints(root: ET.Element, locked) -> None:
    """Each locked joint (model/locked_joints.LockedJoint) made a fixed joint at its value: its
    origin moved by the joint's motion there (a rotation about its axis, or a translation along
    it), its axis, limits, mimic and dynamics removed, a comment saying so."""
    joints = {j.get("name"): j for j in root.findall("joint")}
    for lj in locked:
        joint = joints[lj.name]
        origin = joint.find("origin")
        M = pin.SE3(pin.rpy.rpyToMatrix(*_vec(origin, "rpy", "0 0 0")),
                    _vec(origin, "xyz", "0 0 0"))
        axis = _vec(joint.find("axis"), "xyz", "1 0 0")
        axis = axis / np.linalg.norm(axis)
        if joint.get("type") == "prismatic":
            M = M * pin.SE3(np.eye(3), lj.value * axis)
        else:
            M = M * pin.SE3(pin.exp3(lj.value * axis), np.zeros(3))
        for tag in ("origin", "axis", "limit", "mimic", "dynamics", "safety_controller",
                    "calibration"):
            for el in joint.findall(tag):
                joint.remove(el)
        joint.set("type", "fixed")
        ET.SubElement(joint, "origin", xyz=fmt_vec(M.translation),
                      rpy=fmt_vec(pin.rpy.matrixToRpy(M.rotation)))
        joint.insert(0, ET.Comment(f" locked at {lj.value:.17g} {lj.unit} ({lj.reason()}): "
                                   f"a {lj.kind} joint of the description, fixed here "))


def replace_inertials(urdf_text: str, robot: RobotModel, chi_st: np.ndarray,
                      gains: Sequence[float]) -> str:
    """``urdf_text`` with the bodies' inertials and the joints' drive terms of ``chi_st``; the
    robot's locked joints fixed at their values (their links' inertia is in the identified
    body they are fixed to)."""
    root = ET.fromstring(urdf_text, parser=ET.XMLParser(target=ET.TreeBuilder(
        insert_comments=True)))
    lock_joints(root, robot.locked_joints)
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
            set_dynamics(joint, values, label)
            joint.insert(0, ET.Comment(joint_comment(joint.get("name"), values, label,
                                                     _unit(robot, joint.get("name")))))
    root.insert(0, ET.Comment(header_comment(robot, gains, "The robot's own URDF with the "
                                             "identified inertials.")))
    mujoco_compiler(root)
    return xml_text(root)



def urdf_with_inertials(robot: RobotModel, chi_st: np.ndarray, gains: Sequence[float]) -> str:
    """A URDF robot's own file with the identified inertials and drive terms (module docstring):
    every robot's ``identified_urdf`` unless it writes its own (the Orthoglide's open tree)."""
    path = source_urdf(robot)
    try:
        text = path.read_text()
    except OSError as exc:
        raise ConfigError(f"--urdf-out: cannot read {path}: {exc.strerror or exc}") from None
    return replace_inertials(text, robot, chi_st, gains)


def joint_labels(robot: RobotModel, urdf_text: str) -> dict[str, str]:
    """URDF joint name -> the label of the drive terms of the body it moves (``fv_<label>``)."""
    root = ET.fromstring(urdf_text)
    by_child = {j.find("child").get("link"): j.get("name") for j in root.findall("joint")
                if j.get("type") != "fixed"}
    return {by_child[b.frame or b.name]: body_label(robot, b) for b in robot.bodies
            if (b.frame or b.name) in by_child}
