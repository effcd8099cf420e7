"""Velocity reversals bridged, chunking exact (identify/reversals.py, pipeline chunks)."""
from __future__ import annotations

import numpy as np
from synthetic import SyntheticModel, synthetic_record

from orthoglide_ident.identify import IdentifyOptions, identify_records
from orthoglide_ident.identify.observe.reversals import bridge, find_reversals, rows_clear


def test_bridge_removes_the_sign_step_and_keeps_the_linear_relation():
    t = np.arange(2000) * 1e-3
    qd = np.stack([np.sin(2 * np.pi * 1.3 * t), np.cos(2 * np.pi * 0.9 * t), 0.5 + 0 * t], axis=1)
    zones = find_reversals(qd, 0.01, 50)
    assert len(zones.starts[0]) >= 4 and len(zones.starts[2]) == 0
    W = np.stack([qd, np.sign(qd), np.ones_like(qd)], axis=2)  # (n, 3, 3): fv, fs, offset
    chi = np.array([80.0, 30.0, 1.0])
    Y = W @ chi
    Y_true = Y.copy()
    Y[np.abs(qd) < 0.01] += 25.0  # the drive's friction differs from sign() near reversals
    arrays = {"W": W.copy(), "Y": Y}
    bridge(zones, 0, arrays)
    ok = ~zones.drop  # the run at t = 0 touches the segment start: dropped, not bridged
    assert zones.drop[0, 0] and np.abs(arrays["W"] @ chi - arrays["Y"])[ok].max() < 1e-9
    far = np.abs(qd) > 0.02
    assert np.array_equal(arrays["Y"][far], Y_true[far])


def test_long_runs_are_dropped_from_the_decimated_rows():
    qd = np.ones((3000, 3))
    qd[1000:1100, 1] = 0.0  # 100 samples at rest: too long to bridge with max 20
    zones = find_reversals(qd, 0.005, 20)
    assert zones.n_dropped == 100 and zones.n_bridged == 0
    keep = rows_clear(zones.drop, 10, 290, "fir")
    assert keep[:, 0].all() and keep[:, 2].all()
    assert (~keep[:, 1]).sum() == 18  # windows of 81 samples meeting 100 dropped samples


def test_chunk_size_does_not_change_the_result():
    model = SyntheticModel()
    recs = [synthetic_record(12, 0.0, seed=1, amplitude=0.1, f_max=4.0),
            synthetic_record(12, 1.983, seed=2, amplitude=0.1, f_max=4.0)]
    a = identify_records(recs, model=model, options=IdentifyOptions.of(chunk_samples=700))
    b = identify_records(recs, model=model, options=IdentifyOptions.of(chunk_samples=100_000))
    ga = np.array([g.value for g in a.drive_gains])
    gb = np.array([g.value for g in b.drive_gains])
    assert np.abs(ga / gb - 1).max() < 1e-10
