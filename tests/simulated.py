"""Records from the simulated Orthoglide (orthoglide_sim) for tests: a test fixture.

    recs = simulated_pair(15.0, (5, 6), "real", profile="realistic")

The test is skipped when the simulator is not importable.
"""
from __future__ import annotations

import importlib

from orthoglide_ident.identify import Record
from orthoglide_ident.model.registry import load_robot

ORTHOGLIDE = load_robot("orthoglide")  # the robot these records are of


def simulated_pair(seconds: float, seeds: tuple[int, int], name: str, **simulate_kwargs
                   ) -> list[Record]:
    """An unloaded record on the "exciting" trajectory and a 1.983 kg one on "exciting2", each
    ``seconds`` long with its seed, named ``<name>-unloaded`` and ``<name>-loaded``;
    ``simulate_kwargs`` go to orthoglide_sim.orthoglide.record.simulate (profile, controller...)."""
    simulate = importlib.import_module("orthoglide_sim.orthoglide.record").simulate
    recs = []
    for payload, seed, trajectory in (("none", seeds[0], "exciting"),
                                      ("1.983", seeds[1], "exciting2")):
        r = simulate(seconds, payload=payload, trajectory=trajectory, seed=seed, **simulate_kwargs)
        cond = "loaded" if r.payload_mass > 0 else "unloaded"
        recs.append(Record.from_arrays(f"{name}-{cond}", r.stamps_ns, r.q, r.v_tau, cond,
                                       r.payload_mass, joint_names=ORTHOGLIDE.joint_names))
    return recs
