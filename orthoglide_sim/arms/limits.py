"""Where a simulated serial arm may move: the box its exciting trajectories stay in (position,
velocity, acceleration per joint) and the stop limits beyond which the simulator raises
WorkspaceError (a real arm's protective stop).

UR5: the box is centred on q_c = (0, -2.0, 1.2, -π/2, -π/2, 0) rad, the upper arm leaning back
from the vertical and the elbow bent, half-widths (1.4, 0.5, 0.7, 1.0, 1.2, 1.5) rad. Over 1500
random corners of it every distal link frame (forearm to tool0) stays 0.2 m or more above the
base's mounting plane (tests/sim/arms/test_arm_excitation.py checks it with Pinocchio's kinematics),
the elbow stays between 0.5 and 1.9 rad (away from the stretched-arm singularity and from folding
onto the upper arm), and the speeds and accelerations are about half of what a UR5 allows
(3.15 rad/s). The five-bar (a closed chain: its actuated joints) has its own table; another
robot gets a box from its URDF limits.

Units: rad, rad/s, rad/s² (prismatic joints: m, m/s, m/s²).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from orthoglide_sim.arms.description import ArmDescription

STOP_MARGIN = 0.25  # rad (or m/10) beyond the box: the simulated arm's protective stop


@dataclass(frozen=True)
class MotionLimits:
    """Per joint (n,): box centre and half-width, peak speed and acceleration of a trajectory."""

    centre: np.ndarray
    half: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    stop_lower: np.ndarray  # the simulator's WorkspaceError limits
    stop_upper: np.ndarray


UR5 = {
    "centre": (0.0, -2.0, 1.2, -math.pi / 2, -math.pi / 2, 0.0),
    "half": (1.4, 0.5, 0.7, 1.0, 1.2, 1.5),
    "velocity": (1.5, 1.5, 2.0, 2.5, 2.5, 2.5),
    "acceleration": (8.0, 8.0, 12.0, 15.0, 15.0, 15.0),
}


# The five-bar's actuated joints (closed chain, chain_description): over the whole box the loop
# closes in the working mode with the elbows inside their limits and |G| <= 1.45 (no parallel
# singularity near); 0.05 rad inside the URDF's actuated limits. Its corner (1.5, 1.64) rad
# bends the elbows least (0.22 rad: 0.07 from their limits): the box reaches there because the
# passive joints' offsets are seen only through the variation of G (their columns are Gᵀ e_p),
# which is largest there — a ±0.5 rad box leaves their weakest combination at half the excitation
# (bench/closed_chain.py). Speeds and accelerations of a 1 Hz motion (6 rad/s allowed).
FIVE_BAR = {
    "centre": (2.1, 1.04),
    "half": (0.6, 0.6),
    "velocity": (3.0, 3.0),
    "acceleration": (25.0, 25.0),
}
# The UR10 (orthoglide_sim/data/ur10): the UR5's box, its shoulders' lower speed limit (2.16 rad/s)
UR10 = {**UR5, "velocity": (1.2, 1.2, 2.0, 2.5, 2.5, 2.5),
        "acceleration": (5.0, 5.0, 8.0, 12.0, 12.0, 12.0)}
TABLES = {"ur5": UR5, "ur10": UR10, "five_bar": FIVE_BAR}


def motion_limits(arm: ArmDescription) -> MotionLimits:
    """The arm's box: the table of the UR5 or the five-bar, else 40 % of each URDF range (at most
    ±1.5 rad) around its middle, half the URDF's speed limit, 5 s⁻¹ times that as acceleration."""
    lo = np.array([j.lower for j in arm.joints])
    hi = np.array([j.upper for j in arm.joints])
    known = TABLES.get(arm.name)
    if known is not None and arm.n == len(known["centre"]):
        table = {k: np.array(v, float) for k, v in known.items()}
    else:
        finite = np.isfinite(lo) & np.isfinite(hi)
        mid = np.where(finite, 0.5 * (lo + hi), 0.0)
        span = np.where(finite, 0.5 * (hi - lo), math.pi)
        vel = np.array([j.velocity if math.isfinite(j.velocity) else 2.0 for j in arm.joints])
        table = {"centre": mid, "half": np.minimum(0.4 * span, 1.5), "velocity": 0.5 * vel,
                 "acceleration": 2.5 * vel}
    margin = np.array(
        [STOP_MARGIN if j.kind == "revolute" else 0.1 * STOP_MARGIN for j in arm.joints]
    )
    return MotionLimits(table["centre"], table["half"], table["velocity"], table["acceleration"],
                        np.maximum(table["centre"] - table["half"] - margin, lo),
                        np.minimum(table["centre"] + table["half"] + margin, hi))


def ros2_joint_limits(limits: MotionLimits, names: list[str] | tuple[str, ...]) -> dict:
    """The box's positions as a ros2_control joint_limits mapping (what a user writes for the
    range their cell allows): ``{"joint_limits": {<joint>: {has_position_limits, min_position,
    max_position}}}``; inside the stop limits by STOP_MARGIN."""
    lo, hi = limits.centre - limits.half, limits.centre + limits.half
    return {"joint_limits": {str(n): {"has_position_limits": True, "min_position": float(a),
                                      "max_position": float(b)}
                             for n, a, b in zip(names, lo, hi)}}
