"""The driver's cheap plant (reduced_plant.ReducedIntegrator) against the reference
(simulator.Integrator:
Pinocchio's constraint dynamics on the 15-joint tree at every RK4 stage), on the same inputs.

Bounds and why:
- exact reduction: at any state the reduced dynamics' accelerations are the tree's constrained ones
  (round-off: 1e-9 relative, the brief asked 1e-6); its compiled kinematics are
  kinematics.tree_state's;
- the same closed-loop PID run (2 s of an exciting trajectory, payload 1.983 kg, noise off) with an
  encoder of negligible resolution: positions within 0.1 um (a tenth of the encoder's count) and
  currents within 0.1 mA (a tenth of the current noise's sigma) at every tick (measured: 0.034 um,
  0.017 mA; the reference at 8 RK4 steps per tick instead of 4 is 0.069 um, 0.043 mA from itself),
  for the nominal drive and for the realistic one (current lag, Stribeck, screw ripple);
- the same run with the 1 um encoder: the quantised loop turns any difference into a count read
  one way or the other near a boundary, and the PID answers a count with up to (Kp 1 um +
  Kd 2 um / T + Ki T sum) / 637 pi = 3.15 mA. So: true positions within 1 um at every tick, readings
  within one count, every current difference the PID's answer to the reading differences, and the
  currents' rms difference below the current noise's sigma.
"""
from __future__ import annotations

import numpy as np
import pytest

from orthoglide_ident.errors import WorkspaceError
from orthoglide_ident.model.orthoglide.geometry import G_TAU_MANUFACTURER
from orthoglide_sim.common.trajectories import get_trajectory
from orthoglide_sim.orthoglide import kinematics as kin
from orthoglide_sim.orthoglide import simulator as sm
from orthoglide_sim.orthoglide.plant import Plant
from orthoglide_sim.orthoglide.reduced_plant import ReducedIntegrator, _tree
from orthoglide_sim.orthoglide.truth import PROFILES, load_parameters

TP = load_parameters()
NOISE_STD = PROFILES["nominal"].current_noise_std  # A
COUNT = PROFILES["nominal"].encoder_resolution  # m


def _states(n: int, seed: int):
    rng = np.random.default_rng(seed)
    return (
        rng.uniform(-0.03, 0.11, (n, 3)),
        rng.uniform(-1.0, 1.0, (n, 3)),
        rng.uniform(-0.3, 0.3, (n, 3)),
    )


def test_compiled_kinematics_are_the_simulators():
    for q, qd, _ in zip(*_states(20, seed=4)):
        Q, G = np.empty(15), np.empty((15, 3))
        assert _tree(q, Q, G)
        qt, qtd = kin.tree_state(q, qd)
        np.testing.assert_allclose(Q, qt.reshape(15), rtol=0, atol=1e-14)
        np.testing.assert_allclose(G @ qd, qtd.reshape(15), rtol=0, atol=1e-13)
    far = np.array([0.5, -0.3, 0.5])  # the legs cannot meet: both say so
    with pytest.raises(WorkspaceError, match="no assembly"):
        kin.platform_position(far)
    assert not _tree(far, np.empty(15), np.empty((15, 3)))


@pytest.mark.parametrize("profile", ["nominal", "realistic"])
def test_accelerations_at_random_states_are_the_tree_constrained_ones(profile):
    """The first tick's start accelerations: the reduction is exact (no time step in it)."""
    plant, drive = Plant(TP, "1.983"), sm.drive_model(TP, profile=profile)
    for q, qd, u in zip(*_states(10, seed=5)):
        ref = sm.Integrator(plant, drive, q, qd).tick(u)
        red = ReducedIntegrator(plant, drive, q, qd).tick(u)
        assert np.max(np.abs(red - ref)) <= 1e-9 * np.max(np.abs(ref)), (red, ref)


def _closed_loop(profile: str, resolution: float):
    q, qd, qdd = get_trajectory("exciting").evaluate(np.arange(2000) * sm.TICK)
    plant, drive = Plant(TP, "1.983"), sm.drive_model(TP, profile=profile)
    return [
        sm.simulate_closed_loop(
            q, qd, qdd, plant, drive, "pid", resolution=resolution, integrator=integ
        )
        for integ in (sm.Integrator, ReducedIntegrator)
    ]


@pytest.mark.parametrize("profile", ["nominal", "realistic"])
def test_same_closed_loop_run_without_quantisation(profile):
    ref, red = _closed_loop(profile, resolution=1e-12)
    assert np.max(np.abs(red.q - ref.q)) < 0.1 * COUNT
    assert np.max(np.abs(red.v_tau - ref.v_tau)) < 0.1 * NOISE_STD
    assert np.max(np.abs(red.qdd - ref.qdd)) < 0.01  # m/s², of accelerations up to ~10 m/s²


def test_same_closed_loop_run_with_the_1um_encoder():
    ref, red = _closed_loop("nominal", resolution=COUNT)
    assert np.max(np.abs(red.q - ref.q)) < COUNT
    dm = red.q_meas - ref.q_meas
    assert np.max(np.abs(dm)) <= COUNT * (1 + 1e-6)
    # the PID (simulator.PID, linear, same reference and pre-load) answers the reading differences
    dm_prev = np.vstack([np.zeros((1, 3)), dm[:-1]])
    answer = -(
        sm.KP * dm + sm.KI * sm.TICK * np.cumsum(dm, axis=0) + sm.KD * (dm - dm_prev) / sm.TICK
    )
    np.testing.assert_allclose(
        red.v_tau - ref.v_tau, answer / G_TAU_MANUFACTURER, rtol=0, atol=1e-9
    )
    assert np.sqrt(np.mean((red.v_tau - ref.v_tau) ** 2)) < NOISE_STD


def test_leaving_the_stroke_or_a_nan_current_stops_with_a_reason():
    plant, drive = Plant(TP), sm.drive_model(TP)
    sim = ReducedIntegrator(plant, drive, [0.04, 0.04, 0.13], [0.0, 0.0, 1.0])
    with pytest.raises(WorkspaceError, match="left the actuator stroke"):
        for _ in range(200):
            sim.tick(np.zeros(3))
    sim = ReducedIntegrator(plant, drive, [0.04, 0.04, 0.04], [0.0, 0.0, 0.0])
    with pytest.raises(WorkspaceError, match="not finite"):
        sim.tick(np.array([np.nan, 0.0, 0.0]))
