"""The identification pipeline end to end: bags → segments → filtering → W, decimation → TLS/WLS.

``identify(bag_paths, ...)`` reads the bags; ``identify_records(records, ...)`` does the rest on
in-memory records (the simulator's, or tests'), so every step can run without a bag on disk.
Progress of the long steps goes to the ``orthoglide_ident.identify`` logger (stderr in the CLI).

Bad input raises one of the product's errors with a one-line reason: mismatched joint names or
NaN (DataError), contradicting tags (IdentificationError), only unloaded bags for TLS
(IdentificationError), non-exciting trajectories (ExcitationError), unreadable bags (BagError).
"""
from __future__ import annotations

import dataclasses
import logging
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterable, Iterator, Sequence

import numpy as np

from orthoglide_ident.errors import IdentificationError
from orthoglide_ident.identify.current_lag import lag_instrument, without_instrument
from orthoglide_ident.identify.decimation import decimate_chunked, decimated_count
from orthoglide_ident.identify.drive_terms import observation_model, screw_mask
from orthoglide_ident.identify.factors import RecordFactors
from orthoglide_ident.identify.filtering import states_at_half_tick
from orthoglide_ident.identify.observations import Observations
from orthoglide_ident.identify.options import IdentifyOptions
from orthoglide_ident.identify.payload_unknowns import (check_one_payload, unknowns_of,
                                                        used_columns, with_payload_unknowns)
from orthoglide_ident.identify.reversals import bridge, find_reversals, rows_clear
from orthoglide_ident.identify.segments import Segment, SegmentReport, split_record
from orthoglide_ident.identify.solve import Solved, solve
from orthoglide_ident.identify.stream import DecimatedRows, SegmentStream, lag_rows, model_block
from orthoglide_ident.identify.validation import ValidationResult, cross_validate
from orthoglide_ident.model.geometry import JOINT_NAMES as ORTHOGLIDE_JOINTS
from orthoglide_ident.model.robot import Payload, RobotModel
from orthoglide_ident.results import IdentificationResult

log = logging.getLogger("orthoglide_ident.identify")

__all__ = ["Record", "identify", "identify_records", "observe", "read_record",
           "resolve_payload"]

# What the pipeline needs from the robot (model/robot.py): sizes, names, nominal gains, the
# IDIM block [W | W_payload]; also a DriveTermsModel wrapping one (drive_terms.py).
IdentificationModel = RobotModel


@dataclass
class Record:
    """One recording in memory: positions and currents with their stamps and the bag's tag.

    ``q (N_q, len(names_q))`` m or rad, ``v_tau (N_v, len(names_v))`` A, joints by name (any
    order, extra ones ignored); ``payload``: where and how the payload is mounted (frame, centre
    of mass, inertia: the tag's ``orthoglide.payload_*`` keys; None: a point mass at the
    robot's payload frame)."""

    source: str
    stamps_q_ns: np.ndarray
    names_q: Sequence[str]
    q: np.ndarray
    stamps_v_ns: np.ndarray
    names_v: Sequence[str]
    v_tau: np.ndarray
    condition: str | None  # "loaded" | "unloaded"
    payload_mass: float  # kg, tagged (0 unloaded)
    warnings: list[str] = field(default_factory=list)
    payload: Payload | None = None
    sources: str = ""  # where q and the current were recorded (bags.BagSources.describe)

    @classmethod
    def from_arrays(cls, source: str, stamps_ns: np.ndarray, q: np.ndarray, v_tau: np.ndarray,
                    condition: str, payload_mass: float,
                    joint_names: Sequence[str] = ORTHOGLIDE_JOINTS,
                    payload: Payload | None = None) -> "Record":
        """A record whose positions and currents share stamps and ``joint_names`` (default the
        Orthoglide's)."""
        names = tuple(joint_names)
        return cls(source, stamps_ns, names, q, stamps_ns, names, v_tau, condition,
                   float(payload_mass), payload=payload)


def read_record(path: str | Path, model: RobotModel | None = None,
                opts: IdentifyOptions | None = None) -> Record:
    """Read a tagged bag (directory or lone .mcap) into a :class:`Record`: the robot's joints
    (``model``, default the Orthoglide) by name from whichever topics hold them (bags.sources:
    a DynamicJointState interface, the JointState effort or the CurrentReference), the payload's
    frame, centre of mass and inertia from the tag. With ``effort_unit: torque`` an effort that is
    a torque or force is turned into a current with the nominal gains. BagError if unusable."""
    from orthoglide_ident import bags

    model = model if model is not None else default_model()
    opts = opts or IdentifyOptions()
    data = bags.read_bag(path, joints=model.joint_names,
                         interface=opts.current_interface or None)
    tags, current = data.tags, data.current
    v_tau = current.current
    if opts.effort_unit == "torque":
        v_tau = model.effort_as_current(current.names, v_tau)
    return Record(
        source=str(path),
        stamps_q_ns=data.positions.stamps_ns, names_q=tuple(data.positions.names),
        q=data.positions.position,
        stamps_v_ns=current.stamps_ns, names_v=tuple(current.names), v_tau=v_tau,
        condition=None if tags is None else tags.condition,
        payload_mass=0.0 if tags is None else float(tags.payload_mass),
        warnings=list(data.warnings), payload=_tagged_payload(tags),
        sources=data.sources.describe(),
    )


def _tagged_payload(tags) -> Payload | None:
    """The payload of a loaded bag's tag: mass, frame, CoM and inertia as given, and what of
    them is known (orthoglide.payload_known, else what the tag gives: paper Sect. 4.3)."""
    if tags is None or tags.condition != "loaded":
        return None
    return Payload(float(tags.payload_mass), tags.payload_frame or "",
                   tuple(tags.payload_com or (0.0, 0.0, 0.0)),
                   tuple(tags.payload_inertia or (0.0,) * 6), tags.knowledge)


def record_payload(rec: Record, payload_mass: float, known: str = "") -> Payload | None:
    """A loaded record's payload and what is known of it: ``known`` (payload_known option)
    overrides the tag's; an in-memory record without one carries a mass known alone at the
    robot's payload frame. IdentificationError when the knowledge asks for what is not given."""
    if rec.condition != "loaded":
        return None
    return payload_knowledge(rec.source, rec.payload, payload_mass, known)


def payload_knowledge(source: str, payload: Payload | None, payload_mass: float,
                      known: str = "") -> Payload:
    """A loaded record's payload (None: its mass known alone, at the robot's payload frame) with
    the knowledge ``known`` asks for ("" : as it is); IdentificationError when it asks for what
    the record does not give."""
    p = payload or Payload(payload_mass, known="mass")
    if not known or known == p.known:
        return p
    if known in ("com", "all") and p.known in ("mass", "point") and not any(p.com):
        raise IdentificationError(
            f"{source}: payload_known {known} needs the payload's centre of mass in the tag "
            "(orthoglide.payload_com)")
    if known == "all" and p.known != "all":
        raise IdentificationError(
            f"{source}: payload_known all needs the payload's centre of mass and inertia in "
            "the tag (orthoglide.payload_com, orthoglide.payload_inertia)")
    if known == "point" and p.known == "all" and any(p.inertia):
        raise IdentificationError(
            f"{source} is tagged with the payload's inertia: payload_known point would drop "
            "it (use all, or com to identify the inertia)")
    return dataclasses.replace(p, known=known)


def default_model() -> RobotModel:
    """The robot when none is given: the Orthoglide's closed form (model/robots.py)."""
    from orthoglide_ident.model.robots import load_robot

    return load_robot(None)


def resolve_payload(rec: Record, payload_mass: float | None, tol: float) -> float:
    """Known payload mass of a record (kg); IdentificationError on a missing or wrong tag."""
    if rec.condition not in ("loaded", "unloaded"):
        raise IdentificationError(
            f"{rec.source}: no orthoglide.condition tag (loaded|unloaded); record it with the "
            "recorder or tag it"
        )
    if rec.condition == "unloaded":
        return 0.0
    tagged = float(rec.payload_mass)
    if payload_mass is not None:
        if tagged > 0 and abs(tagged - payload_mass) > tol:
            raise IdentificationError(
                f"{rec.source} is tagged with a payload of {tagged:g} kg but --payload-mass says "
                f"{payload_mass:g} kg; check which payload was mounted"
            )
        return float(payload_mass)
    if not tagged > 0:
        raise IdentificationError(
            f"{rec.source} is loaded without a payload mass: give --payload-mass")
    return tagged


def observe(rec: Record, model: IdentificationModel, opts: IdentifyOptions,
            payload_mass: float) -> tuple[Observations, SegmentReport, dict[str, float]]:
    """Segments, derivative filtering, W and parallel decimation of one record (§6.1-3).

    A loaded record's payload column is that of its payload's known part (``rec.payload``:
    frame, centre of mass and inertia per kg; eq. 33's W_kl generalised), its unknown parameters'
    columns W_ul beside W (payload_unknowns.py, Sect. 4.3), through ``model.with_payload``."""
    times: dict[str, float] = {}
    payload = record_payload(rec, payload_mass, opts.payload_known)
    if payload is not None:
        model = with_known_payload(model, payload)
    t0 = time.perf_counter()
    period_guess = 1e-3
    if len(rec.stamps_q_ns) > 2:
        period_guess = float(np.median(np.diff(np.asarray(rec.stamps_q_ns)))) * 1e-9 or 1e-3
    segments, rep = split_record(
        rec.stamps_q_ns, rec.names_q, rec.q, rec.stamps_v_ns, rec.names_v, rec.v_tau,
        min_samples=opts.min_segment_samples(period_guess), nonfinite=opts.nonfinite,
        source=rec.source, joint_names=model.joint_names)
    times["segments"] = time.perf_counter() - t0
    log.info("%s: %s", rec.source, rep.summary())
    decimate = _segments_fir if opts.decimation_filter == "fir" else _segments_iir
    rows, n_bridged, n_unbridged = decimate(segments, model, opts, rep, times)
    n_b = len(model.names)
    # views of the (n_b + 2, n_j, r) rows: W (n_j, r, n_b), v_tau and w_m (n_j, r), no copies
    obs = Observations(rec.source, str(rec.condition), payload_mass,
                       rows.X[:n_b].transpose(1, 2, 0), rows.X[n_b + 1], rows.X[n_b],
                       t=rows.t, keep=rows.keep, q=rows.q, qd=rows.qd,
                       row_period_s=opts.decimation * rep.period_s, decimation=opts.decimation,
                       screws=screw_mask(model))
    rep.n_reversal_bridged = n_bridged
    rep.n_reversal_unbridged = n_unbridged
    log.info("%s: W built and decimated by %d: %s equations per joint (%.2f s); velocity "
             "reversals: %d joint samples bridged, %d in runs too long to bridge", rec.source,
             opts.decimation, "/".join(str(x) for x in obs.rows_per_joint()),
             times["regressor+decimation"], n_bridged, n_unbridged)
    return obs, rep, times


def with_known_payload(model, payload: Payload):
    """``model`` bound to a loaded record's payload: the whole payload for a model with the
    unknown payload columns (payload_unknowns.py), its known part for one without (the
    Orthoglide's: only the mass acts, whatever else is known)."""
    if unknowns_of(model) is not None:
        return model.with_payload(payload)
    return model.with_payload(payload.known_part())


def _segments_fir(segments: list[Segment], model: IdentificationModel, opts: IdentifyOptions,
                  rep: SegmentReport, times: dict[str, float]) -> tuple[DecimatedRows, int, int]:
    """Every segment through a :class:`SegmentStream`, pushed ``chunk_samples`` at a time.

    The decimated rows of each segment are known in advance: they are written once into their
    final ``(n_b + 2, n_j, r)`` array (no lists of parts, no concatenated copies).
    """
    n_b, n_j = len(model.names), model.n_joints
    T = rep.period_s
    trim = int(round(opts.edge_trim_s / T))
    zoh = 1 if opts.zoh_shift else 0
    counts = [decimated_count(len(seg) - zoh - 2 * trim, opts.decimation) for seg in segments]
    with_keep = opts.velocity_deadband_mps > 0
    r = sum(counts)
    out = DecimatedRows(np.empty((n_b + 2, n_j, r)), np.empty((n_j, r), bool) if with_keep
                        else None, np.empty(r), np.empty((r, n_j)), np.empty((r, n_j)))
    t_start = int(segments[0].stamps_ns[0])
    n_bridged = n_unbridged = 0
    r0 = 0
    for seg in segments:
        stream = SegmentStream(model, opts, T, t_start, n_b)
        t0 = time.perf_counter()
        states = states_at_half_tick(seg.q, _currents(seg, model, rep, t_start), T,
                                     opts.filter_cutoff_hz, opts.filter_order, trim,
                                     opts.zoh_shift, opts.filter_currents)
        stamps = seg.stamps_ns[trim:trim + states[0].shape[0]]
        times["filtering"] = times.get("filtering", 0.0) + time.perf_counter() - t0
        for a in range(0, stamps.shape[0], opts.chunk_samples):
            b = a + opts.chunk_samples
            r0 = out.write(r0, stream.push_states(stamps[a:b], *(x[a:b] for x in states)))
        r0 = out.write(r0, stream.finish())
        n_bridged += stream.n_bridged
        n_unbridged += stream.n_unbridged
        for k, v in stream.times.items():
            times[k] = times.get(k, 0.0) + v
    assert r0 == out.r, (r0, out.r)
    times["regressor+decimation"] = times.pop("regressor", 0.0) + times.pop("decimation", 0.0)
    return out, n_bridged, n_unbridged


def _currents(seg: Segment, model: IdentificationModel, rep: SegmentReport,
              t_start: int) -> np.ndarray:
    """The segment's v_τ (m, n_j), with the lag instrument beside it (m, 2 n_j) when the model has
    lag columns: zero when the segment does not repeat a periodic trajectory (counted in
    ``rep``; identify_records then leaves the lag out). ``t_start``: the record's first stamp."""
    if getattr(model, "lag_column", None) is None:
        return seg.v_tau
    z = lag_instrument(seg.q, seg.v_tau, rep.period_s)
    if z is None:
        log.info("segment at %.1f s of the record does not repeat a trajectory (no lag "
                 "instrument)", (seg.stamps_ns[0] - t_start) * 1e-9)
        rep.n_not_repeating += 1
        return without_instrument(seg.v_tau)
    return np.hstack([seg.v_tau, z])


def _segments_iir(segments: list[Segment], model: IdentificationModel, opts: IdentifyOptions,
                  rep: SegmentReport, times: dict[str, float]) -> tuple[DecimatedRows, int, int]:
    """MATLAB-like Chebyshev decimation (cheby1): whole segments, W produced in chunks.

    The IIR depends on the whole segment, so this path (offline only) keeps the chunked
    producer of decimation.decimate_chunked; bridges are applied chunk by chunk.
    """
    T = rep.period_s
    trim = int(round(opts.edge_trim_s / T))
    n_d = opts.decimation
    parts: dict[str, list[np.ndarray]] = {"X": [], "t": [], "keep": [], "q": [], "qd": []}
    times["filtering"] = times["regressor+decimation"] = 0.0
    n_bridged = n_unbridged = 0
    t_start = int(segments[0].stamps_ns[0])
    for seg in segments:
        t1 = time.perf_counter()
        qh, qdh, qddh, v = states_at_half_tick(seg.q, _currents(seg, model, rep, t_start), T,
                                               opts.filter_cutoff_hz,
                                               opts.filter_order, trim, opts.zoh_shift,
                                               opts.filter_currents)
        ts = (seg.stamps_ns[trim:trim + qh.shape[0]] - t_start) * 1e-9
        if opts.zoh_shift:
            ts = ts + 0.5 * T
        t2 = time.perf_counter()
        times["filtering"] += t2 - t1
        zones = None
        if opts.velocity_deadband_mps > 0:
            zones = find_reversals(qdh, opts.velocity_deadband_mps,
                                   max(1, int(round(opts.reversal_max_bridge_s / T))),
                                   int(round(opts.reversal_margin_s / T)))
            n_bridged += zones.n_bridged
            n_unbridged += zones.n_dropped

        def producer(a: int, b: int) -> dict[str, np.ndarray]:
            # margin so that every run overlapping [a, b) has both clean neighbours
            pad = 0 if zones is None else zones.margin_needed
            a2, b2 = max(0, a - pad), min(qh.shape[0], b + pad)
            m = b2 - a2
            blk = np.empty((len(model.names) + 1, model.n_joints, m))
            model_block(model, qh[a2:b2], qdh[a2:b2], qddh[a2:b2], blk)
            v_tau = lag_rows(model, blk, v[a2:b2])
            out = {"X": np.concatenate([blk, v_tau.T[None]]).transpose(2, 1, 0)}
            if zones is not None:
                bridge(zones, a2, out)
            return {k: x[a - a2:b - a2] for k, x in out.items()}

        dec = decimate_chunked(qh.shape[0], n_d, producer, opts.chunk_samples, "cheby1")
        parts["X"].append(dec["X"].transpose(2, 1, 0))
        r = dec["X"].shape[0]
        parts["t"].append(ts[0::n_d][:r])
        parts["q"].append(qh[0::n_d][:r])
        parts["qd"].append(qdh[0::n_d][:r])
        if zones is not None:
            parts["keep"].append(rows_clear(zones.drop, n_d, r, "cheby1").T)
        times["regressor+decimation"] += time.perf_counter() - t2
    keep = np.concatenate(parts["keep"], axis=1) if parts["keep"] else None
    return (DecimatedRows(np.concatenate(parts["X"], axis=2), keep, np.concatenate(parts["t"]),
                          np.concatenate(parts["q"]), np.concatenate(parts["qd"])),
            n_bridged, n_unbridged)


def _check_request(opts: IdentifyOptions, method: str, payload_mass: float | None) -> None:
    opts.validate()
    if method not in ("tls", "wls"):
        raise IdentificationError(f"unknown method {method!r}: use tls or wls")
    if payload_mass is not None and not (np.isfinite(payload_mass) and payload_mass > 0):
        raise IdentificationError(
            f"--payload-mass must be a positive mass in kg, not {payload_mass}")


def _observe_all(records: Iterable[Record], model: IdentificationModel, opts: IdentifyOptions,
                 payload_mass: float | None, add_timings: Callable[[dict[str, float]], None],
                 partial: list[tuple[str, Payload]] | None = None
                 ) -> tuple[list[Observations], list[dict[str, Any]], list[str], list[str]]:
    """Each record to its observation rows (one record's raw samples in memory at a time):
    the rows, the per-bag reports, the warnings and the bag names; the loaded records'
    payloads appended to ``partial`` (one payload whose parameters are partly unknown)."""
    if isinstance(records, Sequence):  # in memory: check every tag before the long steps
        for r in records:
            resolve_payload(r, payload_mass, opts.payload_tolerance_kg)
    blocks: list[Observations] = []
    reports: list[dict[str, Any]] = []
    warnings: list[str] = []
    bag_names: list[str] = []
    partial = [] if partial is None else partial
    for rec in records:
        m = resolve_payload(rec, payload_mass, opts.payload_tolerance_kg)
        p = record_payload(rec, m, opts.payload_known)
        if p is not None:
            partial.append((rec.source, p))
            check_one_payload(partial)
        bag_names.append(rec.source)
        warnings.extend(rec.warnings)
        obs, rep, ts = observe(rec, model, opts, m)
        add_timings(ts)
        blocks.append(obs)
        reports.append(bag_report(rep, rec.source, rec.condition, m, obs.rows_per_joint(),
                                  rec.sources))
        del rec  # a lazily read bag's raw samples can go now
    if not blocks:
        raise IdentificationError("no bag given")
    return blocks, reports, warnings, bag_names


def identify_records(
    records: Iterable[Record],
    payload_mass: float | None = None,
    method: str = "tls",
    gains: Sequence[float] | None = None,
    essential: bool = False,
    options: IdentifyOptions | None = None,
    model: IdentificationModel | None = None,
    validation: Iterable[Record] = (),
) -> IdentificationResult:
    """Identify from records; see :func:`identify`.

    ``records`` may be a generator (``identify`` reads bags lazily, one at a time, so that only
    one record's raw samples are in memory at once).
    """
    opts = options or IdentifyOptions()
    _check_request(opts, method, payload_mass)
    timings: dict[str, float] = {}
    t_all = time.perf_counter()
    if model is None:
        model = default_model()
        timings["model"] = time.perf_counter() - t_all
    model = observation_model(with_payload_unknowns(model), opts.screw_lead_m,
                              opts.lag_model == "auto")

    def add(ts: dict[str, float]) -> None:
        for k, v in ts.items():
            timings[k] = timings.get(k, 0.0) + v

    payloads: list[tuple[str, Payload]] = []
    blocks, reports, warnings, bag_names = _observe_all(records, model, opts, payload_mass, add,
                                                        payloads)
    model, blocks = _payload_or_not(model, blocks, opts, payloads)
    model, blocks = _lag_or_paper(model, blocks, reports, opts)
    t_solve = time.perf_counter()
    factors = [RecordFactors.from_observations(b) for b in blocks]
    solved = solve(factors, model, opts, method, gains, essential, bag_names)
    add(solved.timings)
    timings["solve"] = time.perf_counter() - t_solve - timings.get("essential", 0.0)
    result = solved.result

    t_v = time.perf_counter()
    vals = _validate(validation, solved, model, opts, payload_mass)
    if vals:
        timings["validation"] = time.perf_counter() - t_v
    for v in vals:
        warnings.extend(v.warnings)
    result.validation = [v.to_json(model.joint_names) for v in vals]
    result.validation_details = vals
    timings["total"] = time.perf_counter() - t_all
    finish_result(result, solved, reports, warnings, opts, timings)
    result.observations = blocks
    result.observations_chi = solved.chi
    return result


def _payload_or_not(model: IdentificationModel, blocks: list[Observations],
                    opts: IdentifyOptions, payloads: list[tuple[str, Payload]]
                    ) -> tuple[IdentificationModel, list[Observations]]:
    """The model and rows with only the unknown payload columns some loaded record fills (a
    payload known by its mass, Sect. 4.3), named at that payload's frame: with every payload
    known, the rows are the robot's own (zero columns would make W_tot rank deficient)."""
    pu = unknowns_of(model)
    if pu is None:
        return model, blocks
    start, n = pu.payload_slice.start, len(pu.columns)
    keep = used_columns([b.W for b in blocks], start, n)
    frames = {p.frame for _, p in payloads if p.unknown}
    reduced = pu.keeping(keep)
    if keep and frames:
        reduced = reduced.at_frame(frames.pop())
    if len(keep) == n and reduced is pu:
        return model, blocks
    drop = [start + k for k in range(n) if k not in keep]
    if drop:
        blocks = [dataclasses.replace(b, W=np.delete(b.W, drop, axis=2)) for b in blocks]
    lag = getattr(model, "lag_column", None) is not None
    return observation_model(reduced, opts.screw_lead_m, lag), blocks


def _lag_or_paper(model: IdentificationModel, blocks: list[Observations],
                  reports: list[dict[str, Any]], opts: IdentifyOptions
                  ) -> tuple[IdentificationModel, list[Observations]]:
    """The model and rows with the lag columns only when every segment used had its instrument:
    rows with a zero lag column would still hold the lag's force and bias τ and the gains
    (a third of the rows without it halved τ on the simulator). Otherwise the paper's model."""
    col = getattr(model, "lag_column", None)
    if col is None:
        return model, blocks
    lacking = [f"{r['bag']} ({r['n_not_repeating']} of {r['n_segments']} segments)"
               for r in reports if r.get("n_not_repeating")]
    if not lacking:
        return model, blocks
    log.info("the current-loop lag is not modelled: %s do not repeat a periodic trajectory "
             "(lag_model: auto needs every segment to)", ", ".join(lacking))
    cols = np.r_[col:col + model.n_joints]
    out = [dataclasses.replace(b, W=np.delete(b.W, cols, axis=2)) for b in blocks]
    return observation_model(model, opts.screw_lead_m, False), out


def _validate(records: Iterable[Record], solved: Solved, model: IdentificationModel,
              opts: IdentifyOptions, payload_mass: float | None) -> list[ValidationResult]:
    """Cross-validation (Fig. 5) of the solution on records not used to identify it."""
    result, out = solved.result, []
    for rec in records:
        m = resolve_payload(rec, payload_mass, opts.payload_tolerance_kg)
        if rec.condition == "loaded" and result.method == "wls" and result.payloads:
            m = next((p.value for p in result.payloads if p.tagged == m), m)
        obs, _, _ = observe(rec, model, opts, m)
        out.append(cross_validate(obs, solved.chi, solved.g_tau, m,
                                  np.asarray(result.residual_rms), joint_names=model.joint_names))
        if result.consistency is not None:  # the consistent model forward-simulated on it
            from orthoglide_ident.identify.direct_dynamics import validate

            result.consistency.direct_dynamics.append(validate(
                rec, getattr(model, "base", model), result.consistency.answer.chi_st,
                solved.g_tau, m, opts))
    return out


def bag_report(rep: SegmentReport, source: str, condition: str | None, payload_mass: float,
               equations: list[int], sources: str = "") -> dict[str, Any]:
    """One record's entry of ``diagnostics["bags"]``: pairing, gaps, reversals, equations, and
    which topics and fields carried q and the current."""
    d = dict(vars(rep))
    d.update(bag=source, condition=condition, payload_mass=payload_mass,
             equations_per_joint=equations)
    if sources:
        d["sources"] = sources
    return d


def finish_result(result: IdentificationResult, solved: Solved, reports: list[dict[str, Any]],
                  warnings: list[str], opts: IdentifyOptions, timings: dict[str, float]) -> None:
    """Warnings and diagnostics of a solved identification (the JSON's ``diagnostics``)."""
    if result.condition_number > opts.warn_condition:
        warnings.append(f"condition number of the scaled observation matrix is "
                        f"{result.condition_number:.3g}: some base parameters are poorly excited "
                        "(see their %σ; --essential keeps the well-identified ones)")
    result.warnings = list(warnings) + [w for w in result.warnings if w not in warnings]
    solver_diagnostics = dict(result.diagnostics)  # e.g. "uncertainty", set by the solve
    result.diagnostics = {
        "samples_used": int(sum(r["n_used"] for r in reports)),
        "samples_dropped": int(sum(r["n_paired"] - r["n_used"] + r["n_unpaired_joint_states"]
                                   + r["n_unpaired_current_reference"] for r in reports)),
        "segments": int(sum(r["n_segments"] for r in reports)),
        "rows": int(sum(sum(r["equations_per_joint"]) for r in reports)),
        "solver": solved.solver,
        "decimation": opts.decimation,
        "bags": reports,
        "timings_s": {k: round(v, 4) for k, v in timings.items()},
        "options": dict(vars(opts)),
    }
    for key, value in solver_diagnostics.items():
        result.diagnostics.setdefault(key, value)


def identify(
    bag_paths: Sequence[str | Path],
    payload_mass: float | None = None,
    method: str = "tls",
    gains: Sequence[float] | None = None,
    essential: bool = False,
    options: IdentifyOptions | None = None,
    model: IdentificationModel | None = None,
    validation_bags: Sequence[str | Path] = (),
) -> IdentificationResult:
    """Identify drive gains and base parameters from tagged bags (docs/architecture.md).

    ``model``: the robot (model/robots.load_robot; default the Orthoglide). ``payload_mass``
    (kg) overrides/checks the loaded bags' tags; ``method`` "tls" (gains identified, payload
    known) or "wls" (``gains`` given in N/A or N·m/A, default the robot's nominal ones; payload
    mass of loaded bags estimated); ``essential`` adds the essential-parameter reduction
    (Sect. 5.2). ``validation_bags`` are cross-validated, not used for identification.
    """
    if not bag_paths:
        raise IdentificationError("no bag given")
    t_read = [0.0]
    model = model if model is not None else default_model()
    opts = options or IdentifyOptions()

    def lazily(paths: Sequence[str | Path]) -> Iterator[Record]:
        for p in paths:
            log.info("reading %s", p)
            t0 = time.perf_counter()
            rec = read_record(p, model, opts)
            log.info("%s: %s", p, rec.sources)
            t_read[0] += time.perf_counter() - t0
            yield rec

    res = identify_records(lazily(bag_paths), payload_mass, method, gains, essential, opts,
                           model, lazily(validation_bags))
    # reading happens inside identify_records' loop: its total already includes it
    res.diagnostics["timings_s"]["read"] = round(t_read[0], 4)
    return res
