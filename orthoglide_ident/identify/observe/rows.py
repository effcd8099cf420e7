"""Observation: one record's segments to filtered, decimated rows of [W | W_payload, v_τ] (§6.1-3).

Segments (segments.py) → derivative filter at the half tick (filtering.py) → W of the robot
(``RobotModel.observation_block``) with the columns beside it (columns/layout.py) →
velocity-reversal bridging (reversals.py) → parallel decimation (decimation.py, or stream.py
block by block for the FIR filter, as the live path runs it).
Shared by the offline path (pipeline.py) and, through stream.py, the live one.
"""
from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from orthoglide_ident.identify.columns.current_lag import lag_instrument, without_instrument
from orthoglide_ident.identify.columns.drive_terms import screw_mask
from orthoglide_ident.identify.columns.layout import ColumnLayout, bound_to
from orthoglide_ident.identify.observe.decimation import decimate_chunked, decimated_count
from orthoglide_ident.identify.observe.equations import Observations
from orthoglide_ident.identify.observe.reversals import (
    anchor_samples,
    bridge,
    find_reversals,
    rows_clear,
    velocity_deadband,
)
from orthoglide_ident.identify.observe.sampling import (
    at_sampling,
    record_sampling,
    robot_file_sampling,
    sampled_shift_s,
)
from orthoglide_ident.identify.observe.stream import (
    DecimatedRows,
    SegmentStream,
    lag_rows,
)
from orthoglide_ident.identify.observe.time_base import choose_velocity, states_at_half_tick
from orthoglide_ident.identify.options import IdentifyOptions
from orthoglide_ident.identify.records.record import Record, record_payload
from orthoglide_ident.identify.records.segments import Segment, SegmentReport, split_record
from orthoglide_ident.model.robot import Payload, RobotModel

log = logging.getLogger("orthoglide_ident.identify")

__all__ = ["observe"]

# What the observation needs from the robot (model/robot.py): sizes, names, nominal gains, the
# IDIM block [W | W_payload]; the columns beside W are the layout's (columns/layout.py).
IdentificationModel = RobotModel


def observe(rec: Record, model: IdentificationModel, opts: IdentifyOptions,
            payload_mass: float, progress: Callable[..., None] | None = None, *,
            layout: ColumnLayout
            ) -> tuple[Observations, SegmentReport, dict[str, float]]:
    """Segments, derivative filtering, W and parallel decimation of one record (§6.1-3);
    ``progress(stage, done, total, unit)`` (None: silent) hears the samples done.

    ``model``: the robot; ``layout``: the columns beside its W (columns/layout.py). A loaded
    record's payload column is that of its payload's known part (``rec.payload``: frame, centre
    of mass and inertia per kg; eq. 33's W_kl generalised), its unknown parameters' columns W_ul
    beside W (payload_unknowns.py, Sect. 4.3): the robot bound by layout.bound_to."""
    times: dict[str, float] = {}
    payload = record_payload(rec, payload_mass, opts.input.payload_known)
    if payload is not None:
        model = bound_to(model, layout, payload)
    t0 = time.perf_counter()
    step = _mean_step_guess(rec.stamps_q_ns)
    opts = opts.at_rate(1.0 / step)
    segments, rep = split_record(  # the shortest segment in samples at this record's step
        rec.stamps_q_ns, rec.names_q, rec.q, rec.stamps_v_ns, rec.names_v, rec.v_tau,
        min_samples=opts.observe.min_segment_samples(step), nonfinite=opts.input.nonfinite,
        source=rec.source, joint_names=model.joint_names, qd=rec.qd)
    opts = opts.at_rate(1.0 / rep.period_s)
    rep.current_sampling, rep.current_sampling_why = record_sampling(
        rec.current_sampling, opts.input.current_sampling, robot_file_sampling(model))
    opts = at_sampling(opts, rep.current_sampling)  # sampled: the states at the stamps
    rep.current_shift_ms = 1e3 * sampled_shift_s(opts)  # (+ its loop's half tick, if known)
    rep.filter_cutoff_hz, rep.decimation = opts.observe.filter_cutoff_hz, opts.observe.decimation
    rep.decimation_cutoff_hz = opts.observe.decimation_cutoff_hz
    times["segments"] = time.perf_counter() - t0
    log.info("%s: %s", rec.source, rep.summary())
    log.info("%s: %s; %s", rec.source, rep.time_base(), opts.observe.describe_rates())
    segments, rep.velocity = choose_velocity(segments, opts, rep.period_s, rec.source)
    log.info("%s: joint velocity %s", rec.source, rep.velocity)
    log.info("%s: current %s (%s)", rec.source, rep.current_sampling, rep.current_sampling_why)
    decimate = _segments_fir if opts.observe.decimation_filter == "fir" else _segments_iir
    what = f"observing {Path(rec.source).name}"
    tell = None if progress is None else (lambda done, total: progress(what, done, total,
                                                                       "samples"))
    cols = _Columns(model, layout, payload)
    rows, n_bridged, n_unbridged = decimate(segments, cols, opts, rep, times, tell)
    n_b = layout.n_columns
    # views of the (n_b + 2, n_j, r) rows: W (n_j, r, n_b), v_tau and w_m (n_j, r), no copies
    obs = Observations(rec.source, str(rec.condition), payload_mass,
                       rows.X[:n_b].transpose(1, 2, 0), rows.X[n_b + 1], rows.X[n_b],
                       t=rows.t, keep=rows.keep, q=rows.q, qd=rows.qd,
                       row_period_s=opts.observe.decimation * rep.period_s,
                       decimation=opts.observe.decimation, screws=screw_mask(model))
    rep.n_reversal_bridged = n_bridged
    rep.n_reversal_unbridged = n_unbridged
    log.info("%s: W built and decimated by %d: %s equations per joint (%.2f s); velocity "
             "reversals: %d joint samples bridged, %d in runs too long to bridge", rec.source,
             opts.observe.decimation, "/".join(str(x) for x in obs.rows_per_joint()),
             times["regressor+decimation"], n_bridged, n_unbridged)
    return obs, rep, times


def _mean_step_guess(stamps_ns: np.ndarray) -> float:
    """Mean step of a record's stamps (s) before its gaps are known: the median step where it
    is at least the mean over the record (a steady clock with gaps), else the mean (uneven)."""
    st = np.asarray(stamps_ns, np.int64)
    if st.shape[0] < 3:
        return 1e-3
    dt = np.diff(st)
    med = float(np.median(dt)) * 1e-9
    if med <= 0:
        return 1e-3
    ok = dt[(dt > 0.5 * med * 1e9) & (dt < 1.5 * med * 1e9)]
    return float(np.mean(ok)) * 1e-9 if ok.size else med


@dataclass(frozen=True)
class _Columns:
    """What one record's rows are built from: the robot bound to its payload, the layout, the
    payload (whose unknown kinds fill W_ul)."""

    robot: IdentificationModel
    layout: ColumnLayout
    payload: Payload | None


def _segments_fir(segments: list[Segment], cols: _Columns, opts: IdentifyOptions,
                  rep: SegmentReport, times: dict[str, float],
                  tell: Callable[..., None] | None = None) -> tuple[DecimatedRows, int, int]:
    """Every segment through a :class:`SegmentStream`, pushed ``chunk_samples`` at a time
    (``tell(done, total)``: the samples done, None: silent).

    The decimated rows of each segment are known in advance: they are written once into their
    final ``(n_b + 2, n_j, r)`` array (no lists of parts, no concatenated copies).
    """
    n_b, n_j = cols.layout.n_columns, cols.robot.n_joints
    T = rep.period_s
    trim = int(round(opts.observe.edge_trim_s / T))
    zoh = 1 if opts.observe.zoh_shift else 0
    counts = [decimated_count(len(seg) - zoh - 2 * trim, opts.observe.decimation)
              for seg in segments]
    with_keep = opts.observe.velocity_deadband_mps > 0
    r = sum(counts)
    out = DecimatedRows(np.empty((n_b + 2, n_j, r)), np.empty((n_j, r), bool) if with_keep
                        else None, np.empty(r), np.empty((r, n_j)), np.empty((r, n_j)))
    t_start = int(segments[0].stamps_ns[0])
    n_bridged = n_unbridged = 0
    r0, done, total = 0, 0, sum(len(seg) for seg in segments)
    for seg in segments:
        stream = SegmentStream(cols.robot, cols.layout, opts, T, t_start, cols.payload)
        t0 = time.perf_counter()
        states = states_at_half_tick(seg.q, _currents(seg, cols.layout, rep, t_start), T,
                                     opts.observe.filter_cutoff_hz, opts.observe.filter_order, trim,
                                     opts.observe.zoh_shift, opts.observe.filter_currents,
                                     seg.stamps_ns, seg.qd, sampled_shift_s(opts))
        stamps = seg.stamps_ns[trim:trim + states[0].shape[0]]
        times["filtering"] = times.get("filtering", 0.0) + time.perf_counter() - t0
        for a in range(0, stamps.shape[0], opts.observe.chunk_samples):
            b = a + opts.observe.chunk_samples
            r0 = out.write(r0, stream.push_states(stamps[a:b], *(x[a:b] for x in states)))
            if tell is not None:
                tell(done + min(b, stamps.shape[0]), total)
        r0 = out.write(r0, stream.finish())
        done += len(seg)
        n_bridged += stream.n_bridged
        n_unbridged += stream.n_unbridged
        for k, v in stream.times.items():
            times[k] = times.get(k, 0.0) + v
    assert r0 == out.r, (r0, out.r)
    times["regressor+decimation"] = times.pop("regressor", 0.0) + times.pop("decimation", 0.0)
    return out, n_bridged, n_unbridged


def _currents(seg: Segment, layout: ColumnLayout, rep: SegmentReport,
              t_start: int) -> np.ndarray:
    """The segment's v_τ (m, n_j), with the lag instrument beside it (m, 2 n_j) when the layout
    has lag columns: zero when the segment does not repeat a periodic trajectory (counted in
    ``rep``; identify_records then leaves the lag out). ``t_start``: the record's first stamp."""
    if layout.lag_column is None:
        return seg.v_tau
    if rep.steps is not None and rep.steps.uneven:  # a period is a number of ticks: none here
        log.info("segment at %.1f s of the record: uneven steps, no lag instrument",
                 (seg.stamps_ns[0] - t_start) * 1e-9)
        rep.n_not_repeating += 1
        return without_instrument(seg.v_tau)
    z = lag_instrument(seg.q, seg.v_tau, rep.period_s)
    if z is None:
        log.info("segment at %.1f s of the record does not repeat a trajectory (no lag "
                 "instrument)", (seg.stamps_ns[0] - t_start) * 1e-9)
        rep.n_not_repeating += 1
        return without_instrument(seg.v_tau)
    return np.hstack([seg.v_tau, z])


def _segments_iir(segments: list[Segment], cols: _Columns, opts: IdentifyOptions,
                  rep: SegmentReport, times: dict[str, float],
                  tell: Callable[..., None] | None = None) -> tuple[DecimatedRows, int, int]:
    """MATLAB-like Chebyshev decimation (cheby1): whole segments, W produced in chunks
    (``tell(done, total)``: the samples of the segments done, None: silent).

    The IIR depends on the whole segment, so this path (offline only) keeps the chunked
    producer of decimation.decimate_chunked; bridges are applied chunk by chunk.
    """
    T = rep.period_s
    trim = int(round(opts.observe.edge_trim_s / T))
    n_d = opts.observe.decimation
    parts: dict[str, list[np.ndarray]] = {"X": [], "t": [], "keep": [], "q": [], "qd": []}
    times["filtering"] = times["regressor+decimation"] = 0.0
    n_bridged = n_unbridged = 0
    t_start = int(segments[0].stamps_ns[0])
    total = sum(len(seg) for seg in segments)
    for k, seg in enumerate(segments):
        t1 = time.perf_counter()
        qh, qdh, qddh, v = states_at_half_tick(seg.q, _currents(seg, cols.layout, rep, t_start), T,
                                               opts.observe.filter_cutoff_hz,
                                               opts.observe.filter_order, trim,
                                               opts.observe.zoh_shift,
                                               opts.observe.filter_currents, seg.stamps_ns, seg.qd,
                                               sampled_shift_s(opts))
        ts = (seg.stamps_ns[trim:trim + qh.shape[0]] - t_start) * 1e-9
        ts = ts + (0.5 * T if opts.observe.zoh_shift else sampled_shift_s(opts))
        t2 = time.perf_counter()
        times["filtering"] += t2 - t1
        zones = None
        if opts.observe.velocity_deadband_mps > 0:
            zones = find_reversals(qdh, velocity_deadband(cols.robot,
                                                          opts.observe.velocity_deadband_mps),
                                   max(1, int(round(opts.observe.reversal_max_bridge_s / T))),
                                   int(round(opts.observe.reversal_margin_s / T)))
            zones.anchor = anchor_samples(T)
            n_bridged += zones.n_bridged
            n_unbridged += zones.n_dropped

        def producer(a: int, b: int) -> dict[str, np.ndarray]:
            # margin so that every run overlapping [a, b) has both clean neighbours
            pad = 0 if zones is None else zones.margin_needed
            a2, b2 = max(0, a - pad), min(qh.shape[0], b + pad)
            m = b2 - a2
            blk = np.empty((cols.layout.n_columns + 1, cols.robot.n_joints, m))
            cols.layout.observation_block(cols.robot, qh[a2:b2], qdh[a2:b2], qddh[a2:b2], blk,
                                          cols.payload)
            v_tau = lag_rows(cols.layout, blk, v[a2:b2])
            out = {"X": np.concatenate([blk, v_tau.T[None]]).transpose(2, 1, 0)}
            if zones is not None:
                bridge(zones, a2, out)
            return {k: x[a - a2:b - a2] for k, x in out.items()}

        dec = decimate_chunked(qh.shape[0], n_d, producer, opts.observe.chunk_samples, "cheby1")
        parts["X"].append(dec["X"].transpose(2, 1, 0))
        r = dec["X"].shape[0]
        parts["t"].append(ts[0::n_d][:r])
        parts["q"].append(qh[0::n_d][:r])
        parts["qd"].append(qdh[0::n_d][:r])
        if zones is not None:
            parts["keep"].append(rows_clear(zones.drop, n_d, r, "cheby1").T)
        times["regressor+decimation"] += time.perf_counter() - t2
        if tell is not None:
            tell(sum(len(x) for x in segments[:k + 1]), total)
    keep = np.concatenate(parts["keep"], axis=1) if parts["keep"] else None
    return (DecimatedRows(np.concatenate(parts["X"], axis=2), keep, np.concatenate(parts["t"]),
                          np.concatenate(parts["q"]), np.concatenate(parts["qd"])),
            n_bridged, n_unbridged)
