"""The "realistic" plant profile: each real-drive effect the IDIM lacks is measurably in the force,
and the nominal profile is the plant as it was (the plant-vs-model agreement is
tests/test_sim_plant_vs_model.py)."""
from __future__ import annotations

import numpy as np
import pytest

from orthoglide_ident.errors import ConfigError
from orthoglide_sim.orthoglide import simulator as sm
from orthoglide_sim.orthoglide.plant import Plant
from orthoglide_sim.orthoglide.record import simulate
from orthoglide_sim.orthoglide.truth import PROFILES, load_parameters

TP = load_parameters()
REAL = PROFILES["realistic"]
FS = np.array([TP.values[f"fs_1{i}"] for i in (1, 2, 3)])


def _force_on_plant(drive: sm.DriveModel, q, qd, current) -> np.ndarray:
    """The actuator force (3,) N the drive applies at a state, read back through the plant's
    forward dynamics: the Integrator's first acceleration, against the ideal drive's."""
    plant = Plant(TP)
    ideal = sm.DriveModel(drive.g_tau)
    a = sm.Integrator(plant, drive, q, qd).tick(np.asarray(current, float))
    a0 = sm.Integrator(plant, ideal, q, qd).tick(np.asarray(current, float))
    minv = np.column_stack([plant.forward_dynamics(q, qd, e) - plant.forward_dynamics(q, qd, 0 * e)
                            for e in np.eye(3)])
    return drive.g_tau * np.asarray(current, float) + np.linalg.solve(minv, a - a0)


def test_nominal_profile_is_the_ideal_drive():
    d = sm.drive_model(TP)
    assert d.current_lag_s == 0.0 and not d.has_friction
    assert sm.CURRENT_NOISE_STD == 1e-3 and sm.ENCODER_RESOLUTION == 1e-6
    a = simulate(0.2, trajectory="test1", seed=3)
    b = simulate(0.2, trajectory="test1", seed=3, profile="nominal")
    assert np.array_equal(a.v_tau, b.v_tau) and np.array_equal(a.q, b.q) and a.profile == "nominal"


def test_current_lag_delays_the_force_by_tau():
    tau = REAL.current_lag_s
    d = sm.drive_model(TP, profile="realistic")
    assert d.current_lag_s == tau
    # the motor current after a reference step reaches 1 - 1/e of it at t = tau
    i = d.motor_current(np.zeros(3), np.ones(3), tau)
    assert np.allclose(i, 1.0 - np.exp(-1.0))
    # integrated over a tick: the velocity lags the ideal drive's by the impulse g u tau (1 -
    # e^(-T/tau))
    lag_only = sm.DriveModel(d.g_tau, current_lag_s=tau)
    plant = Plant(TP)
    q, qd, u = (
        np.array([0.03, 0.05, 0.04]),
        np.array([0.3, -0.2, 0.25]),
        np.array([0.2, -0.1, 0.15]),
    )
    lagged = sm.Integrator(plant, lag_only, q, qd, current0=np.zeros(3))
    ideal = sm.Integrator(plant, sm.DriveModel(d.g_tau), q, qd)
    lagged.tick(u)
    ideal.tick(u)
    deficit = d.g_tau * u * tau * (1.0 - np.exp(-sm.TICK / tau))  # N s
    minv = np.column_stack([plant.forward_dynamics(q, qd, e) - plant.forward_dynamics(q, qd, 0 * e)
                            for e in np.eye(3)])
    expected = minv @ deficit
    assert np.allclose(ideal.qd - lagged.qd, expected, rtol=0.03)
    assert np.allclose(lagged.current, u * (1.0 - np.exp(-sm.TICK / tau)))
    # the closed form is exact: 4 RK4 steps per tick agree with 32
    fine = sm.Integrator(plant, lag_only, q, qd, substeps=32, current0=np.zeros(3))
    fine.tick(u)
    assert np.abs(fine.qd - lagged.qd).max() < 2e-8  # the lag's impulse is ~7e-4 m/s here


def test_stribeck_breakaway_above_fs_near_zero_velocity():
    d = sm.drive_model(TP, profile="realistic")
    q = np.array([0.04, 0.04, 0.04])
    plant = Plant(TP)
    V = np.zeros(15)
    v = np.linspace(2e-4, 0.03, 300)
    total = []
    for x in v:  # the plant's actuator friction (fv v + fs tanh + tauoff) plus the drive's
        V[[0, 5, 10]] = x
        total.append(plant.friction(V)[[0, 5, 10]] + d.friction(q, np.full(3, x)))
    coulomb = np.array(total) - plant.fv[[0, 5, 10]] * v[:, None] - plant.tauoff[[0, 5, 10]]
    ripple = REAL.ripple_amplitude * FS  # the screw ripple adds at most this at a given q
    peak = coulomb.max(axis=0)  # the breakaway force: fs (1 + breakaway), near zero velocity
    assert np.all(np.abs(peak - FS * (1.0 + REAL.stribeck_breakaway)) < ripple + 0.01 * FS)
    assert np.all(v[np.argmax(coulomb, axis=0)] < REAL.stribeck_velocity)
    assert np.allclose(coulomb[-1], FS, atol=1.1 * ripple.max())  # back to fs at 30 mm/s
    # through the plant's dynamics: the breakaway is in the force the drive applies at 2 mm/s
    f = _force_on_plant(d, q, np.full(3, 2e-3), np.zeros(3))
    assert np.all(-f > 0.5 * REAL.stribeck_breakaway * FS)
    nominal = sm.drive_model(TP)
    assert np.allclose(nominal.friction(q, np.full(3, 2e-3)), 0.0)


def test_screw_ripple_varies_with_position_at_the_lead():
    d = sm.drive_model(TP, profile="realistic")
    lead = REAL.ripple_lead
    qs = 0.03 + lead * np.arange(16) / 16.0
    qd = np.full(3, 0.2)  # well above the Stribeck velocity: ripple only
    f = np.array([-_force_on_plant(d, np.full(3, x), qd, np.zeros(3)) for x in qs])  # (16, 3)
    phase = 2 * np.pi * qs / lead
    amp = 2 * np.abs(np.exp(-1j * phase) @ f) / len(qs)  # component at the lead's period
    half = 2 * np.abs(np.exp(-2j * phase) @ f) / len(qs)  # at half the lead
    assert np.allclose(amp, REAL.ripple_amplitude * FS, rtol=0.02)
    assert np.all(half < 0.02 * amp)
    # with the velocity reversed the ripple turns with it (a friction ripple)
    fr = -_force_on_plant(d, np.full(3, qs[3]), -qd, np.zeros(3))
    assert np.allclose(fr, -f[3], rtol=1e-6)


def test_profile_selector_in_simulate_and_bags(tmp_path):
    a = simulate(0.3, trajectory="test1", seed=2, profile="nominal", noise=False)
    b = simulate(0.3, trajectory="test1", seed=2, profile="realistic", noise=False)
    assert b.profile == "realistic"
    assert np.abs(a.v_tau - b.v_tau).max() > 1e-4  # the controller fights what the drive adds
    n = simulate(0.3, trajectory="test1", seed=2, profile="realistic")
    assert np.std(n.v_tau - b.v_tau) > 0  # 2 mA noise on the realistic drive
    with pytest.raises(ConfigError, match="unknown plant profile"):
        simulate(0.1, profile="rough")
    from orthoglide_ident import bags
    from orthoglide_sim.orthoglide.make_bags import main

    assert main(["--duration", "0.8", "--out", str(tmp_path), "--profile", "realistic"]) == 0
    data = bags.read_bag(tmp_path / "loaded")
    assert data.tags.condition == "loaded" and len(data.joint_states.stamps_ns) == 800
    meta = (tmp_path / "loaded" / "metadata.yaml").read_text()
    assert "orthoglide.sim.profile" in meta and "realistic" in meta
    assert main(["--duration", "0.1", "--out", str(tmp_path), "--profile", "rough"]) == 2
