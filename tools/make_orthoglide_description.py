"""Write orthoglide_ident/robots/orthoglide_general.urdf: the Orthoglide's open tree for the general
(Pinocchio) model, from the MDH tables of the paper (Briot & Gautier 2013, Tables 1-2, as
corrected in docs/design/conventions.md).

The tree: per leg i = 1..3 a prismatic foot joint q1i and four revolute pivots q2i..q5i, links
``b<j><i>`` whose frames are the MDH frames j_i (so the description's standard parameters are
the paper's, inertia at the frame origin, first moments in the frame); the platform ``platform``
(axes of the base, origin P) fixed on b51; frames ``platform_2`` on b52 and ``platform_3`` on
b53 where the platform sits when the loops are closed (orthoglide_general.yaml holds them to the
platform by two 6D loops). Inertials and friction are design values of the prototype's parts
(legs alike): the general model needs them only as nominal values, never to identify.

Run from the repository root: ``.venv/bin/python tools/make_orthoglide_description.py``; it
checks its output by loading it with Pinocchio.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin

from orthoglide_ident.model.orthoglide.geometry import D4, D6, A

ROBOTS = Path(__file__).resolve().parent.parent / "orthoglide_ident" / "robots"
OUT = ROBOTS / "orthoglide_general.urdf"
HP = 0.5 * np.pi


def rot(axis: str, t: float) -> np.ndarray:
    c, s = np.cos(t), np.sin(t)
    if axis == "x":
        return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def mdh(gamma: float, b: float, alpha: float, d: float, theta: float = 0.0,
        r: float = 0.0) -> pin.SE3:
    """Constant part of Rot(z, γ) Trans(z, b) Rot(x, α) Trans(x, d) Rot(z, θ) Trans(z, r)."""
    T = pin.SE3(rot("z", gamma), np.array([0.0, 0.0, b]))
    T = T * pin.SE3(rot("x", alpha), np.array([d, 0.0, 0.0]))
    return T * pin.SE3(rot("z", theta), np.array([0.0, 0.0, r]))


# Table 1 (r of 1_2 and 1_3 is q - a: the constant -a goes into the joint origin) and Table 2.
FEET = (mdh(0.0, 0.0, 0.0, 0.0), mdh(HP, A, HP, 0.0, 0.0, -A), mdh(0.0, A, -HP, 0.0, -HP, -A))
PIVOTS = {2: mdh(0.0, 0.0, -HP, 0.0), 3: mdh(0.0, 0.0, -HP, 0.0), 4: mdh(0.0, 0.0, 0.0, D4),
          5: mdh(0.0, 0.0, HP, 0.0)}
E_AXIS = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])  # actuator axes e_i


def platform_in_body5(leg: int) -> pin.SE3:
    """Platform frame (base axes, origin P) in body 5 of leg ``leg`` (1..3) on the closed loop:
    body 5 has the orientation R_1i Rot(x, -π/2) (q4i = -q3i, q5i = -q2i) and origin
    C_i = P - d6 e_i, so P sits at d6 e_i."""
    R5 = FEET[leg - 1].rotation @ rot("x", -HP)
    return pin.SE3(R5.T, R5.T @ (D6 * E_AXIS[leg - 1]))


# Design values per body j (legs alike): mass kg, centre of mass in the MDH frame m, inertia
# about the centre of mass (xx, xy, xz, yy, yz, zz) kg·m².
BODIES = {
    1: (3.6, (0.012, 0.021, -0.048), (0.0112, 2.0e-4, -1.5e-4, 0.0095, 1.1e-4, 0.0068)),
    2: (0.26, (0.006, -0.011, 0.018), (2.1e-4, 6.0e-6, -4.0e-6, 1.7e-4, 5.0e-6, 1.2e-4)),
    3: (0.31, (0.155, 0.0035, 0.0042), (2.9e-4, 2.2e-5, -1.8e-5, 2.55e-3, 9.0e-6, 2.6e-3)),
    4: (0.055, (0.004, 0.003, 0.009), (1.9e-5, 1.0e-6, -8.0e-7, 1.6e-5, 6.0e-7, 1.1e-5)),
    5: (0.062, (0.005, -0.004, 0.007), (2.2e-5, -1.1e-6, 9.0e-7, 1.8e-5, 7.0e-7, 1.3e-5)),
}
PLATFORM = (0.42, (0.003, 0.011, -0.006), (4.1e-4, 1.2e-5, -9.0e-6, 3.6e-4, 1.4e-5, 5.2e-4))
# Friction (damping = fv, friction = fs): feet N·s/m and N, pivots N·m·s/rad and N·m.
FRICTION = {1: (85.0, 35.0), 2: (0.12, 0.21), 3: (0.095, 0.18), 4: (0.105, 0.165), 5: (0.14, 0.24)}
FOOT_LIMIT = 0.15  # m, each way from q = 0 (the platform's ±0.1 m cube needs -0.10 to +0.131)


def _origin(T: pin.SE3) -> str:
    p = np.where(np.abs(T.translation) < 1e-15, 0.0, T.translation)
    xyz = " ".join(repr(float(v) + 0.0) for v in p)
    rpy = " ".join(repr(float(v) + 0.0) for v in pin.rpy.matrixToRpy(T.rotation))
    return f'<origin xyz="{xyz}" rpy="{rpy}" />'


def _link(name: str, body: tuple | None) -> str:
    if body is None:
        return f'  <link name="{name}" />'
    m, c, (xx, xy, xz, yy, yz, zz) = body
    return (f'  <link name="{name}">\n    <inertial>\n'
            f'      <origin xyz="{c[0]:g} {c[1]:g} {c[2]:g}" rpy="0 0 0" />\n'
            f'      <mass value="{m:g}" />\n'
            f'      <inertia ixx="{xx:g}" ixy="{xy:g}" ixz="{xz:g}" iyy="{yy:g}" iyz="{yz:g}" '
            f'izz="{zz:g}" />\n'
            f'    </inertial>\n  </link>')


def _joint(name: str, kind: str, parent: str, child: str, T: pin.SE3, limit: str = "",
           friction: tuple[float, float] | None = None) -> str:
    lines = [f'  <joint name="{name}" type="{kind}">', f'    <parent link="{parent}" />',
             f'    <child link="{child}" />', f'    {_origin(T)}']
    if kind != "fixed":
        lines.append('    <axis xyz="0 0 1" />')
        lines.append(f"    {limit}")
        lines.append(f'    <dynamics damping="{friction[0]:g}" friction="{friction[1]:g}" />')
    return "\n".join(lines + ["  </joint>"])


def urdf() -> str:
    out = ['<?xml version="1.0"?>',
           "<!-- Generated by tools/make_orthoglide_description.py: do not edit by hand.",
           "     The Orthoglide (Briot & Gautier 2013) as an open tree in the MDH frames of",
           "     Tables 1-2; the loops are in orthoglide_general.yaml. -->",
           '<robot name="orthoglide_general">',
           "  <!-- MuJoCo: keep the fixed links (platform, platform_2, platform_3) as bodies -->",
           '  <mujoco><compiler fusestatic="false" discardvisual="true" /></mujoco>',
           '  <link name="base" />']
    foot_limit = (f'<limit lower="{-FOOT_LIMIT:g}" upper="{FOOT_LIMIT:g}" effort="2000" '
                  'velocity="1.5" />')
    pivot_limit = '<limit lower="-3.1" upper="3.1" effort="100" velocity="20" />'
    for i in (1, 2, 3):
        parent = "base"
        for j in range(1, 6):
            child = f"b{j}{i}"
            kind, T = ("prismatic", FEET[i - 1]) if j == 1 else ("revolute", PIVOTS[j])
            out.append(_joint(f"q{j}{i}", kind, parent, child, T,
                              foot_limit if j == 1 else pivot_limit, FRICTION[j]))
            out.append(_link(child, BODIES[j]))
            parent = child
        if i == 1:
            out.append(_joint("platform_joint", "fixed", "b51", "platform", platform_in_body5(1)))
            out.append(_link("platform", PLATFORM))
        else:
            out.append(_joint(f"platform_{i}_joint", "fixed", f"b5{i}", f"platform_{i}",
                              platform_in_body5(i)))
            out.append(_link(f"platform_{i}", None))
    out.append("</robot>")
    return "\n".join(out) + "\n"


def check(path: Path) -> None:
    """The written placements are the MDH transforms (to 1e-15)."""
    model = pin.buildModelFromUrdf(str(path))
    for i in (1, 2, 3):
        for j in range(1, 6):
            want = FEET[i - 1] if j == 1 else PIVOTS[j]
            got = model.jointPlacements[model.getJointId(f"q{j}{i}")]
            assert np.allclose(got.homogeneous, want.homogeneous, atol=1e-15), (i, j)


if __name__ == "__main__":
    OUT.write_text(urdf())
    check(OUT)
    print(f"wrote {OUT}")
