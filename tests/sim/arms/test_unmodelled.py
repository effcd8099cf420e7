"""The arm simulator's unmodelled drive effects (orthoglide_sim/arms/unmodelled.py): off, the
usual loop to the bit; each effect's law against its closed form."""
from __future__ import annotations

import numpy as np
import pytest

from orthoglide_sim.arms.record import simulate_arm
from orthoglide_sim.arms.unmodelled import DriveState, Unmodelled, current_loop_matrices


def test_no_effect_is_the_usual_loop():
    a = simulate_arm(0.1, trajectory="exciting1", seed=3)
    b = simulate_arm(0.1, trajectory="exciting1", seed=3, effects=Unmodelled())
    assert np.array_equal(a.v_tau, b.v_tau) and np.array_equal(a.q, b.q)


@pytest.mark.parametrize("zeta", [0.3, 0.7])
def test_the_current_loop_is_the_second_order_step_response(zeta):
    """i(t) under a unit step: 1 - e^(-ζωt) (cos ω_d t + ζ/√(1-ζ²) sin ω_d t), ω_d = ω√(1-ζ²)."""
    f, dt = 1000.0, 2.5e-4
    Phi, Gamma = current_loop_matrices(f, zeta, dt)
    x, got = np.zeros(2), []
    for _ in range(40):
        x = Phi @ x + Gamma * 1.0
        got.append(x[0])
    w = 2 * np.pi * f
    wd = w * np.sqrt(1 - zeta**2)
    t = dt * np.arange(1, 41)
    exact = 1 - np.exp(-zeta * w * t) * (
        np.cos(wd * t) + zeta / np.sqrt(1 - zeta**2) * np.sin(wd * t)
    )
    np.testing.assert_allclose(got, exact, rtol=0, atol=1e-12)


def test_the_gap_the_spring_and_the_stribeck_excess():
    fx = Unmodelled(elasticity_hz=50.0, backlash=2e-3, stribeck=0.5, stribeck_velocity=0.02)
    J, J_m, f_c = np.array([2.0]), np.array([0.5]), np.array([4.0])
    d = DriveState(fx, J, J_m, f_c, 2.5e-4)
    K = 2.0 * (2 * np.pi * 50.0) ** 2
    d.theta, d.omega = np.array([0.0005]), np.array([0.0])
    assert d.spring(np.zeros(1), np.zeros(1))[0] == 0.0  # inside the gap (half of 2 mrad)
    d.theta = np.array([0.003])
    assert d.spring(np.zeros(1), np.zeros(1))[0] == pytest.approx(K * 0.002)  # 1 mrad past it
    assert d.stribeck(np.array([0.02]))[0] == pytest.approx(-0.5 * 4.0 * np.exp(-1.0))
    assert d.stribeck(np.array([-1.0]))[0] == pytest.approx(0.0, abs=1e-12)
    d.start(np.zeros(1), np.zeros(1), np.array([1.0]), np.array([10.0]))
    assert d.spring(np.zeros(1), np.zeros(1))[0] == pytest.approx(10.0)  # the start torque carried
