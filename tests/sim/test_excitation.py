"""The exciting pair is designed for what IDIM-TLS is asked for: the drive gains."""
from __future__ import annotations

import numpy as np

from orthoglide_sim.excitation import (COND_SOFT, Design, criterion, predicted_gain_std,
                                       scaled)
from orthoglide_sim.trajectories import FourierTrajectory, get_trajectory


def test_committed_pair_predicts_the_gains_to_a_seventh_of_a_percent():
    # 30 s unloaded + 30 s with 1.983 kg, 1 mA white current noise. The pair designed for
    # cond(W) alone (before 2026-12) predicted 0.161, 0.213, 0.079 %.
    design = Design.default()
    s = predicted_gain_std(get_trajectory("exciting1"), get_trajectory("exciting2"), design)
    assert np.all(s < 0.13), s
    for name in ("exciting1", "exciting2"):
        assert criterion(get_trajectory(name), design.regressor) < 1.5 * COND_SOFT


def test_predicted_gain_std_follows_the_payload_signal():
    # The gains are scaled by the known payload's force. Loaded trajectory at half the
    # amplitude: the horizontal actuators 1 and 2 see only its inertial force, now halved, and
    # their σ grows a lot; the vertical actuator 3 also carries its weight, which stays.
    tu, tl = get_trajectory("exciting1"), get_trajectory("exciting2")
    small = FourierTrajectory(tl.q0, 0.5 * tl.a, 0.5 * tl.b, tl.w_f)
    s_full, s_small = predicted_gain_std(tu, tl), predicted_gain_std(tu, small)
    assert np.all(s_small[:2] > 1.4 * s_full[:2]), (s_full, s_small)
    assert s_small[2] < 1.2 * s_full[2], (s_full, s_small)


def test_scaled_trajectory_sits_on_a_limit():
    rng = np.random.default_rng(3)
    traj = scaled(FourierTrajectory(np.full(3, 0.04), rng.normal(size=(3, 4)),
                                    rng.normal(size=(3, 4)), 2 * np.pi / 1.5))
    t = np.linspace(0.0, traj.period, 2000, endpoint=False)
    q, qd, qdd = traj.evaluate(t)
    from orthoglide_sim.excitation import POSITION_LIMIT
    from orthoglide_sim.trajectories import A_MAX, V_MAX
    ratios = [np.ptp(q, 0).max() / (2 * POSITION_LIMIT), np.abs(qd).max() / V_MAX,
              np.abs(qdd).max() / A_MAX]
    assert max(ratios) > 0.99 and max(ratios) < 1.01, ratios
