"""Derivative filtering, half-sample shift and parallel decimation (filtering.py, decimation.py)."""
from __future__ import annotations

import numpy as np
import pytest

from orthoglide_ident.identify.observe.decimation import (
    decimate,
    decimate_chunked,
    decimate_fir,
    fir_output_range,
    fir_taps,
)
from orthoglide_ident.identify.observe.filtering import derivative_filter, half_tick
from orthoglide_ident.identify.observe.time_base import states_at_half_tick

T = 1e-3


def _sines(t):
    w = 2 * np.pi * np.array([0.7, 1.9, 3.1])
    a = np.array([0.05, 0.02, 0.01])
    s, c = np.sin(w * t[:, None]), np.cos(w * t[:, None])
    return a * s, a * w * c, -a * w**2 * s


def test_derivative_filter_on_smooth_motion():
    t = np.arange(10_000) * T
    q, qd, qdd = _sines(t)
    qf, qdf, qddf = derivative_filter(q, T, cutoff_hz=25.0)
    core = slice(300, -300)
    assert np.abs(qf - q)[core].max() < 1e-9
    assert np.abs(qdf - qd)[core].max() < 2e-6 * np.abs(qd).max()
    assert np.abs(qddf - qdd)[core].max() < 2e-5 * np.abs(qdd).max()


def test_half_tick_interpolates_forward_by_half_a_sample():
    t = np.arange(2000) * T
    q, _, _ = _sines(t)
    mid, _, _ = _sines(t[:-1] + T / 2)
    assert np.abs(half_tick(q) - mid)[1:-1].max() < 1e-10
    qh, qdh, qddh, v = states_at_half_tick(q, np.ones_like(q), T, trim=100)
    assert qh.shape == v.shape == (2000 - 1 - 200, 3)


def test_filter_currents_puts_v_tau_through_the_filter_of_q():
    # parallel filtering: a current with the same samples as q comes out as q̂ (same filter, same
    # instants), 150 Hz content is taken out of both, and the default options ask for it
    from orthoglide_ident.identify import IdentifyOptions

    t = np.arange(4000) * T
    q = _sines(t)[0] + 1e-4 * np.sin(2 * np.pi * 150.0 * t)[:, None]
    qh, _, _, v = states_at_half_tick(q, q, T, 100.0, 4, trim=200, zoh_shift=False,
                                      filter_currents=True)
    assert np.abs(v - qh).max() < 1e-15
    assert np.abs(v - _sines(t)[0][200:-200]).max() < 5e-6  # the 150 Hz part: 1e-4 -> ~3e-6
    raw = states_at_half_tick(q, q, T, 100.0, 4, trim=200, zoh_shift=False)[3]
    assert np.array_equal(raw, q[200:-200])
    assert IdentifyOptions().observe.filter_currents


def test_fir_is_zero_phase_unit_gain_and_chunks_exactly():
    taps = fir_taps(10)
    assert taps.sum() == pytest.approx(1.0) and np.allclose(taps, taps[::-1])
    t = np.arange(20_000) * T
    x = np.sin(2 * np.pi * 1.0 * t)[:, None]
    y = decimate_fir(x, 10)
    first, r = fir_output_range(20_000, 10)
    assert y.shape == (r, 1)
    assert np.abs(y[:, 0] - x[first::10, 0][:r]).max() < 1e-3  # no delay, ~unit gain at 1 Hz
    rng = np.random.default_rng(1)
    X = rng.standard_normal((30_001, 3, 5)).cumsum(axis=0)
    whole = decimate_fir(X, 10)
    chunked = decimate_chunked(X.shape[0], 10, lambda a, b: {"X": X[a:b]}, chunk=1000)["X"]
    assert chunked.shape == whole.shape
    assert np.abs(chunked - whole).max() <= 1e-12 * np.abs(whole).max()


def test_cheby1_chunks_match_whole_segment():
    rng = np.random.default_rng(2)
    X = rng.standard_normal((40_000, 2)).cumsum(axis=0)
    whole = decimate(X, 10)
    chunked = decimate_chunked(X.shape[0], 10, lambda a, b: {"X": X[a:b]}, chunk=4096,
                               method="cheby1")["X"]
    assert np.abs(chunked - whole).max() < 1e-9 * np.abs(whole).max()


@pytest.mark.parametrize("method", ["fir", "cheby1"])
def test_parallel_decimation_keeps_w_chi_equal_y(method):
    rng = np.random.default_rng(3)
    n, nb = 25_000, 6
    W = rng.standard_normal((n, 3, nb)).cumsum(axis=0)
    chi = rng.standard_normal(nb)
    Y = W @ chi
    d = decimate_chunked(n, 10, lambda a, b: {"W": W[a:b], "Y": Y[a:b]}, chunk=3000, method=method)
    assert np.abs(d["W"] @ chi - d["Y"]).max() < 1e-10 * np.abs(d["Y"]).max()
