"""Robots and trajectories written on the fly for the excite tests: a two-link arm whose URDF
has (or lacks) limits and collision meshes, an STL cube, runs at a pose."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from orthoglide_ident.excite.trajectory import ExcitationRun, ExcitationTrajectory

LIMIT = '<limit lower="-2.0" upper="2.0" effort="{effort}" velocity="3.0"/>'


def two_link_urdf(folder: Path, limits: bool = True, mesh: str | None = None,
                  effort: float = 20.0) -> Path:
    """A vertical two-link arm (revolute about y, 0.3 m links); ``mesh``: a collision mesh
    filename on each link."""
    lim = LIMIT.format(effort=effort) if limits else ""
    kind = "revolute" if limits else "continuous"
    col = f'<collision><geometry><mesh filename="{mesh}"/></geometry></collision>' if mesh else ""

    def link(name: str) -> str:
        return (f'<link name="{name}"><inertial><origin xyz="0 0 0.15"/><mass value="1.0"/>'
                '<inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.001"/></inertial>'
                f'{col}</link>')

    text = f"""<?xml version="1.0"?>
<robot name="two_link">
  <link name="base"/>
  <joint name="j1" type="{kind}"><parent link="base"/><child link="l1"/>
    <origin xyz="0 0 0.1"/><axis xyz="0 1 0"/>{lim}</joint>
  {link("l1")}
  <joint name="j2" type="{kind}"><parent link="l1"/><child link="l2"/>
    <origin xyz="0 0 0.3"/><axis xyz="0 1 0"/>{lim}</joint>
  {link("l2")}
</robot>"""
    path = folder / "two_link.urdf"
    path.write_text(text)
    return path


def cube_stl(path: Path, half: float = 0.02) -> Path:
    """An ASCII STL cube of half-width ``half`` m centred on the origin."""
    v = np.array([[x, y, z] for x in (-half, half) for y in (-half, half) for z in (-half, half)])
    faces = [(0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5), (0, 4, 5), (0, 5, 1), (2, 3, 7),
             (2, 7, 6), (0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3)]
    lines = ["solid cube"]
    for f in faces:
        lines += ["facet normal 0 0 0", "outer loop"] + \
            [f"vertex {v[i][0]} {v[i][1]} {v[i][2]}" for i in f] + ["endloop", "endfacet"]
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(lines + ["endsolid cube"]) + "\n")
    return path


def static_runs(robot: str, joints, pose, a=None, b=None, period: float = 5.0,
                payload: dict | None = None) -> ExcitationTrajectory:
    """Both runs of one series: q0 = ``pose``, coefficients a, b (zero: the robot holds still)."""
    n = len(joints)
    a = np.zeros((n, 2)) if a is None else np.asarray(a, float)
    b = np.zeros((n, 2)) if b is None else np.asarray(b, float)
    runs = {"unloaded": ExcitationRun("unloaded", np.asarray(pose, float), a, b),
            "loaded": ExcitationRun("loaded", np.asarray(pose, float), a, b,
                                    payload or {"mass": 1.0})}
    return ExcitationTrajectory(robot, tuple(joints), period, 2, runs)


def mimic_arm_urdf(folder: Path, multiplier: float = 3.0) -> Path:
    """A three-link arm (revolute about y) whose j3 follows j2 × ``multiplier`` (URDF <mimic>),
    every joint limited to ±2 rad, 3 rad/s, 20 N·m; a robot YAML beside it gives 10 rad/s²."""
    lim = LIMIT.format(effort=20.0)

    def link(name: str) -> str:
        return (f'<link name="{name}"><inertial><origin xyz="0 0 0.1"/><mass value="0.5"/>'
                '<inertia ixx="0.005" ixy="0" ixz="0" iyy="0.005" iyz="0" izz="0.001"/>'
                '</inertial></link>')

    text = f"""<?xml version="1.0"?>
<robot name="mimic_arm">
  <link name="base"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
    <origin xyz="0 0 0.1"/><axis xyz="0 1 0"/>{lim}</joint>
  {link("l1")}
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/>
    <origin xyz="0 0 0.2"/><axis xyz="0 1 0"/>{lim}</joint>
  {link("l2")}
  <joint name="j3" type="revolute"><parent link="l2"/><child link="l3"/>
    <origin xyz="0 0 0.2"/><axis xyz="0 1 0"/>{lim}<mimic joint="j2" multiplier="{multiplier}"/>
  </joint>
  {link("l3")}
</robot>"""
    urdf = folder / "mimic_arm.urdf"
    urdf.write_text(text)
    robot = folder / "mimic_arm.yaml"
    robot.write_text("name: mimic_arm\ndescription: mimic_arm.urdf\n"
                     "excitation:\n  acceleration_limits: 10.0\n")
    return robot
