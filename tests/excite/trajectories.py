"""Small exciting-trajectory files for the run's tests: a few seconds, small amplitudes inside
the simulated arms' boxes (orthoglide_sim/arms/limits.py), at rest at both ends."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from orthoglide_ident.excite.trajectory import (
    ExcitationRun,
    ExcitationTrajectory,
    rest_projection,
    save_trajectory,
)

UR5_JOINTS = ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint",
              "wrist_2_joint", "wrist_3_joint")
UR5_CENTRE = np.array([0.0, -2.0, 1.2, -np.pi / 2, -np.pi / 2, 0.0])  # arm_limits.UR5's box centre


def small_trajectory(
    robot: str = "ur5",
    joints=UR5_JOINTS,
    centre=UR5_CENTRE,
    period_s: float = 2.0,
    periods: int = 1,
    amplitude: float = 0.15,
    seed: int = 0,
    mass: float = 2.0,
) -> ExcitationTrajectory:
    """Both runs: 3 harmonics per joint, speeds ~``amplitude`` x 2π/period rad/s at most a few."""
    rng = np.random.default_rng(seed)
    runs = {}
    for name in ("unloaded", "loaded"):
        a, b = rest_projection(
            rng.normal(0, amplitude, (len(joints), 3)), rng.normal(0, amplitude, (len(joints), 3))
        )
        payload = {"mass": mass, "frame": "tool0"} if name == "loaded" else None
        runs[name] = ExcitationRun(name, np.array(centre, float), a, b, payload)
    return ExcitationTrajectory(robot, tuple(joints), period_s, periods, runs)


def write_small(path: Path, **kw) -> Path:
    save_trajectory(small_trajectory(**kw), path)
    return path
