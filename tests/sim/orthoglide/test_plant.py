"""Plant physics (Pinocchio): the closed loops hold, energy balance, the integrator, the
workspace."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from orthoglide_ident.errors import WorkspaceError
from orthoglide_sim.orthoglide import kinematics as kin
from orthoglide_sim.orthoglide import simulator as sm
from orthoglide_sim.orthoglide.plant import ACTUATED, Plant, platform_in_body5
from orthoglide_sim.orthoglide.truth import apply_overrides, load_parameters

FRICTION = [f"{p}_{j}{i}" for p in ("fv", "fs", "tauoff") for j in range(1, 6) for i in (1, 2, 3)]


def _frictionless(payload: str = "none") -> Plant:
    tp = apply_overrides(load_parameters(), {"parameters": {n: 0.0 for n in FRICTION}})
    return Plant(tp, payload)


def _random_states(n: int, seed: int):
    rng = np.random.default_rng(seed)
    return rng.uniform(-0.03, 0.11, (n, 3)), rng.uniform(-1.0, 1.0, (n, 3))


def test_isotropic_configuration_and_loops_closed():
    assert np.allclose(kin.platform_position(np.zeros(3)), [0.0, 0.0, kin.A])
    plant = Plant(load_parameters())
    for q, qd in zip(*_random_states(5, seed=0)):
        Q, V = plant.lift(q, qd)
        pin.forwardKinematics(plant.model, plant.data, Q, V)
        P = kin.platform_position(q)
        # every leg's body 5 carries the platform frame at P, parallel to the base
        for leg in range(3):
            oMp = plant.data.oMi[plant._joint5[leg]] * platform_in_body5(leg)
            assert (
                np.abs(oMp.translation - P).max() < 1e-13
                and np.abs(oMp.rotation - np.eye(3)).max() < 1e-13
            )
        # the lifted velocities satisfy the loop constraints (no relative motion of the welds)
        for cm in plant.constraints:
            v1 = pin.getFrameVelocity(
                plant.model, plant.data, cm.joint1_id, cm.joint1_placement, pin.WORLD
            )
            v2 = pin.getFrameVelocity(
                plant.model, plant.data, cm.joint2_id, cm.joint2_placement, pin.WORLD
            )
            assert np.abs((v1 - v2).vector).max() < 1e-12


def test_energy_balance_without_friction_instantaneous():
    """d/dt (T + V) = qd . tau along the forward dynamics (no friction), by central differences."""
    plant = _frictionless("1.983")
    rng = np.random.default_rng(0)
    h = 1e-6
    for q, qd in zip(*_random_states(4, seed=1)):
        tau = rng.uniform(-200.0, 200.0, 3)
        qdd = plant.forward_dynamics(q, qd, tau)
        dE = (plant.energy(q + h * qd, qd + h * qdd) - plant.energy(q - h * qd, qd - h * qdd)) / (
            2 * h
        )
        power = float(qd @ tau)
        assert abs(dE - power) < 1e-6 * (abs(power) + 1.0), (dE, power)


def test_energy_conserved_by_the_integrator_without_friction_or_force():
    plant = _frictionless()
    sim = sm.Integrator(
        plant, sm.drive_model(load_parameters(), ripple=False), [0.03, 0.05, 0.02], [0.6, -0.5, 0.4]
    )
    E0 = plant.energy(sim.q, sim.qd)
    for _ in range(100):  # 0.1 s, with a re-projection on the closed loop on the way
        sim.tick(np.zeros(3))
    E1 = plant.energy(sim.q, sim.qd)
    assert abs(E1 - E0) < 1e-6 * abs(E0), (E0, E1)


def test_integrator_converges():
    """4 RK4 steps per tick against 32: the same state to well under the 1 um encoder step."""
    tp = load_parameters()
    plant, drive = Plant(tp, "1.136"), sm.drive_model(tp)
    x0 = ([0.03, 0.05, 0.02], [0.8, -0.6, 0.5])
    coarse, fine = sm.Integrator(plant, drive, *x0), sm.Integrator(plant, drive, *x0, substeps=32)
    for k in range(50):
        current = np.array([0.07, -0.04, 0.05]) * np.sin(0.1 * k)
        coarse.tick(current)
        fine.tick(current)
    assert np.abs(coarse.q - fine.q).max() < 1e-8
    assert np.abs(coarse.qd - fine.qd).max() < 1e-6


def test_smooth_coulomb_turns_through_zero():
    plant = Plant(load_parameters())
    V = np.zeros(15)
    f0 = plant.friction(V)
    V[ACTUATED[0]] = 1e-5
    # at rest only the offsets remain; a tiny velocity gives a tiny Coulomb force (no jump)
    assert abs(plant.friction(V)[ACTUATED[0]] - f0[ACTUATED[0]]) < 0.5
    assert np.allclose(f0, plant.tauoff)


def test_leaving_the_stroke_or_a_nan_current_stops_with_a_reason():
    tp = load_parameters()
    sim = sm.Integrator(Plant(tp), sm.drive_model(tp), [0.04, 0.04, 0.13], [0.0, 0.0, 1.0])
    with pytest.raises(WorkspaceError, match=r"q13 = 1\d\d\.\d mm left the actuator stroke"):
        for _ in range(100):
            sim.tick(np.zeros(3))
    sim = sm.Integrator(Plant(tp), sm.drive_model(tp), [0.04, 0.04, 0.04], [0.0, 0.0, 0.0])
    with pytest.raises(WorkspaceError, match="not finite"):
        sim.tick(np.array([np.nan, 0.0, 0.0]))
    with pytest.raises(WorkspaceError, match="no assembly"):
        kin.platform_position(np.array([-0.3, -0.3, -0.3]))
