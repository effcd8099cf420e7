"""The plant (Lagrange + autodiff, orthoglide_sim.plant) and the identification model
(Newton-Euler tree + loop closure, orthoglide_ident.model) agree on random states."""
from __future__ import annotations

import numpy as np
import pytest

from orthoglide_sim import kinematics as kin
from orthoglide_sim import plant as pl
from orthoglide_sim.true_parameters import load_parameters

idim = pytest.importorskip("orthoglide_ident.model.idim")


def _random_states(n: int, seed: int = 1):
    """States inside the safe box with every tree joint velocity far from zero (sign == tanh)."""
    rng = np.random.default_rng(seed)
    out = []
    while len(out) < n:
        q = rng.uniform(-0.08, 0.08, 3)
        qd = rng.uniform(-1.0, 1.0, 3)
        qdd = rng.uniform(-15.0, 15.0, 3)
        Jt = np.asarray(pl.jax.jacfwd(kin.tree_joints)(pl.jnp.asarray(q)))  # (3, 5, 3)
        qtd = Jt @ qd
        if np.min(np.abs(qtd[:, :1])) > 0.05 and np.min(np.abs(qtd[:, 1:])) > 0.2:
            out.append((q, qd, qdd))
    return (np.array(v) for v in zip(*out))


def test_plant_inverse_of_forward_matches_model():
    tp = load_parameters()
    chi_st = tp.standard_vector()
    chi_l = tp.payload_vector("1.983")
    q, qd, qdd = _random_states(12)
    N = len(q)
    # plant: forward dynamics under random forces, sign() friction like the model
    tau = np.random.default_rng(2).uniform(-300.0, 300.0, (N, 3))
    qdd_plant = pl.forward_dynamics(q, qd, tau, (chi_st, chi_l), coulomb="sign")
    W_st, W_l = idim.standard_regressor(q, qd, qdd_plant)
    tau_model = (W_st @ chi_st + W_l @ chi_l).reshape(3, N).T
    rel = np.abs(tau_model - tau).max() / np.abs(tau).max()
    assert rel < 1e-9, rel


def test_plant_regressor_columns_match_model():
    """Column by column: tells which standard parameter disagrees, if any."""
    q, qd, qdd = _random_states(6, seed=3)
    W_model, _ = idim.standard_regressor(q, qd, qdd)
    W_plant = pl.parameter_regressor(q, qd, qdd)
    scale = np.abs(W_model).max(axis=0) + 1e-12
    err = np.abs(W_model - W_plant).max(axis=0) / np.maximum(scale, 1.0)
    names = load_parameters().names
    bad = [(names[k], float(err[k])) for k in np.argsort(-err)[:5] if err[k] > 1e-9]
    assert not bad, bad
