"""UR5 records whose payload adds no torque on the wrist_3 axis (a test fixture, issue 32).

The 2 kg payload's centre of mass is on the wrist_3 axis (tool0's z, 6 cm out) and its inertia
about that axis is tiny: the loaded record fixes the scale of five gains, not wrist_3's. Written
as bags the way ``python -m orthoglide_sim.arm_or_chain.bags --params`` writes them.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from orthoglide_sim.arm_or_chain.bags import write_record
from orthoglide_sim.arms.description import load_arm
from orthoglide_sim.arms.record import simulate_arm
from orthoglide_sim.arms.truth import apply_overrides, load_truth

AXIAL = {"payloads": {"2.0": {"mass": 2.0, "com": [0.0, 0.0, 0.06],
                              "inertia": [2.0e-3, 0.0, 0.0, 2.0e-3, 0.0, 1.0e-6]}}}


def write_axial_bags(folder: Path, seconds: float = 20.0) -> tuple[str, str, np.ndarray]:
    """(unloaded bag, loaded bag, the true gains in actuated-joint order)."""
    truth = apply_overrides(load_truth(load_arm("ur5")), AXIAL)
    out = []
    for name, payload, traj, seed in (("unloaded", None, "exciting1", 0),
                                      ("loaded_axial", "2.0", "exciting2", 1)):
        rec = simulate_arm(seconds, payload=payload, trajectory=traj, seed=seed, truth=truth)
        out.append(str(write_record(Path(folder) / name, rec)))
    return out[0], out[1], truth.drive_array("g_tau")
