"""Plant physics: energy balance, kinematics vs the generic MDH chain, the fast integrator."""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from orthoglide_sim import kinematics as kin
from orthoglide_sim import plant as pl
from orthoglide_sim import simulator as sm
from orthoglide_sim.true_parameters import load_parameters


def _frictionless(p: pl.PlantParams) -> pl.PlantParams:
    return p._replace(fv=0 * p.fv, fs=0 * p.fs, tauoff=0 * p.tauoff)


def test_isotropic_configuration_and_mdh_chain():
    assert np.allclose(kin.platform_position(jnp.zeros(3)), [0.0, 0.0, kin.A])
    q = jnp.array([0.05, -0.02, 0.09])
    O, R = kin.body_poses(q)
    O2, R2 = kin.body_poses_mdh(q)
    assert np.abs(O - O2).max() < 1e-14 and np.abs(R - R2).max() < 1e-14
    P = kin.platform_position(q)
    for i in range(3):  # origin of frame 4_i is C_i = P - d6 e_i, at d4 from the foot
        assert np.allclose(O[5 * i + 3], P - kin.D6 * kin.E_AXIS[i], atol=1e-14)
        assert abs(np.linalg.norm(O[5 * i + 3] - O[5 * i]) - kin.D4) < 1e-14


def test_energy_balance_without_friction_instantaneous():
    """d/dt (T + V) = qd . tau along the forward dynamics (no friction)."""
    p = _frictionless(pl.plant_params(load_parameters(), "1.983"))
    rng = np.random.default_rng(0)
    dE = jax.grad(pl.total_energy, (0, 1))
    for _ in range(4):
        q, qd = jnp.asarray(rng.uniform(-0.03, 0.11, 3)), jnp.asarray(rng.uniform(-1, 1, 3))
        tau = jnp.asarray(rng.uniform(-200, 200, 3))
        qdd = pl.forward_dynamics(q, qd, tau, p)
        gq, gqd = dE(q, qd, p)
        power = float(qd @ tau)
        assert abs(float(gq @ qd + gqd @ qdd) - power) < 1e-10 * (abs(power) + 1.0)


def test_energy_balance_without_friction_integrated():
    """The 10 kHz integrator (fast, per-tick geometry) conserves T + V without friction or force."""
    tp = load_parameters()
    p = _frictionless(pl.plant_params(tp, "none"))
    drive = sm.drive_model(tp, ripple=False)
    x = jnp.array([0.03, 0.05, 0.02, 0.6, -0.5, 0.4])
    E0 = float(pl.total_energy(x[:3], x[3:], p))
    step = jax.jit(lambda x: sm._rk4_tick(x, jnp.zeros(3), p, drive, sm.SUBSTEPS)[0])
    for _ in range(100):  # 0.1 s
        x = step(x)
    E1 = float(pl.total_energy(x[:3], x[3:], p))
    assert abs(E1 - E0) < 1e-6 * abs(E0), (E0, E1)


def test_fast_integrator_matches_exact():
    tp = load_parameters()
    p = pl.plant_params(tp, "1.136")
    drive = sm.drive_model(tp)
    x = jnp.array([0.03, 0.05, 0.02, 0.8, -0.6, 0.5])
    f = jnp.array([150.0, -80.0, 60.0])
    fast = jax.jit(lambda x: sm._rk4_tick(x, f, p, drive, sm.SUBSTEPS)[0])(x)
    exact = jax.jit(lambda x: sm._rk4_tick(x, f, p, drive, sm.SUBSTEPS, exact=True)[0])(x)
    assert np.abs(fast - exact)[:3].max() < 1e-9
    assert np.abs(fast - exact)[3:].max() < 1e-6


def test_smooth_coulomb_turns_through_zero():
    p = pl.plant_params(load_parameters())
    q = jnp.array([0.04, 0.04, 0.04])
    f0 = pl.friction_force(q, jnp.zeros(3), p)
    f_small = pl.friction_force(q, jnp.array([1e-5, 0.0, 0.0]), p)
    # at rest only the offsets remain; a tiny velocity gives a tiny Coulomb force (no jump)
    assert abs(float(f_small[0] - f0[0])) < 0.5
