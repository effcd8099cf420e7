"""The Orthoglide's identified model as a URDF of its open tree (``identify --urdf-out``).

Written from the MDH frames of docs/design/conventions.md: per leg a prismatic foot (q1i) and four
pivots (q2i..q5i), link ``body_<j><i>`` in frame j_i, the platform fixed to body 5 of leg 1 at
P; the loops are **not** in the file (URDF has no closed chains): the product's model closes
them (body 5 of legs 2 and 3 welded to the platform: links ``platform_on_leg2``,
``platform_on_leg3`` mark where; forward.py). The elements every robot's URDF shares (inertials,
drive terms, the MuJoCo compiler flags) are model/urdf.py's.
"""
from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Sequence

import numpy as np

from orthoglide_ident.model.robot import RobotModel
from orthoglide_ident.model.urdf import (
    EFFORT_LIMIT,
    SPEED_LIMIT,
    fmt_num,
    fmt_vec,
    header_comment,
    inertial_element,
    joint_comment,
    mujoco_compiler,
    rpy,
    set_dynamics,
    xml_text,
)

__all__ = ["PLATFORM_LINK", "joint_labels", "orthoglide_urdf", "platform_in_body5"]


# ------------------------------------------------------------------ the Orthoglide's open tree
# MDH α of the pivot frames 2..5 of every leg (docs/design/conventions.md, Table 2; θ = q_ji, d = d4
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
    ET.SubElement(j, "origin", xyz=fmt_vec(xyz), rpy=fmt_vec(rpy(R)))
    ET.SubElement(j, "parent", link=parent)
    ET.SubElement(j, "child", link=child)
    if kind != "fixed":
        ET.SubElement(j, "axis", xyz="0 0 1")
        lim = 1.0 if kind == "prismatic" else math.pi
        ET.SubElement(j, "limit", lower=fmt_num(-lim), upper=fmt_num(lim), effort=EFFORT_LIMIT,
                      velocity=SPEED_LIMIT)
    return j


def orthoglide_urdf(robot: RobotModel, chi_st: np.ndarray, gains: Sequence[float]) -> str:
    """The Orthoglide's open tree with the inertials and drive terms of ``chi_st`` (208)."""
    from orthoglide_ident.model.orthoglide.geometry import D4, FOOT_OFFSET, G0, R_LEG

    values = dict(zip(robot.standard_names, (float(x) for x in chi_st)))
    inertial = {b.frame: np.asarray(chi_st)[list(b.inertial)] for b in robot.bodies}
    root = ET.Element("robot", name="orthoglide_identified")
    root.append(
        ET.Comment(
            header_comment(
                robot,
                gains,
                (
                    "Open tree of the Orthoglide: per leg i a prismatic foot q1i and pivots "
                    "q2i..q5i in the "
                    "MDH frames of docs/design/conventions.md (link body_<j><i> = frame j_i), the "
                    "platform fixed to "
                    "body 5 of leg 1 at P. The loops are closed by the product's model, not by "
                    "this "
                    ""
                    ""
                    ""
                    "file: "
                    "body 5 of legs 2 and 3 is welded to the platform (links platform_on_leg2/3 "
                    "coincide "
                    f"with platform on the robot). Gravity: {G0} m/s² along +y of base_link (y0 "
                    "down)."
                ),
            )
        )
    )
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
            set_dynamics(jt, values, label)
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
    mujoco_compiler(root)
    return xml_text(root)


def joint_labels() -> dict[str, str]:
    """URDF joint name -> the label of its drive terms: q<j><i> moves body j of leg i."""
    return {f"q{j}{i}": f"{j}{i}" for i in (1, 2, 3) for j in range(1, 6)}
