"""The identified URDF of a robot with a transmission (issue 33): the rigid-body part as the
joint-side robot writes it (model/urdf.py), plus a ``<ros2_control>`` block with one
``<transmission>`` per part of N that ros2_control can express (the reader's formulas,
model/transmission.py, run backwards):

- a 1 × 1 block n: SimpleTransmission, the joint's ``<mechanical_reduction>`` n and ``<offset>``
  o = −offset_m / n (ros2_control: q_j = q_a / n + o);
- a 2 × 2 block with all four entries and N₁₁ N₂₂ + N₁₂ N₂₁ = 0: DifferentialTransmission
  (a1 = N₁₁, a2 = N₂₁, j1 = 1, j2 = N₁₂ / N₁₁);
- a 2 × 2 triangular block: FourBarLinkageTransmission (j1 = 1, a1 = N₁₁, a2 = N₂₁,
  j2 = N₂₂ / N₂₁), with a warning: ros2_control's own four-bar effort formula is not Nᵀ;
- anything else (a motor on three joints...): an XML comment with the full N and a warning.

Each motor's identified drive terms (ia, fv, fs, tauoff, motor side) and drive gain are an XML
comment inside its ``<actuator>``. A joint on a SimpleTransmission also gets them reflected to
the joint in ``<dynamics>`` (n² fv, |n| fs: what a simulator of the URDF alone should see); a
coupled joint's ``<dynamics>`` are 0 (the coupling's friction is not a joint's).
"""
from __future__ import annotations

import logging
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from typing import Any

import numpy as np

from orthoglide_ident.model.urdf import fmt_num, header_comment, xml_text

RobotModel = Any  # model/actuator_space.ActuatorSpaceRobot (it imports this module)
LOG = logging.getLogger("orthoglide_ident")
PLUGIN = "transmission_interface/"
DRIVE = ("ia", "fv", "fs", "tauoff")
TOL = 1e-12  # relative: N₁₁ N₂₂ + N₁₂ N₂₁ = 0 for a differential


def blocks(N: np.ndarray) -> list[tuple[list[int], list[int]]]:
    """(rows, columns) of N's coupled blocks: connected components of its non-zeros."""
    n, seen, out = N.shape[0], set(), []
    for start in range(n):
        if start in seen:
            continue
        cols, stack = {start}, [start]
        while stack:
            c = stack.pop()
            for r in np.nonzero(N[:, c])[0]:
                for c2 in np.nonzero(N[r])[0]:
                    if c2 not in cols:
                        cols.add(int(c2))
                        stack.append(int(c2))
        seen |= cols
        rows = sorted({int(r) for c in cols for r in np.nonzero(N[:, c])[0]})
        out.append((rows, sorted(cols)))
    return out


def ros2_control_form(M: np.ndarray) -> tuple[str, list[int], list[int], list[float],
                                               list[float]] | None:
    """(plugin, row order, column order, actuator reductions, joint reductions) of a block, or
    None when ros2_control has no transmission for it."""
    if M.shape == (1, 1):
        return "SimpleTransmission", [0], [0], [1.0], [float(M[0, 0])]
    if M.shape != (2, 2):
        return None
    for rows in ([0, 1], [1, 0]):
        for cols in ([0, 1], [1, 0]):
            B = M[np.ix_(rows, cols)]
            if np.all(B != 0) and abs(B[0, 0] * B[1, 1] + B[0, 1] * B[1, 0]) <= \
                    TOL * abs(B[0, 0] * B[1, 1]):
                return ("DifferentialTransmission", rows, cols,
                        [B[0, 0], B[1, 0]], [1.0, B[0, 1] / B[0, 0]])
            if B[0, 1] == 0 and np.all(B[[0, 1, 1], [0, 0, 1]] != 0):
                return ("FourBarLinkageTransmission", rows, cols,
                        [B[0, 0], B[1, 0]], [1.0, B[1, 1] / B[1, 0]])
    return None


def joint_side_values(robot: RobotModel, chi_st: np.ndarray) -> np.ndarray:
    """The joint model's standard vector: the rigid part of ``chi_st``; a joint on a simple
    transmission n gets its motor's terms reflected (n² ia, n² fv, |n| fs, n tauoff: τ_j = n τ_m
    with q̇_m = n q̇_j), a coupled joint 0."""
    jm, t = robot.joint_model, robot.transmission
    values = dict(zip(robot.standard_names, np.asarray(chi_st, float)))
    out = np.zeros(len(jm.standard_names))
    out[list(robot.rigid_columns)] = np.asarray(chi_st, float)[:len(robot.rigid_columns)]
    for rows, cols in blocks(t.N):
        if len(rows) != 1:
            continue
        a, j, n = rows[0], cols[0], t.N[rows[0], cols[0]]
        scale = {"ia": n * n, "fv": n * n, "fs": abs(n), "tauoff": n}
        for kind, k in jm.drive_columns(j).items():
            out[k] = scale[kind] * values[f"{kind}_{t.actuators[a]}"]
    return out


def _motor_comment(robot: RobotModel, a: int, values: dict, gain: float) -> ET.Element:
    name, joint = robot.transmission.actuators[a], robot.joints[a]
    unit = "kg, N·s/m, N, N" if joint.kind == "prismatic" else "kg·m², N·m·s/rad, N·m, N·m"
    terms = ", ".join(f"{k} = {values[f'{k}_{name}']:.6g}" for k in DRIVE)
    return ET.Comment(f" motor {name} (identified, motor side): {terms} ({unit}); drive gain "
                      f"g_tau = {gain:.6g} {joint.gain_unit} ")


def _transmission(robot: RobotModel, rows: list[int], cols: list[int], form, values: dict,
                  gains: Sequence[float]) -> ET.Element:
    t = robot.transmission
    plugin, r_order, c_order, ar, jr = form
    rows, cols = [rows[i] for i in r_order], [cols[i] for i in c_order]
    o = -np.linalg.solve(t.N[np.ix_(rows, cols)], t.offset[rows])  # joint offsets: −N_b⁻¹ off
    el = ET.Element("transmission", name=f"{'_'.join(t.actuators[a] for a in rows)}_transmission")
    ET.SubElement(el, "plugin").text = PLUGIN + plugin
    for k, a in enumerate(rows):
        act = ET.SubElement(el, "actuator", name=t.actuators[a], role=f"actuator{k + 1}")
        act.append(_motor_comment(robot, a, values, gains[a]))
        if plugin != "SimpleTransmission":  # ros2_control reads a simple one's on the joint
            ET.SubElement(act, "mechanical_reduction").text = fmt_num(ar[k])
    for k, j in enumerate(cols):
        jel = ET.SubElement(el, "joint", name=t.joints[j], role=f"joint{k + 1}")
        ET.SubElement(jel, "mechanical_reduction").text = fmt_num(jr[k])
        ET.SubElement(jel, "offset").text = fmt_num(o[k])
    return el


def _unsupported(robot: RobotModel, rows: list[int], cols: list[int], values: dict,
                 gains: Sequence[float]) -> list[ET.Element]:
    t = robot.transmission
    N = "; ".join(" ".join(fmt_num(x) for x in r) for r in t.N)
    why = (f"motors {[t.actuators[a] for a in rows]} on joints {[t.joints[j] for j in cols]} "
           "have no ros2_control transmission (Simple, Differential, FourBarLinkage)")
    LOG.warning("--urdf-out: %s: written as a comment with the full N", why)
    return [ET.Comment(f" NOT A ros2_control TRANSMISSION: {why}. The full reduction N "
                       f"(q̇_m = N q̇_j, rows {list(t.actuators)}, columns {list(t.joints)}) "
                       f"is [{N}]; motor-side offset {t.offset.tolist()} ")] + \
        [_motor_comment(robot, a, values, gains[a]) for a in rows]


def ros2_control_block(root: ET.Element, robot: RobotModel, chi_st: np.ndarray,
                       gains: Sequence[float]) -> None:
    """Replace the ``<transmission>``s of ``root``'s ``<ros2_control>`` blocks by the
    identified ones (a new block when it has none)."""
    t = robot.transmission
    values = dict(zip(robot.standard_names, (float(x) for x in chi_st)))
    blocks_rc = list(root.iter("ros2_control"))
    for rc in blocks_rc:
        for old in rc.findall("transmission"):
            rc.remove(old)
    if blocks_rc:
        rc = blocks_rc[0]
    else:
        rc = ET.SubElement(root, "ros2_control", name=robot.name, type="system")
        rc.append(ET.Comment(" the identified transmissions; add the <hardware> plugin and the "
                             "joints' interfaces of your system "))
    for rows, cols in blocks(t.N):
        form = ros2_control_form(t.N[np.ix_(rows, cols)])
        if form is None:
            rc.extend(_unsupported(robot, rows, cols, values, gains))
            continue
        if form[0] == "FourBarLinkageTransmission":
            LOG.warning(
                "--urdf-out: motors %s are written as a FourBarLinkageTransmission: its "
                "velocities are N's, but ros2_control's own four-bar effort formula is "
                "not τ_j = Nᵀ τ_m (docs/guide/robot_files.md)",
                [t.actuators[a] for a in rows],
            )
        rc.append(_transmission(robot, rows, cols, form, values, gains))


def identified_urdf(robot: RobotModel, chi_st: np.ndarray, gains: Sequence[float]) -> str:
    """The joint-side robot's identified URDF (rigid part of ``chi_st``, reflected simple drive
    terms) with the motors' header and the ``<ros2_control>`` transmissions (module docstring)."""
    jm = robot.joint_model
    text = jm.identified_urdf(joint_side_values(robot, chi_st), list(gains))
    root = ET.fromstring(text, parser=ET.XMLParser(target=ET.TreeBuilder(insert_comments=True)))
    for el in root:
        if el.tag is ET.Comment and "Identified by orthoglide-ident" in (el.text or ""):
            el.text = header_comment(robot, gains, "The robot's own URDF with the identified "
                                     "inertials; the motors' drive terms and gains are at their "
                                     "<actuator>s in <ros2_control>.")
            break
    ros2_control_block(root, robot, chi_st, gains)
    return xml_text(root)
