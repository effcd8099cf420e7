"""W's smooth columns at the decimated rows (``regressor_at: rows``, identify/smooth_rows.py)
against every column at every sample (``samples``, eqs. 19-20 as written), on the simulated UR5.

Tolerances: the answers within 0.1 σ (the paper's eq. 39 σ, the smaller one) is the bar of the
approximation (issue 35); the bridges' part on the smooth columns is exact, so built from the
sample-rate columns it gives the sample-rate path's rows to round-off (1e-12); block by block
(live) and whole segments (offline) give the same rows to the filtering's windowing (1e-9).
"""
from __future__ import annotations

import numpy as np
import pytest

from orthoglide_ident.identify import stream as stream_mod
from orthoglide_ident.identify.decimation import fir_decimate_last, fir_taps
from orthoglide_ident.identify.drive_terms import observation_model
from orthoglide_ident.identify.filtering import states_at_half_tick
from orthoglide_ident.identify.observe import observe
from orthoglide_ident.identify.options import IdentifyOptions
from orthoglide_ident.identify.payload_unknowns import with_payload_unknowns
from orthoglide_ident.identify.pipeline import identify_records
from orthoglide_ident.identify.stream import SegmentStream
from orthoglide_ident.model.robots import load_robot
from orthoglide_sim.arm_record import simulate_arm
from test_on_arm import as_record

SECONDS = 8.0  # per record: the answer's σ is then ~4x the 2 x 60 s bags'


@pytest.fixture(scope="module")
def ur5():
    runs = [simulate_arm(SECONDS, payload=None, trajectory="exciting1", seed=0),
            simulate_arm(SECONDS, payload="2.0", trajectory="exciting2", seed=1)]
    return load_robot("ur5"), [as_record(r, k) for r, k in zip(runs, ("unloaded", "2kg"))]


def _worst_sigma(a, b) -> float:
    return max(abs(x.value - y.value) / (abs(x.value) * x.rel_std_paper)
               for x, y in zip(a, b))


def test_rows_give_the_answer_of_every_sample_within_a_tenth_of_sigma(ur5):
    model, recs = ur5
    res = {m: identify_records(recs, options=IdentifyOptions(regressor_at=m), model=model)
           for m in ("samples", "rows")}
    assert _worst_sigma(res["samples"].drive_gains, res["rows"].drive_gains) < 0.1
    assert _worst_sigma(res["samples"].parameters, res["rows"].parameters) < 0.1
    assert res["rows"].to_json()["diagnostics"]["options"]["regressor_at"] == "rows"
    assert res["samples"].to_json()["diagnostics"]["options"]["regressor_at"] == "samples"


def _full_rate_smooth(self, Xr, a, b, r):
    """_smooth_at_rows with the smooth columns built at every sample and filtered."""
    n_j, x = self.n_j, self._qs[a:b]
    W = np.empty((self.n_b + 1, n_j, b - a))
    stream_mod.model_block(self.model, x[:, :n_j], x[:, n_j:2 * n_j], x[:, 2 * n_j:], W)
    out = np.empty((self.n_b + 2, n_j, r))
    out[:self.n_b + 1] = fir_decimate_last(W, self.n_d, r)
    self._corr.add_to(out, self._i_out, self.n_d, fir_taps(self.n_d))
    out[self.rough] = Xr[:-1]
    out[self.n_b + 1] = Xr[-1]
    return out


def test_the_bridges_on_the_smooth_columns_are_those_of_the_sample_rate_path(ur5, monkeypatch):
    model, recs = ur5
    rec = recs[1]
    m = observation_model(with_payload_unknowns(model), 0.0, True)
    old, rep, _ = observe(rec, m, IdentifyOptions(regressor_at="samples"), 2.0)
    assert rep.n_reversal_bridged > 100  # the record has bridges to check
    monkeypatch.setattr(SegmentStream, "_smooth_at_rows", _full_rate_smooth)
    new, _, _ = observe(rec, m, IdentifyOptions(regressor_at="rows"), 2.0)
    scale = np.abs(old.W).max(axis=(0, 1)) + 1e-300
    assert np.max(np.abs(old.W - new.W) / scale) < 1e-12
    np.testing.assert_allclose(new.v_tau, old.v_tau, rtol=0, atol=1e-12)


def test_blocks_give_the_rows_of_the_whole_segment(ur5):
    """Live (raw ticks in blocks) = offline (the segment's states at once), rows mode."""
    model, recs = ur5
    rec = recs[0]
    opts = IdentifyOptions(regressor_at="rows").at_rate(1000.0)
    T, n_b = 1e-3, len(model.names)
    t0 = int(rec.stamps_q_ns[0])
    whole = SegmentStream(model, opts, T, t0, n_b)
    assert whole.rough is not None  # the rows path is the one checked
    trim = int(round(opts.edge_trim_s / T))
    states = states_at_half_tick(rec.q, rec.v_tau, T, opts.filter_cutoff_hz, opts.filter_order,
                                 trim, opts.zoh_shift, opts.filter_currents)
    stamps = rec.stamps_q_ns[trim:trim + states[0].shape[0]]
    parts = [whole.push_states(stamps, *states), whole.finish()]
    live = SegmentStream(model, opts, T, t0, n_b)
    for a in range(0, rec.q.shape[0], 700):
        parts.append(live.push(rec.stamps_q_ns[a:a + 700], rec.q[a:a + 700],
                               rec.v_tau[a:a + 700]))
    parts.append(live.finish())
    X_whole = np.concatenate([p.X for p in parts[:2]], axis=2)
    X_live = np.concatenate([p.X for p in parts[2:]], axis=2)
    assert X_whole.shape == X_live.shape and X_whole.shape[2] > 100
    scale = np.abs(X_whole).max(axis=(1, 2), keepdims=True) + 1e-300  # per column
    assert np.max(np.abs(X_whole - X_live) / scale) < 1e-9
