"""Block-by-block processing of a segment (identify/stream.py, reversals.ReversalTracker)."""
from __future__ import annotations

import numpy as np
import pytest
from synthetic import SyntheticModel, synthetic_record

from orthoglide_ident.identify import IdentifyOptions
from orthoglide_ident.identify.columns.layout import plain_layout
from orthoglide_ident.identify.observe.decimation import fir_decimate_last, fir_taps
from orthoglide_ident.identify.observe.reversals import ReversalTracker, find_reversals
from orthoglide_ident.identify.observe.stream import SegmentStream
from orthoglide_ident.identify.observe.time_base import states_at_half_tick


def _velocities(rng: np.random.Generator, n: int) -> np.ndarray:
    t = np.arange(n) * 1e-3
    qd = np.stack([rng.uniform(0.01, 0.5) * np.sin(2 * np.pi * rng.uniform(0.5, 8) * t
                                                     + rng.uniform(0, 6)) for _ in range(3)], 1)
    qd[:, 0] += rng.normal(0, 0.01, n)  # dithering around the dead band: merged runs
    a, b = sorted(rng.integers(0, n, 2))
    qd[a:b, 1] = 0.0  # a pause: a run too long to bridge
    return qd


def test_tracker_decides_what_find_reversals_decides_whatever_the_blocks():
    rng = np.random.default_rng(0)
    for _ in range(150):
        n = int(rng.integers(50, 3000))
        qd = _velocities(rng, n)
        max_bridge, margin = int(rng.integers(1, 30)), int(rng.integers(0, 10))
        zones = find_reversals(qd, 0.02, max_bridge, margin)
        tr = ReversalTracker(0.02, max_bridge, margin, qd.shape[1])
        final = np.zeros(3, int)
        a = seen = 0
        while a < n:
            b = min(n, a + int(rng.integers(1, 200)))
            tr.update(qd[a:b])
            a = b
            # no bridge lands before what was said final, and what is final never moves back
            assert all(d.s >= final[d.j] for d in tr.decisions[seen:] if d.ok)
            seen = len(tr.decisions)
            for j in range(3):
                assert tr.final_upto(j) >= final[j]
                final[j] = tr.final_upto(j)
        tr.update(None, n)
        for j in range(3):
            ok = [(d.s, d.e) for d in tr.decisions if d.j == j and d.ok]
            assert ok == list(zip(zones.starts[j].tolist(), zones.ends[j].tolist()))
            drop = np.zeros(n, bool)
            for d in tr.decisions:
                if d.j == j and not d.ok:
                    drop[d.s:d.e] = True
            assert np.array_equal(drop, zones.drop[:, j])


def test_fir_decimate_last_is_the_direct_convolution_at_the_kept_samples():
    rng = np.random.default_rng(1)
    for n_d in (2, 7, 10):
        x = rng.standard_normal((4, 3, 1000))[:, :, 3:]  # a strided slice, like the buffer's
        taps = fir_taps(n_d)
        r = (x.shape[2] - taps.shape[0]) // n_d + 1
        y = fir_decimate_last(x, n_d, r)
        direct = np.stack([x[:, :, i * n_d:i * n_d + taps.shape[0]] @ taps for i in range(r)], -1)
        assert np.abs(y - direct).max() < 1e-14


@pytest.mark.parametrize("opts", [IdentifyOptions(), IdentifyOptions.of(edge_trim_s=0.02),
                                  IdentifyOptions.of(zoh_shift=False, decimation=5),
                                  IdentifyOptions.of(decimation=1, velocity_deadband_mps=0.0),
                                  IdentifyOptions.of(filter_currents=False)])
def test_raw_blocks_give_the_rows_of_the_whole_segment(opts):
    """Ticks pushed in random blocks (live) = the whole segment filtered at once (offline)."""
    opts = opts.at_rate(1e3)
    rec = synthetic_record(6.0, 0.0, seed=3, amplitude=0.1, f_max=4.0)
    model = SyntheticModel()
    T = 1e-3
    trim = int(round(opts.observe.edge_trim_s / T))
    whole = SegmentStream(model, plain_layout(model), opts, T, 0)
    states = states_at_half_tick(rec.q, rec.v_tau, T, opts.observe.filter_cutoff_hz,
                                 opts.observe.filter_order, trim,
                                 opts.observe.zoh_shift, opts.observe.filter_currents)
    stamps = rec.stamps_q_ns[trim:trim + states[0].shape[0]]
    ref = [whole.push_states(stamps, *states), whole.finish()]
    blocks = SegmentStream(model, plain_layout(model), opts, T, 0)
    rng = np.random.default_rng(4)
    got, a = [], 0
    while a < len(stamps) + 2 * trim + 1:
        b = a + int(rng.integers(1, 1500))
        got.append(blocks.push(rec.stamps_q_ns[a:b], rec.q[a:b], rec.v_tau[a:b]))
        a = b
    got.append(blocks.finish())
    X0 = np.concatenate([r.X for r in ref], axis=2)
    X1 = np.concatenate([r.X for r in got], axis=2)
    assert X0.shape == X1.shape and X0.shape[2] > 0
    scale = np.abs(X0).max(axis=2, keepdims=True) + 1e-300
    assert np.abs((X1 - X0) / scale).max() < 1e-9
    if opts.observe.velocity_deadband_mps > 0:
        assert np.array_equal(np.concatenate([r.keep for r in ref], 1),
                              np.concatenate([r.keep for r in got], 1))
        assert (blocks.n_bridged, blocks.n_unbridged) == (whole.n_bridged, whole.n_unbridged)
    assert np.allclose(np.concatenate([r.t for r in ref]), np.concatenate([r.t for r in got]))
