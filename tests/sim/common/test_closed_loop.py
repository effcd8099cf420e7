"""The one closed loop, PID and quantiser every simulated robot runs (common/closed_loop.py),
against closed forms: the PID's triple pole, and a double integrator under the loop."""
from __future__ import annotations

import numpy as np

from orthoglide_sim.common.closed_loop import PID, TICK, quantise, run_closed_loop, triple_pole


def test_the_gains_place_a_triple_pole_at_minus_omega():
    """J s³ + Kd s² + Kp s + Ki = J (s + ω)³ (the paper's linear part, Sect. 5.2)."""
    J, omega = np.array([0.7, 10.0]), 100.0
    kp, ki, kd = triple_pole(J, omega)
    for j in range(2):
        np.testing.assert_allclose([J[j], kd[j], kp[j], ki[j]], J[j] * np.poly([-omega] * 3),
                                   rtol=1e-12)


def test_quantise_rounds_to_the_nearest_count():
    res = np.array([1e-6, 1e-3])
    np.testing.assert_array_equal(quantise(np.array([2.4e-6, -2.6e-3]), res),
                                  np.array([2e-6, -3e-3]))


def test_a_double_integrator_settles_on_its_reference():
    """A unit mass (x'' = g i) under the loop, advanced by its exact zero-order-hold solution:
    a 20-count step settles within one count, the integrator holding the load force and a held
    current offset; the noise is applied with the reference, the limit counted."""
    g, load, res = 2.0, 0.3, 1e-6  # N/A, N against the motion, m per count
    state = {"x": 0.0, "v": 0.0}

    def read():
        return np.array([state["x"]]), np.array([state["v"]]), np.array([state["x"]])

    def advance(k, current):
        a = g * current[0] - load
        state["x"] += state["v"] * TICK + 0.5 * a * TICK**2
        state["v"] += a * TICK
        return np.array([a])

    pid = PID.tuned(1.0, g, np.zeros(1), np.array([load]), current_limit=np.array([1.0]))
    N = 3000
    noise = np.zeros((N, 1))
    noise[N // 2:] = 1e-4  # a small held offset late in the run: the integrator takes it up
    out = run_closed_loop(read, lambda k, q: pid.current(q, np.array([2e-5]), np.zeros(1)),
                          advance, noise, res, current_limit=pid.current_limit)
    assert out.saturated == 0 and np.all(np.abs(out.v_tau) < 1.0)
    np.testing.assert_array_equal(out.current, out.v_tau + noise)
    np.testing.assert_allclose(out.logged[:, 0], g * out.current[:, 0] - load, atol=1e-12)
    assert abs(out.q[-1, 0] - 2e-5) <= res
    np.testing.assert_allclose(g * out.current[-1, 0], load, atol=1e-3)
