"""Online identification (identify/live.py): equal to the offline pipeline, says what is wrong."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from live_helpers import feed, rel_diff, rel_sigma_diff
from simulated import simulated_pair

from orthoglide_ident.errors import ExcitationError, IdentificationError
from orthoglide_ident.identify import (
    IdentifyOptions,
    LiveIdentification,
    Record,
    identify_records,
    read_record,
)
from orthoglide_ident.model.registry import load_robot

ORTHOGLIDE = load_robot("orthoglide")  # the robot these records are of

BAGS = Path(__file__).resolve().parents[3] / "bags"
# live = offline to 1e-6 holds for the same equations: the paper's drive model here; with the
# current-loop lag (lag_model: auto, the default) the live rows' instrument is the mean over the
# previous periods, the offline one over all the others (test_live_lag_* below)
PAPER_DRIVE = IdentifyOptions.of(lag_model="off")


@pytest.fixture(scope="module")
def bag_records() -> list[Record]:
    """The sample bags: 10 s unloaded, 10 s loaded (1.983 kg), simulated plant at 1 kHz."""
    return [read_record(BAGS / "unloaded", model=ORTHOGLIDE), read_record(BAGS / "loaded",
                                                                          model=ORTHOGLIDE)]


@pytest.fixture(scope="module")
def offline(bag_records):
    return identify_records(bag_records, options=PAPER_DRIVE, model=ORTHOGLIDE)








@pytest.mark.parametrize("batches, offset", [((1,), 0), ((7,), 3), ((100,), 5),
                                             ((1000,), 40), ((1, 7, 100, 1000), 4)])
def test_live_result_equals_offline_whatever_the_batches(bag_records, offline, batches, offset):
    live = LiveIdentification(PAPER_DRIVE, model=ORTHOGLIDE)
    warnings = []
    for i, rec in enumerate(bag_records):
        warnings += feed(live, rec, batches, offset, seed=i)
    assert warnings == []
    res = live.result()
    dg, dp = rel_diff(offline, res)
    assert dg < 1e-6 and dp < 1e-6
    assert res.bags == offline.bags and res.payload_mass.value == 1.983
    for d_off, d_live in zip(offline.record_reports, res.record_reports):
        for key in ("n_paired", "n_missing_ticks", "n_segments", "n_used", "period_s",
                    "n_reversal_bridged", "n_reversal_unbridged", "equations_per_joint"):
            assert getattr(d_live, key) == getattr(d_off, key), key
    # memory is bounded: one (n_b + 2)-square R factor per joint and condition
    assert all(R.shape == (live.n_b + 2, live.n_b + 2)
               for f in live._factors.values() for R in f.R)
    # the honest σ (residual moments folded with the factors) and the paper's are the same too
    assert max(rel_sigma_diff(offline, res)) < 1e-6
    assert res.uncertainty.blocks == offline.uncertainty.blocks


def test_wls_and_essential_equal_offline(bag_records, offline):
    live = LiveIdentification(PAPER_DRIVE, model=ORTHOGLIDE)
    for rec in bag_records:
        feed(live, rec, (250,))
    g = [2170.0, 2100.0, 2070.0]
    assert max(rel_diff(identify_records(bag_records, method="wls", gains=g, options=PAPER_DRIVE,
                                         model=ORTHOGLIDE),
                        live.result("wls", gains=g))) < 1e-6
    with pytest.raises(IdentificationError, match="1.983 kg but 1.136 kg"):
        live.result(payload_mass=1.136)
    assert live.result(payload_mass=1.9832).payload_mass.value == 1.9832
    ess_off = identify_records(bag_records, essential=True, options=PAPER_DRIVE,
                               model=ORTHOGLIDE).essential
    ess_live = live.result(essential=True).essential
    assert [p.name for p in ess_live.parameters] == [p.name for p in ess_off.parameters]
    assert max(rel_diff(ess_off, ess_live)) < 1e-6
    assert max(rel_sigma_diff(ess_off, ess_live)) < 1e-6
    s_off, s_live = ess_off.reduction.steps, ess_live.reduction.steps
    assert [(s.name, s.accepted) for s in s_live] == [(s.name, s.accepted) for s in s_off]
    assert np.allclose([s.shift for s in s_live], [s.shift for s in s_off], atol=1e-8)


def _with_gap_and_nan(rec: Record, a: int, b: int, k_nan: int) -> Record:
    keep = np.ones(len(rec.stamps_q_ns), bool)
    keep[a:b] = False
    v = rec.v_tau.copy()
    v[k_nan, 1] = np.nan
    return Record(rec.source, rec.stamps_q_ns[keep], rec.names_q, rec.q[keep], rec.stamps_v_ns,
                  rec.names_v, v, rec.condition, rec.payload_mass)


def test_gaps_and_nan_split_the_record_like_offline_drop(bag_records):
    recs = [_with_gap_and_nan(bag_records[0], 4000, 4025, 7000),
            _with_gap_and_nan(bag_records[1], 5000, 5001, 2500)]
    opts = IdentifyOptions.of(nonfinite="drop", lag_model="off")
    off = identify_records(recs, options=opts, model=ORTHOGLIDE)
    live = LiveIdentification(opts, model=ORTHOGLIDE)
    warnings = [w for i, rec in enumerate(recs) for w in feed(live, rec, (1, 50, 333), 7, i)]
    res = live.result()
    assert max(rel_diff(off, res)) < 1e-6
    assert any("25 tick(s) lost" in w and "joint_states" in w for w in warnings)
    assert sum("NaN" in w for w in warnings) == 2
    d = res.record_reports[0]
    assert d.n_missing_ticks == off.record_reports[0].n_missing_ticks == 26
    assert d.n_segments == off.record_reports[0].n_segments == 3


def test_status_says_what_is_missing_and_result_raises_with_the_reason(bag_records):
    live = LiveIdentification(PAPER_DRIVE, model=ORTHOGLIDE)
    assert live.estimate().status.startswith("no data")
    unloaded, loaded = bag_records
    live.start_recording(unloaded.source, "unloaded")
    half = 5000
    live.add_joint_states(unloaded.stamps_q_ns[:half], unloaded.names_q, unloaded.q[:half])
    live.add_current_reference(unloaded.stamps_v_ns[:half], unloaded.names_v, unloaded.v_tau[:half])
    est = live.estimate()  # folded while recording, ~1 s blocks, lag under 2 s
    assert est.status.startswith("unloaded only: record with the payload")
    assert est.recording == "unloaded" and 2.0 < est.seconds_unloaded and est.lag_s < 2.0
    live.add_joint_states(unloaded.stamps_q_ns[half:], unloaded.names_q, unloaded.q[half:])
    live.add_current_reference(unloaded.stamps_v_ns[half:], unloaded.names_v, unloaded.v_tau[half:])
    live.stop_recording()
    with pytest.raises(IdentificationError, match="loaded"):
        live.result()
    feed(live, loaded)
    est = live.estimate()
    assert est.ok and est.status.startswith("gains known to") and est.lag_s == 0.0
    fields = est.message_fields(["a warning"])
    assert fields["enough_data"] == est.enough_data and len(fields["drive_gains"]) == 3
    assert fields["warnings"] == ["a warning"] and fields["lag"] == 0.0
    assert np.allclose(est.gains, [2170, 2100, 2070], rtol=0.01)
    assert 9 < est.seconds_loaded < 10 and est.singular_ratio < 0.5

    only_loaded = LiveIdentification(PAPER_DRIVE, model=ORTHOGLIDE)
    feed(only_loaded, loaded)
    assert only_loaded.estimate().status == "loaded only: record without the payload"
    with pytest.raises(IdentificationError, match="unloaded"):
        only_loaded.result()


def test_a_joint_that_does_not_move_is_said(bag_records):
    live = LiveIdentification(model=ORTHOGLIDE)
    warnings = []
    for rec in bag_records:
        still = Record(**{**vars(rec), "q": rec.q.copy()})
        still.q[:, 2] = still.q[0, 2]  # q13 never moves
        warnings += feed(live, still, (100,))
    assert any(w.startswith("q13 has stayed below the velocity dead band") for w in warnings)
    assert live.estimate().status.startswith("excitation too weak on q13")
    with pytest.raises(ExcitationError, match="q13"):
        live.result()


def test_bad_samples_warn_and_the_rest_is_used(bag_records, offline):
    live = LiveIdentification(IdentifyOptions.of(current_limit_a=0.5, lag_model="off"),
                              model=ORTHOGLIDE)
    unloaded, loaded = bag_records
    feed(live, unloaded)
    live.start_recording(loaded.source, "loaded", loaded.payload_mass)
    w = live.add_joint_states(loaded.stamps_q_ns[:10], ["x", "y", "z"], loaded.q[:10])
    assert len(w) == 1 and "joint names" in w[0] and "dropped" in w[0]
    assert live.add_joint_states(loaded.stamps_q_ns[:3], ["x", "y", "z"], loaded.q[:3]) == []
    w = live.add_joint_states(loaded.stamps_q_ns[10:12], loaded.names_q, np.zeros((2, 2)))
    assert "shape" in w[0]
    names = ("q13", "q11", "q12")  # another order is fine: reordered as offline
    live.add_joint_states(loaded.stamps_q_ns[12:], names, loaded.q[12:, [2, 0, 1]])
    live.add_current_reference(loaded.stamps_v_ns, loaded.names_v, loaded.v_tau)
    live.stop_recording()
    drained = live.drain_warnings()
    assert any("q11 at" in x and "beyond 0.45 A" in x for x in drained)  # 90 % of 0.5 A
    assert live.drain_warnings() == []
    res = live.result()  # the first 12 ticks of the loaded record are missing: nearly offline
    assert rel_diff(offline, res)[0] < 1e-3
    assert res.record_reports[1].n_unpaired_current_reference == 12



@pytest.fixture(scope="module")
def sim_records() -> list[Record]:
    """12 s unloaded and 12 s loaded (1.983 kg) from the simulated plant (its own trajectories)."""
    return simulated_pair(12.0, (1, 2), "sim", controller="pid")


def test_simulated_records_with_a_real_gap(sim_records):
    unloaded, loaded = sim_records
    keep = np.ones(len(loaded.stamps_q_ns), bool)
    keep[6000:6200] = False  # 0.2 s lost on both topics in the middle of the loaded record
    gappy = Record.from_arrays(
        loaded.source,
        loaded.stamps_q_ns[keep],
        loaded.q[keep],
        loaded.v_tau[keep],
        "loaded",
        loaded.payload_mass,
        joint_names=ORTHOGLIDE.joint_names,
    )
    off = identify_records([unloaded, gappy], options=PAPER_DRIVE, model=ORTHOGLIDE)
    live = LiveIdentification(PAPER_DRIVE, model=ORTHOGLIDE)
    warnings = feed(live, unloaded, (10,), 2) + feed(live, gappy, (10, 37), 3, seed=1)
    assert sum("200 tick(s) lost" in w for w in warnings) == 2  # one per topic
    res = live.result()
    assert max(rel_diff(off, res)) < 1e-6
    assert res.record_reports[1].n_segments == off.record_reports[1].n_segments == 2
    est = live.estimate()
    assert est.ok and np.allclose(est.gains, [2170.0, 2100.0, 2070.0], rtol=0.01)


def test_gentle_trajectories_are_said_not_returned_as_gains():
    from synthetic import SyntheticModel, synthetic_record

    model = SyntheticModel()
    live = LiveIdentification(model=model)
    for payload, seed in ((0.0, 1), (1.983, 2)):
        feed(live, synthetic_record(20.0, payload, seed=seed, amplitude=0.01, f_max=0.5), (50,))
    est = live.estimate()
    assert not est.ok and est.status.startswith("excitation too weak")
    with pytest.raises(ExcitationError):
        live.result()


def test_a_silent_topic_and_a_recording_too_short_are_said(bag_records):
    live = LiveIdentification(model=ORTHOGLIDE)
    rec = bag_records[0]
    live.start_recording("silent", "unloaded")
    w = live.add_current_reference(rec.stamps_v_ns[:10], rec.names_v, rec.v_tau[:10])
    w += live.add_joint_states(rec.stamps_q_ns[:3000], rec.names_q, rec.q[:3000])
    assert any(x.startswith("current_reference: nothing new for") for x in w)
    w = live.stop_recording()
    assert any("nothing used from this recording" in x for x in w)
    assert live.estimate().status.startswith("no data")


@pytest.fixture(scope="module")
def realistic_records():
    """15 s unloaded + 15 s loaded of the simulated realistic drive (screw friction ripple at a
    10 mm lead, current-loop lag, Stribeck, 2 mA)."""
    return simulated_pair(15.0, (5, 6), "real", profile="realistic")


def _live_result(recs, opts=None):
    live = LiveIdentification(opts, model=ORTHOGLIDE)
    for i, rec in enumerate(recs):
        feed(live, rec, (333,), 2, seed=i)
    return live, live.result()


def test_realistic_drive_ripple_found_and_modelled_alike_live_and_offline(realistic_records):
    """The realistic drive's ripple is found in the residual and modelled, with the same result
    live as offline."""
    recs = realistic_records
    off = identify_records(recs, options=PAPER_DRIVE, model=ORTHOGLIDE)
    assert "q12" in {r.joint for r in off.ripple}
    for r in off.ripple:
        assert abs(r.wavelength_m - 0.01) < 0.0005 and r.kind.startswith("friction")
    live, res = _live_result(recs, PAPER_DRIVE)
    assert max(rel_diff(off, res)) < 1e-6 and max(rel_sigma_diff(off, res)) < 1e-6
    assert [r.joint for r in res.ripple] == [r.joint for r in off.ripple]
    assert np.allclose([r.amplitude_n for r in res.ripple],
                       [r.amplitude_n for r in off.ripple], rtol=1e-6)
    g = np.array([x.value for x in res.drive_gains])
    s = np.array([x.rel_std for x in res.drive_gains]) * g
    assert np.all(np.abs(g - [2170.0, 2100.0, 2070.0]) < 3 * s)
    est = live.estimate()  # the estimate watched while recording is the result's solve
    assert np.allclose(est.gains, g, rtol=1e-12) and np.allclose(est.gains_rel_std, s / g)


def test_screw_ripple_at_the_given_lead_alike_live_and_offline(realistic_records):
    """With the screws' lead given (screw_lead_m), every joint's ripple columns are built at
    1 kHz beside W, live as offline: the same gains, σ and ripples; the amplitudes are the
    plant's (1.5 % of fs_1i = 35.2, 41.7, 24.1 N in config/plant.yaml) within 3 of their σ
    (measured 0.8-1.7 σ here; noise-free, within 2 %: the plant turns the ripple with
    tanh(q̇/v_s), the model with sign(q̂̇))."""
    opts = IdentifyOptions.of(screw_lead_m=0.01, lag_model="off")
    off = identify_records(realistic_records, options=opts, model=ORTHOGLIDE)
    _, res = _live_result(realistic_records, opts)
    assert max(rel_diff(off, res)) < 1e-6 and max(rel_sigma_diff(off, res)) < 1e-6
    assert [r.joint for r in res.ripple] == ["q11", "q12", "q13"]
    a_off, a_live = ([r.amplitude_n for r in x.ripple] for x in (off, res))
    np.testing.assert_allclose(a_live, a_off, rtol=1e-6)
    sigma = np.array([r.amplitude_std_n for r in off.ripple])
    assert np.all(np.abs(a_off - 0.015 * np.array([35.2, 41.7, 24.1])) < 3 * sigma)


def _sigma_diff(off, res) -> tuple[float, float]:
    """Largest difference of two results' gains and parameters in the offline σ, and largest
    relative difference of their σ (absolute: a near-zero value has a huge relative σ)."""
    ea, eb = off.drive_gains + off.parameters, res.drive_gains + res.parameters
    sa = np.array([x.rel_std * abs(x.value) for x in ea])
    sb = np.array([y.rel_std * abs(y.value) for y in eb])
    d = np.array([y.value - x.value for x, y in zip(ea, eb)])
    return float(np.max(np.abs(d) / sa)), float(np.max(np.abs(sb / sa - 1)))


def test_live_lag_within_a_fraction_of_sigma_of_offline_whatever_the_batches(realistic_records):
    """lag_model: auto (the default), live: each segment's first ticks are held until the
    trajectory has repeated 4 times (6 s here; the status says so), then the lag columns get the
    mean of v̇_τ over the *previous* periods instead of all the others: τ found, and every gain
    and parameter within 0.25 σ of offline (measured: gains 0.03-0.05 σ, 0.0002 relative; 0.08 σ
    at most; σ within 1.6 %), the same whatever the batches."""
    unloaded = realistic_records[0]
    live = LiveIdentification(model=ORTHOGLIDE)
    live.start_recording(unloaded.source, "unloaded")
    assert live.estimate().status.startswith("collecting: the first equations come after")
    live.add_joint_states(unloaded.stamps_q_ns[:5000], unloaded.names_q, unloaded.q[:5000])
    live.add_current_reference(unloaded.stamps_v_ns[:5000], unloaded.names_v,
                               unloaded.v_tau[:5000])
    est = live.estimate()
    assert est.status.startswith("collecting: 5 s held until the trajectory has repeated 4 times")
    assert est.seconds_unloaded == 0.0 and est.lag_s > 4.5
    off = identify_records(realistic_records, model=ORTHOGLIDE)
    results = []
    for batches in ((333,), (1, 7, 100, 1000)):
        live = LiveIdentification(model=ORTHOGLIDE)
        assert not [w for i, r in enumerate(realistic_records)
                    for w in feed(live, r, batches, 2, seed=i)]
        results.append(live.result())
    res = results[0]
    assert rel_diff(results[1], res)[0] < 1e-9 and max(_sigma_diff(results[1], res)) < 1e-6
    in_sigma, sigma_ratio = _sigma_diff(off, res)
    assert in_sigma < 0.25 and sigma_ratio < 0.05, (in_sigma, sigma_ratio)
    tau = np.array([x.tau_ms for x in res.current_lag])
    sig = np.array([x.tau_std_ms for x in res.current_lag])
    assert np.all(np.abs(tau - 0.12) < 3 * sig), (tau, sig)  # config/plant.yaml: 0.12 ms
    assert np.all(np.abs(tau - [x.tau_ms for x in off.current_lag]) < 0.5 * sig)


def test_live_lag_left_out_when_a_segment_does_not_repeat(realistic_records):
    """A record shorter than 4 periods: the segment's held ticks come out at its end without an
    instrument, the user is told, and the identification is the paper's drive model's, as
    offline (pipeline._lag_or_paper) — also when an earlier recording had the instrument."""
    cut = [
        Record.from_arrays(
            r.source,
            r.stamps_q_ns[:5000],
            r.q[:5000],
            r.v_tau[:5000],
            r.condition,
            r.payload_mass,
            joint_names=ORTHOGLIDE.joint_names,
        )
        for r in realistic_records
    ]
    for recs in (cut, [realistic_records[0], cut[1]]):
        opts = IdentifyOptions.of(check_excitation=False)
        live = LiveIdentification(opts, model=ORTHOGLIDE)
        warnings = [w for i, r in enumerate(recs) for w in feed(live, r, (250,), 2, seed=i)]
        assert sum("does not repeat a periodic trajectory" in w for w in warnings) == 1
        res = live.result()
        paper = LiveIdentification(IdentifyOptions.of(check_excitation=False, lag_model="off"),
                                   model=ORTHOGLIDE)
        for i, r in enumerate(recs):
            feed(paper, r, (250,), 2, seed=i)
        bad = 0 if recs is cut else 1
        assert res.current_lag == [] and res.record_reports[bad].n_not_repeating == 1
        # round-off, through the per-joint noise scaling's fixed point on 5 s records (~1e-9)
        assert max(rel_diff(paper.result(), res)) < 1e-8
        off = identify_records(recs, options=IdentifyOptions.of(check_excitation=False,
                                                                lag_model="off"), model=ORTHOGLIDE)
        assert max(rel_diff(off, res)) < 1e-6
