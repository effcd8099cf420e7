"""The Orthoglide's exciting pair: its predicted gain σ (the product's prediction over the
simulator's parameter table), and its design command (the product's designer in the safe box)."""
from __future__ import annotations

import json

import numpy as np

from orthoglide_ident.excite import FourierSeries
from orthoglide_ident.model.registry import load_robot
from orthoglide_sim.common.trajectories import A_MAX, Q_CENTER, Q_HALF, V_MAX, get_trajectory
from orthoglide_sim.orthoglide.excitation import (
    DESIGN_NOISE_A,
    DESIGN_PAYLOAD_KG,
    DESIGN_SECONDS,
    main,
    predicted_gain_std,
)
from orthoglide_sim.orthoglide.truth import load_parameters


def _linearised_std(unloaded, loaded, n=240):
    """Eqs. (35)-(36) linearised, written out: unknowns [χ, g] of W χ − V g = −W_kl m, rows
    [W, −V] (V: the a priori currents, joint j's in column j), each standing for the record's
    1 kHz samples; white current noise σ_i: σ(g)/g = σ_i √((AᵀA)⁻¹)_gg at equal gains."""
    robot = load_robot("orthoglide")
    chi = robot.base_values(load_parameters().standard_vector())
    g = robot.nominal_gains
    blocks = []
    for traj, mass in ((unloaded, 0.0), (loaded, DESIGN_PAYLOAD_KG)):
        t = np.linspace(0.0, traj.period, n, endpoint=False)
        q, qd, qdd = traj.evaluate(t)
        W = robot.regressor(q, qd, qdd)
        f = (W @ chi + mass * robot.payload_mass_column(q, qd, qdd)).reshape(3, n)
        V = np.zeros((3 * n, 3))
        for j in range(3):
            V[j * n:(j + 1) * n, j] = f[j] / g[j]
        blocks.append(np.hstack([W, -V]) * np.sqrt(DESIGN_SECONDS * 1000.0 / n))
    A = np.vstack(blocks)
    return 100.0 * DESIGN_NOISE_A * np.sqrt(np.diag(np.linalg.inv(A.T @ A))[-3:])


def test_committed_pair_predicts_the_gains_to_a_seventh_of_a_percent():
    # 30 s unloaded + 30 s with 1.983 kg, 1 mA white current noise. The pair designed for
    # cond(W) alone (before 2026-12) predicted 0.161, 0.213, 0.079 %.
    tu, tl = get_trajectory("exciting1"), get_trajectory("exciting2")
    s = predicted_gain_std(tu, tl)
    assert np.all(s < 0.13), s
    np.testing.assert_allclose(s, _linearised_std(tu, tl), rtol=1e-8)


def test_predicted_gain_std_follows_the_payload_signal():
    # The gains are scaled by the known payload's force. Loaded trajectory at half the
    # amplitude: the horizontal actuators 1 and 2 see only its inertial force, now halved, and
    # their σ grows a lot; the vertical actuator 3 also carries its weight, which stays.
    tu, tl = get_trajectory("exciting1"), get_trajectory("exciting2")
    small = FourierSeries(tl.q0, 0.5 * tl.a, 0.5 * tl.b, tl.w_f)
    s_full, s_small = predicted_gain_std(tu, tl), predicted_gain_std(tu, small)
    assert np.all(s_small[:2] > 1.4 * s_full[:2]), (s_full, s_small)
    assert s_small[2] < 1.2 * s_full[2], (s_full, s_small)


def test_design_command_writes_a_pair_inside_the_box_from_the_products_designer(tmp_path):
    assert main(["--restarts", "1", "--steps", "1", "--harmonics", "2", "--search", "walk",
                 "--out-dir", str(tmp_path)]) == 0
    pair = [get_trajectory(str(tmp_path / f"exciting{k}.json")) for k in (1, 2)]
    for k, traj in enumerate(pair, 1):
        doc = json.loads((tmp_path / f"exciting{k}.json").read_text())
        assert doc["criterion"] == "orthoglide_ident.excite.design"
        assert doc["run"] == ("unloaded", "loaded")[k - 1] and doc["robot"] == "orthoglide_general"
        t = np.linspace(0.0, traj.period, 3001)
        q, qd, qdd = traj.evaluate(t)
        assert np.all(np.abs(q - Q_CENTER) <= Q_HALF)
        assert np.abs(qd).max() <= V_MAX and np.abs(qdd).max() <= A_MAX
        assert np.abs(qd[[0, -1]]).max() < 1e-9  # the product's runs start and end at rest
        assert np.isfinite(doc["predicted_gain_std_pct"]).any()
