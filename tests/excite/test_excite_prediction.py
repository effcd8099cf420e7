"""The predicted σ (excite/prediction.py) against a Monte Carlo on the model itself: the model's
own efforts plus white current noise, identified by the product's IDIM-TLS (eqs. 33-39)."""
from __future__ import annotations

import numpy as np
import pytest

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.excite.prediction import (
    RunSamples,
    noise_from_result,
    nominal_base_values,
    predict,
    run_rows,
)
from orthoglide_ident.identify.observe.equations import Observations
from orthoglide_ident.identify.solve.tls import idim_tls
from orthoglide_ident.model.registry import load_robot
from orthoglide_ident.model.robot import Payload

TRIALS = 150


def fourier_samples(n: int, m: int, seed: int, centre: np.ndarray, amp: float):
    """m samples of a random 3-harmonic series per joint over one 4 s period."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 4.0, m, endpoint=False)
    w = 2 * np.pi / 4.0 * np.arange(1, 4)
    a, b = rng.normal(0, amp, (2, n, 3))
    s, c = np.sin(np.outer(t, w)), np.cos(np.outer(t, w))
    q = centre + s @ (a / w).T - c @ (b / w).T
    return q, c @ a.T + s @ b.T, -s @ (a * w).T + c @ (b * w).T


@pytest.fixture(scope="module")
def five_bar_runs():
    robot = load_robot("five_bar")
    payload = Payload(1.0, "tip", (0.01, 0.0, 0.02), (1e-4, 0, 0, 1e-4, 0, 1e-4))
    centre = np.array([2.1, 1.04])
    runs = [RunSamples(*fourier_samples(2, 600, s, centre, 0.5), 0.6, p)
            for s, p in ((0, None), (1, payload))]
    return robot, runs


def test_predicted_gain_sigma_matches_a_monte_carlo_of_the_tls(five_bar_runs):
    """600 + 600 samples, 0.05 A of current noise: the spread of the TLS gains over 150 noise
    draws within 20 % of the prediction (the sd of 150 draws is itself known to ±6 %). The
    mixed LS-TLS: the noise model of the prediction (exact W, noisy currents); the paper's TLS
    with every column noisy meets it on records whose W is noisy too (the bench)."""
    robot, runs = five_bar_runs
    chi_b, g = nominal_base_values(robot), robot.nominal_gains
    noise = np.array([0.05, 0.05])
    pred = predict(robot, runs, noise)
    rows = [run_rows(robot, chi_b, g, r) for r in runs]
    rng = np.random.default_rng(7)
    gains = []
    for _ in range(TRIALS):
        obs = []
        for k, ((X, tau), r) in enumerate(zip(rows, runs)):
            v = tau / g[:, None] + rng.normal(0.0, 1.0, tau.shape) * noise[:, None]
            mass = r.payload.mass if r.payload else 0.0
            obs.append(Observations(f"mc{k}", "loaded" if mass else "unloaded", mass,
                                    X[:-1].transpose(1, 2, 0), v, X[-1]))
        gains.append(idim_tls(obs, noisy_columns="currents").g_tau)
    spread = np.std(np.array(gains) / g - 1, axis=0, ddof=1)
    print("predicted σ %", 100 * pred.gain_rel_std, "Monte Carlo %", 100 * spread)
    assert np.all(np.abs(spread / pred.gain_rel_std - 1) < 0.2)
    assert np.abs(np.mean(gains, axis=0) / g - 1).max() < 4 * pred.gain_rel_std.max()


def test_sigma_falls_as_one_over_root_duration_and_needs_a_loaded_run(five_bar_runs):
    robot, runs = five_bar_runs
    p1 = predict(robot, runs, 0.05)
    longer = [RunSamples(r.q, r.qd, r.qdd, 4 * r.seconds, r.payload) for r in runs]
    p4 = predict(robot, longer, 0.05)
    np.testing.assert_allclose(p4.gain_rel_std, p1.gain_rel_std / 2, rtol=1e-9)
    assert p1.condition == pytest.approx(p4.condition)
    from orthoglide_ident.errors import ExcitationError

    with pytest.raises(ExcitationError, match="loaded run"):
        predict(robot, [runs[0]], 0.05)


def test_noise_from_a_previous_result_scales_the_residual_per_row():
    doc = {"joint_names": ["joint_1", "joint_2"], "residual_rms_per_joint": [0.01, 0.02],
           "drive_gains": [{"joint": "joint_1", "value": 0.5}, {"joint": "joint_2", "value": 0.4}],
           "diagnostics": {"decimation": 4}}
    np.testing.assert_allclose(noise_from_result(doc, ("joint_1", "joint_2"), "r.json"),
                               [0.04, 0.1])
    doc["diagnostics"]["solver"] = {"joint_sigma": [0.01, 0.04]}  # the TLS's row weights
    noise = noise_from_result(doc, ("joint_1", "joint_2"), "r.json")
    assert noise[1] / noise[0] == pytest.approx(4 * 0.5 / 0.4)  # as the weights, per gain
    pooled = np.sqrt(np.mean([1.0, 0.25]))  # residual / weight, pooled
    assert noise[0] == pytest.approx(0.01 * pooled / 0.5 * 2)
    with pytest.raises(ConfigError, match="r.json: not an identification result"):
        noise_from_result({"joint_names": ["x"]}, ("joint_1",), "r.json")


def test_the_current_lag_terms_only_add_unknowns(five_bar_runs):
    """With the lag terms the identification adds on periodic records, every σ is as large or
    larger (more unknowns), and the periodic difference is the effort's derivative."""
    robot, runs = five_bar_runs
    plain = predict(robot, runs, 0.05)
    lagged = predict(robot, runs, 0.05, lag=True, period_s=4.0)
    assert np.all(lagged.gain_rel_std >= plain.gain_rel_std * (1 - 1e-9))
    assert np.all(lagged.base_std >= plain.base_std * (1 - 1e-9))
    from orthoglide_ident.excite.prediction import periodic_rate

    t = np.linspace(0.0, 4.0, 400, endpoint=False)
    x = np.sin(2 * np.pi * t / 4.0)[None]
    np.testing.assert_allclose(periodic_rate(x, 0.01), (np.pi / 2) * np.cos(np.pi * t / 2)[None],
                               atol=2e-4)
