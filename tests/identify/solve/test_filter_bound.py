"""The derivative filter's bias bound in a slow log's gain σ (solve/filter_bound.py, issue 43)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from orthoglide_ident.identify import IdentifyOptions
from orthoglide_ident.identify.solve.filter_bound import second_cutoff, widen
from orthoglide_ident.results import Estimate, IdentificationResult


def _result(values, rel_std) -> IdentificationResult:
    gains = [Estimate(f"j{i}", v, s) for i, (v, s) in enumerate(zip(values, rel_std))]
    return IdentificationResult("tls", [g.name for g in gains], gains, False, [], None, [], 1.0,
                                [], [], "synthetic")


def test_widen_adds_the_move_in_quadrature_and_refuses_beyond_the_bound():
    res = _result([10.0, 5.0, 2.0], [0.001, 0.002, 0.01])
    other = _result([10.04, 5.0001, 1.8], [0.001, 0.002, 0.01])
    line = widen(res, other, 16.7, 25.0, max_rel_std=0.05)
    # closed form: hypot(σ, |Δ|), Δ = 0.4 %, 0.002 %, 10 %
    assert res.drive_gains[0].rel_std == pytest.approx(math.hypot(0.001, 0.004))
    assert res.drive_gains[1].rel_std == pytest.approx(math.hypot(0.002, 2e-5))
    assert not res.drive_gains[2].determined and "16.7 to 25 Hz" in res.drive_gains[2].reason
    assert "j0" in line and "j1 " not in line  # j1 moved less than its σ: not listed
    # a gain the second solve leaves not determined keeps its σ and is named
    res, other = _result([10.0], [0.001]), _result([10.0], [0.001])
    other.drive_gains[0].determined = False
    assert "j0 not determined at 25 Hz" in widen(res, other, 16.7, 25.0, 0.05)
    assert res.drive_gains[0].determined and res.drive_gains[0].rel_std == 0.001


def test_the_second_cut_off_stays_below_the_nyquist_frequency():
    from types import SimpleNamespace

    bags = [SimpleNamespace(filter_cutoff_hz=16.67, period_s=0.012, decimation_cutoff_hz=6.67)]
    f2, fd = second_cutoff(bags)
    assert f2 == pytest.approx(25.0, rel=1e-3) and fd == 6.67
    bags = [SimpleNamespace(filter_cutoff_hz=30.0, period_s=0.012, decimation_cutoff_hz=6.67)]
    assert second_cutoff(bags) is None  # 0.4 x 83 Hz = 33 Hz: too close to move


@pytest.mark.slow
def test_a_point_sampled_83_hz_log_marks_no_biased_gain_determined():
    """UR5 under its 1 kHz PID logged every 10/12/14 ticks, the loop's current band-limited
    below the log's Nyquist frequency (bench/logger_sampling.py's '~83 Hz pt, smooth'), read
    sampled with the loop's rate known: every gain marked determined within 3 σ of the
    plant's (before the bound: wrist_3 about -0.4 % at > 3 σ, the derivative filter's bias)."""
    import dataclasses

    from orthoglide_ident.identify import Record, identify_records
    from orthoglide_ident.identify.observe.filtering import zero_phase_butterworth
    from orthoglide_ident.model.registry import load_robot
    from orthoglide_ident.model.robot import Payload
    from orthoglide_sim.arms.log import (
        KEEP_10_12_14,
        clock_uniform,
        point_sampled,
        simulate_arm_log,
    )

    seconds, recs = 40.0, []
    for p, tr, s in ((None, "exciting1", 0), ("2.0", "exciting2", 1)):
        r = simulate_arm_log(seconds, clock_uniform(seconds, 1000.0), payload=p, trajectory=tr,
                             seed=s, print_resolution=0.0)
        r = dataclasses.replace(r, v_tau=zero_phase_butterworth(r.v_tau, 1e-3, 0.35 * 83.3, 4))
        r = point_sampled(r, KEEP_10_12_14, 0.0)
        tag = None if r.payload is None else r.payload.tag()
        pl = None if tag is None else Payload(r.payload_mass, tag["payload_frame"],
                                              tuple(tag["payload_com"]),
                                              tuple(tag["payload_inertia"]))
        recs.append((r, Record.from_arrays(f"r{s}", r.stamps_ns, r.q, r.v_tau,
                                           "loaded" if pl else "unloaded", r.payload_mass,
                                           r.joint_names, pl)))
    res = identify_records([x for _, x in recs], model=load_robot("ur5"),
                           options=IdentifyOptions.of(current_sampling="sampled",
                                                      current_loop_hz=1000.0))
    truth = recs[0][0].truth.drive_array("g_tau")
    z = np.array([abs(g.value / t - 1) / g.rel_std for g, t in zip(res.drive_gains, truth)
                  if g.determined])
    assert z.size >= 5 and z.max() < 3.0, z
    assert any(w.startswith("slow log: the gains' σ include") for w in res.warnings)
