"""Records for the identification benchmarks, from the simulator (docs/design/simulator.md).

``record(duration_s, payload_kg, seed, noise, profile=...)`` returns (Record, truth) where truth
holds the plant's true drive gains (``g_tau``): the Pinocchio plant of ``orthoglide_sim``, closed
loop, smooth Coulomb friction, 1 µm encoder, current noise; ``profile="realistic"`` adds the drive
effects the IDIM lacks (config/plant.yaml).
"""
from __future__ import annotations

import numpy as np

from orthoglide_ident.identify import Record
from orthoglide_ident.model.registry import load_robot
from orthoglide_sim.orthoglide.record import simulate

ORTHOGLIDE = load_robot("orthoglide")  # the robot these records are of


def record(duration_s: float, payload_kg: float, seed: int, noise: bool = True,
           source: str | None = None, trajectory: str = "exciting",
           profile: str | None = None) -> tuple[Record, dict]:
    """``profile``: the simulator's plant profile ("nominal" by default, or "realistic")."""
    cond = "loaded" if payload_kg > 0 else "unloaded"
    name = source or f"{cond}-{payload_kg:g}kg-seed{seed}"
    payload = "none" if payload_kg == 0 else (f"{payload_kg:g}" if f"{payload_kg:g}" in
                                             ("1.983", "1.136") else payload_kg)
    rec = simulate(duration_s, payload=payload, trajectory=trajectory, seed=seed, noise=noise,
                   profile=profile)
    truth = {"g_tau": np.asarray(rec.g_tau, float), "source": f"simulator ({trajectory})"}
    return Record.from_arrays(name, rec.stamps_ns, rec.q, rec.v_tau, cond, payload_kg,
                              joint_names=ORTHOGLIDE.joint_names), truth
