"""The plant (Pinocchio: P + 4R legs closed by 6D constraints, orthoglide_sim.orthoglide.plant) and
the
identification model (Newton-Euler tree + loop closure, orthoglide_ident.model) agree on random
states, loaded and unloaded, parameter by parameter."""
from __future__ import annotations

import numpy as np
import pytest

from orthoglide_ident.model.orthoglide import idim
from orthoglide_sim.orthoglide import kinematics as kin
from orthoglide_sim.orthoglide.plant import Plant
from orthoglide_sim.orthoglide.truth import apply_overrides, load_parameters


def _random_states(n: int, seed: int = 1):
    """States inside the safe box with every tree joint velocity far from zero (sign == tanh)."""
    rng = np.random.default_rng(seed)
    out = []
    while len(out) < n:
        q = rng.uniform(-0.08, 0.08, 3) + 0.04
        qd = rng.uniform(-1.0, 1.0, 3)
        qdd = rng.uniform(-15.0, 15.0, 3)
        _, qtd = kin.tree_state(q, qd)
        if np.min(np.abs(qtd[:, :1])) > 0.05 and np.min(np.abs(qtd[:, 1:])) > 0.2:
            out.append((q, qd, qdd))
    return (np.array(v) for v in zip(*out))


@pytest.mark.parametrize("payload", ["none", "1.983"])
def test_plant_forward_dynamics_matches_model(payload):
    """Forward dynamics under random forces, then the model's W_st chi_st + W_l chi_l gives them
    back."""
    tp = load_parameters()
    q, qd, _ = _random_states(12)
    tau = np.random.default_rng(2).uniform(-300.0, 300.0, q.shape)
    qdd = Plant(tp, payload, coulomb="sign").forward_dynamics(q, qd, tau)
    W_st, W_l = idim.standard_regressor(q, qd, qdd)
    tau_model = (
        (W_st @ tp.standard_vector() + W_l @ tp.payload_vector(payload)).reshape(3, len(q)).T
    )
    rel = np.abs(tau_model - tau).max() / np.abs(tau).max()
    assert rel < 1e-9, rel


def test_plant_regressor_columns_match_model():
    """Parameter by parameter: the plant's force is affine in each standard parameter, so
    (tau(chi + d e_j) - tau(chi)) / d is its column j; tells which parameter disagrees, if any."""
    tp = load_parameters()
    q, qd, qdd = _random_states(4, seed=3)
    W_model, _ = idim.standard_regressor(q, qd, qdd)
    base = Plant(tp, coulomb="sign").inverse_dynamics(q, qd, qdd)
    bad = []
    for j, name in enumerate(tp.names):
        d = max(0.1 * abs(tp.values[name]), 0.01)  # any step: affine; not too small for round-off
        moved = apply_overrides(tp, {"parameters": {name: tp.values[name] + d}})
        column = ((Plant(moved, coulomb="sign").inverse_dynamics(q, qd, qdd) - base) / d).T.ravel()
        scale = max(np.abs(W_model[:, j]).max(), 1.0)
        err = np.abs(column - W_model[:, j]).max() / scale
        if err > 1e-7:  # round-off floor ~1e-13 x 300 N / step; a mis-mapped parameter gives > 1e-3
            bad.append((name, float(err)))
    assert not bad, bad[:5]
