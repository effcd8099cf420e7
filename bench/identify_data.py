"""Records for the identification benchmarks: the simulator when it is there, else model data.

``record(duration_s, payload_kg, seed, noise)`` returns (Record, truth) where truth holds the
true drive gains (``g_tau``) and, for model data, the true base parameters (``chi``).

- simulator (``orthoglide_sim.record.simulate``): the faithful plant of DESIGN §5, closed loop,
  smooth Coulomb friction, 1 µm encoder, current noise.
- fallback, "model data": q(t) a sum of sines near the Orthoglide's speed and acceleration limits,
  v_τ = zero-order-hold mean of (W χ + W_kl m_7)/g_τ with the base model and the simulator's true
  parameters, 1 µm quantisation and 1 mA current noise. Not a plant: no controller, sign() friction.
"""
from __future__ import annotations

import numpy as np

from orthoglide_ident.identify.pipeline import Record


def simulator_available(trajectory: str = "exciting") -> bool:
    """The simulator is importable and has the (optimised) trajectory."""
    try:
        from orthoglide_sim.record import simulate  # noqa: F401
        from orthoglide_sim.trajectories import get_trajectory

        get_trajectory(trajectory)
    except Exception:
        return False
    return True


def record(duration_s: float, payload_kg: float, seed: int, noise: bool = True,
           source: str | None = None, trajectory: str = "exciting",
           profile: str | None = None) -> tuple[Record, dict]:
    """``profile``: the simulator's plant profile ("nominal" by default, or "realistic")."""
    cond = "loaded" if payload_kg > 0 else "unloaded"
    name = source or f"{cond}-{payload_kg:g}kg-seed{seed}"
    if simulator_available(trajectory):
        from orthoglide_sim.record import simulate

        payload = "none" if payload_kg == 0 else (f"{payload_kg:g}" if f"{payload_kg:g}" in
                                                 ("1.983", "1.136") else payload_kg)
        rec = simulate(duration_s, payload=payload, trajectory=trajectory, seed=seed, noise=noise,
                       profile=profile)
        truth = {"g_tau": np.asarray(rec.g_tau, float), "source": f"simulator ({trajectory})"}
        return Record.from_arrays(name, rec.stamps_ns, rec.q, rec.v_tau, cond, payload_kg), truth
    from orthoglide_ident.identify.synthetic import synthetic_record
    from orthoglide_ident.model.base import base_model
    from orthoglide_sim.true_parameters import default_parameters

    bm = base_model()
    tp = default_parameters()
    chi = bm.base_values(tp.standard_vector())
    g = np.array(tp.g_tau, float)
    rec = synthetic_record(duration_s, payload_kg, seed=seed, noise=noise, model=bm, chi=chi,
                           g_tau=g, amplitude=0.13, f_max=3.5, current_noise_a=1e-3, source=name)
    return rec, {"g_tau": g, "chi": chi, "source": "model data (no simulator)"}
