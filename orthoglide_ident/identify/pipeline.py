"""The identification pipeline end to end: bags → segments → filtering → W, decimation → TLS/WLS.

``identify(bag_paths, ...)`` reads the bags; ``identify_records(records, ...)`` does the rest on
in-memory records (the simulator's, or tests'), so every step can run without a bag on disk.
Progress of the long steps goes to the ``orthoglide_ident.identify`` logger (stderr in the CLI).

Bad input raises one of the product's errors with a one-line reason: mismatched joint names or
NaN (DataError), contradicting tags (IdentificationError), only unloaded bags for TLS
(IdentificationError), non-exciting trajectories (ExcitationError), unreadable bags (BagError).
"""
from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable, Iterator, Protocol, Sequence

import numpy as np

from orthoglide_ident.errors import ExcitationError, IdentificationError
from orthoglide_ident.identify.decimation import decimate_chunked, fir_output_range
from orthoglide_ident.identify.essential import EssentialResult, essential_parameters
from orthoglide_ident.identify.filtering import states_at_half_tick
from orthoglide_ident.identify.observations import Observations
from orthoglide_ident.identify.options import IdentifyOptions
from orthoglide_ident.identify.reversals import bridge, find_reversals, rows_clear
from orthoglide_ident.identify.segments import JOINT_NAMES, SegmentReport, split_record
from orthoglide_ident.identify.tls import (TLSProblem, TLSSolution, check_excitation,
                                           require_loaded_and_unloaded)
from orthoglide_ident.identify.validation import ValidationResult, cross_validate
from orthoglide_ident.identify.wls import WLSSolution, idim_wls
from orthoglide_ident.results import Estimate, IdentificationResult, PayloadMass

log = logging.getLogger("orthoglide_ident.identify")

G_TAU_MANUFACTURER = 637.0 * np.pi  # N/A, eq. (17), the paper's 2001


class IdentificationModel(Protocol):
    """What the pipeline needs from the model (``orthoglide_ident.model.base.base_model()``)."""

    names: Sequence[str]
    expressions: Sequence[str]

    def regressor(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        """W: (3 N, n_b), rows joint by joint."""

    def payload_mass_column(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        """W_kl of m_7: (3 N,)."""


@dataclass
class Record:
    """One recording in memory: both topics with their stamps and the bag's tag."""

    source: str
    stamps_q_ns: np.ndarray
    names_q: Sequence[str]
    q: np.ndarray  # (N, 3) m
    stamps_v_ns: np.ndarray
    names_v: Sequence[str]
    v_tau: np.ndarray  # (N, 3) A
    condition: str | None  # "loaded" | "unloaded"
    payload_mass: float  # kg, tagged (0 unloaded)
    warnings: list[str] = field(default_factory=list)

    @classmethod
    def from_arrays(cls, source: str, stamps_ns: np.ndarray, q: np.ndarray, v_tau: np.ndarray,
                    condition: str, payload_mass: float) -> "Record":
        """A record whose two topics share stamps and the joint names q11, q12, q13."""
        return cls(source, stamps_ns, JOINT_NAMES, q, stamps_ns, JOINT_NAMES, v_tau, condition,
                   float(payload_mass))


def read_record(path: str | Path) -> Record:
    """Read a tagged bag (directory or lone .mcap) into a :class:`Record`; BagError if unusable."""
    from orthoglide_ident import bags

    data = bags.read_bag(path)
    tags = data.tags
    return Record(
        source=str(path),
        stamps_q_ns=data.joint_states.stamps_ns, names_q=tuple(data.joint_states.names),
        q=data.joint_states.position,
        stamps_v_ns=data.current_reference.stamps_ns, names_v=tuple(data.current_reference.names),
        v_tau=data.current_reference.current,
        condition=None if tags is None else tags.condition,
        payload_mass=0.0 if tags is None else float(tags.payload_mass),
        warnings=list(data.warnings),
    )


def default_model() -> IdentificationModel:
    from orthoglide_ident.model.base import base_model

    return base_model()


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
    """Segments, derivative filtering, W in chunks and parallel decimation of one record."""
    times: dict[str, float] = {}
    t0 = time.perf_counter()
    period_guess = 1e-3
    if len(rec.stamps_q_ns) > 2:
        period_guess = float(np.median(np.diff(np.asarray(rec.stamps_q_ns)))) * 1e-9 or 1e-3
    segments, rep = split_record(
        rec.stamps_q_ns, rec.names_q, rec.q, rec.stamps_v_ns, rec.names_v, rec.v_tau,
        min_samples=opts.min_segment_samples(period_guess), nonfinite=opts.nonfinite,
        source=rec.source)
    times["segments"] = time.perf_counter() - t0
    log.info("%s: %s", rec.source, rep.summary())
    T = rep.period_s
    trim = int(round(opts.edge_trim_s / T))
    n_d = opts.decimation
    parts: dict[str, list[np.ndarray]] = {"v": [], "w_m": [], "t": [], "keep": []}
    times["filtering"] = 0.0
    times["regressor+decimation"] = 0.0
    n_bridged = n_unbridged = 0
    t_start = int(segments[0].stamps_ns[0])
    # decimated rows of each segment, known in advance: W is written once into its final
    # (3, r, n_b) array, chunk by chunk (no lists of parts, no concatenated copies)
    fir = opts.decimation_filter == "fir"
    counts = []
    for seg in segments:
        n_states = len(seg) - (1 if opts.zoh_shift else 0) - 2 * trim
        counts.append(fir_output_range(n_states, n_d)[1] if fir else -(-n_states // n_d))
    r_all = int(sum(counts))
    W_all = np.empty((3, r_all, len(model.names)))
    r0 = 0
    for iseg, seg in enumerate(segments):
        t1 = time.perf_counter()
        qh, qdh, qddh, v = states_at_half_tick(seg.q, seg.v_tau, T, opts.filter_cutoff_hz,
                                               opts.filter_order, trim, opts.zoh_shift)
        ts = (seg.stamps_ns[trim:trim + qh.shape[0]] - t_start) * 1e-9
        if opts.zoh_shift:
            ts = ts + 0.5 * T
        times["filtering"] += time.perf_counter() - t1
        t2 = time.perf_counter()

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
            q_, qd_, qdd_ = qh[a2:b2], qdh[a2:b2], qddh[a2:b2]
            m = b2 - a2
            if hasattr(model, "observation"):  # W and W_kl in one pass
                W, w_m = model.observation(q_, qd_, qdd_)
            else:
                W = model.regressor(q_, qd_, qdd_)
                w_m = model.payload_mass_column(q_, qd_, qdd_)
            n_b = W.shape[1]
            out = {"W": W.reshape(3, m, n_b).transpose(1, 0, 2), "v": v[a2:b2].copy(),
                   "w_m": w_m.reshape(3, m).T.copy()}
            if zones is not None:
                bridge(zones, a2, out)
            return {k: x[a - a2:b - a2] for k, x in out.items()}

        r_seg = counts[iseg]
        dec = decimate_chunked(qh.shape[0], n_d, producer, opts.chunk_samples,
                               opts.decimation_filter,
                               out={"W": W_all[:, r0:r0 + r_seg].transpose(1, 0, 2)})
        if not fir:
            W_all[:, r0:r0 + r_seg] = dec["W"].transpose(1, 0, 2)
        r0 += r_seg
        for k in ("v", "w_m"):
            parts[k].append(dec[k])
        first = fir_output_range(qh.shape[0], n_d)[0] if opts.decimation_filter == "fir" else 0
        r = dec["v"].shape[0]
        parts["t"].append(ts[first::n_d][:r])
        if zones is not None:
            parts["keep"].append(rows_clear(zones.drop, n_d, r, opts.decimation_filter))
        times["regressor+decimation"] += time.perf_counter() - t2
        if len(segments) > 1:
            log.debug("%s: segment %d/%d decimated", rec.source, iseg + 1, len(segments))
    v_d = np.concatenate(parts["v"], axis=0).T
    w_d = np.concatenate(parts["w_m"], axis=0).T
    keep = None
    if opts.velocity_deadband_mps > 0:
        keep = np.concatenate(parts["keep"], axis=0).T
    obs = Observations(rec.source, str(rec.condition), payload_mass, W_all,
                       np.ascontiguousarray(v_d), np.ascontiguousarray(w_d),
                       t=np.concatenate(parts["t"]), keep=keep)
    rep.n_reversal_bridged = n_bridged
    rep.n_reversal_unbridged = n_unbridged
    log.info("%s: W built and decimated by %d: %s equations per joint (%.2f s); velocity "
             "reversals: %d joint samples bridged, %d in runs too long to bridge", rec.source, n_d,
             "/".join(str(x) for x in obs.rows_per_joint()), times["regressor+decimation"],
             n_bridged, n_unbridged)
    return obs, rep, times


def _gains_estimates(g: np.ndarray, rel: np.ndarray | None) -> list[Estimate]:
    return [Estimate(j, float(g[i]), float(rel[i]) if rel is not None else 0.0)
            for i, j in enumerate(JOINT_NAMES)]


def _param_estimates(model: IdentificationModel, sol: TLSSolution | WLSSolution) -> list[Estimate]:
    idx = np.flatnonzero(sol.active)
    exprs = list(getattr(model, "expressions", [""] * len(model.names)))
    return [Estimate(str(model.names[k]), float(sol.chi[i]), float(sol.rel_std[i]),
                     str(exprs[k]) if k < len(exprs) else "")
            for i, k in enumerate(idx)]


def _tls_result(model, sol: TLSSolution, blocks, opts, bags: list[str]) -> IdentificationResult:
    n = sol.chi.shape[0]
    loaded = [b for b in blocks if b.loaded]
    payloads = []
    for m in sorted({b.payload_mass for b in loaded}):
        payloads.append(PayloadMass(m, opts.payload_mass_std_kg / m, True, m,
                                    [b.source for b in loaded if b.payload_mass == m]))
    return IdentificationResult(
        method="tls", joint_names=list(JOINT_NAMES),
        drive_gains=_gains_estimates(sol.g_tau, sol.rel_std[n:n + 3]), drive_gains_given=False,
        parameters=_param_estimates(model, sol), payload_mass=payloads[0] if payloads else None,
        payloads=payloads, condition_number=sol.condition_number,
        residual_rms=[float(x) for x in sol.residual_rms], bags=bags,
    )


def _wls_result(model, sol: WLSSolution, g_tau: np.ndarray, blocks, bags) -> IdentificationResult:
    n = sol.chi.shape[0]
    payloads = []
    for k, m_tag in enumerate(sol.payload_groups):
        payloads.append(PayloadMass(float(sol.payload_masses[k]), float(sol.rel_std[n + k]), False,
                                    m_tag, [b.source for b in blocks
                                            if b.loaded and abs(b.payload_mass - m_tag) < 1e-9]))
    return IdentificationResult(
        method="wls", joint_names=list(JOINT_NAMES), drive_gains=_gains_estimates(g_tau, None),
        drive_gains_given=True, parameters=_param_estimates(model, sol),
        payload_mass=payloads[0] if payloads else None, payloads=payloads,
        condition_number=sol.condition_number, residual_rms=[float(x) for x in sol.residual_rms],
        bags=bags,
    )


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
    opts.validate()
    if method not in ("tls", "wls"):
        raise IdentificationError(f"unknown method {method!r}: use tls or wls")
    if payload_mass is not None and not (np.isfinite(payload_mass) and payload_mass > 0):
        raise IdentificationError(
            f"--payload-mass must be a positive mass in kg, not {payload_mass}")
    timings: dict[str, float] = {}
    t_all = time.perf_counter()
    if model is None:
        model = default_model()
        timings["model"] = time.perf_counter() - t_all

    def add(ts: dict[str, float]) -> None:
        for k, v in ts.items():
            timings[k] = timings.get(k, 0.0) + v

    if isinstance(records, Sequence):  # in memory: check every tag before the long steps
        for r in records:
            resolve_payload(r, payload_mass, opts.payload_tolerance_kg)
    blocks: list[Observations] = []
    reports: list[dict[str, Any]] = []
    warnings: list[str] = []
    bag_names: list[str] = []
    for rec in records:
        m = resolve_payload(rec, payload_mass, opts.payload_tolerance_kg)
        bag_names.append(rec.source)
        warnings.extend(rec.warnings)
        obs, rep, ts = observe(rec, model, opts, m)
        add(ts)
        blocks.append(obs)
        d = dict(vars(rep))
        d.update(bag=rec.source, condition=rec.condition, payload_mass=m,
                 equations_per_joint=obs.rows_per_joint())
        reports.append(d)
        del rec  # a lazily read bag's raw samples can go now
    if not blocks:
        raise IdentificationError("no bag given")
    n_b = blocks[0].W.shape[2]
    for j, name in enumerate(JOINT_NAMES):
        rows = sum(b.rows_per_joint()[j] for b in blocks)
        total = sum(b.n_samples for b in blocks)
        if rows < max(50, 2 * n_b):
            raise ExcitationError(
                f"{name} moves slower than the velocity dead band "
                f"({opts.velocity_deadband_mps} m/s)"
                f" almost all the time: {rows} of {total} equations left; the trajectories are "
                "not exciting (or lower velocity_deadband_mps)")

    t_solve = time.perf_counter()
    ess_res: EssentialResult | None = None
    if method == "tls":
        require_loaded_and_unloaded(blocks, "IDIM-TLS")
        log.info("IDIM-TLS on %d equations × %d unknowns", sum(b.n_rows for b in blocks),
                 blocks[0].W.shape[2] + 4)
        problem = TLSProblem(blocks, opts.weighting, noisy_columns=opts.tls_noisy_columns)
        sol = problem.solve()
        if opts.check_excitation:
            check_excitation(sol, opts.limits(), list(model.names))
        timings["solve"] = time.perf_counter() - t_solve
        result = _tls_result(model, sol, blocks, opts, bag_names)
        solver_diag = {"tls_noisy_columns": opts.tls_noisy_columns,
                       "singular_ratio": sol.singular_ratio,
                       "smallest_singular_values": [float(x) for x in sol.singular_values[-3:]],
                       "joint_sigma": [float(x) for x in sol.joint_sigma],
                       "lambda": sol.lambda_scale}
        if essential:
            t_e = time.perf_counter()
            log.info("essential parameters (r_sigma = %g)", opts.r_sigma)
            ess_res = essential_parameters(lambda act: problem.solve(act, reweight=False),
                                           problem.n_b, opts.r_sigma, start=sol)
            timings["essential"] = time.perf_counter() - t_e
            result.essential = _tls_result(model, ess_res.solution, blocks, opts, bag_names)
        final_chi, final_g = sol.chi_full(), sol.g_tau
    else:
        g = np.full(3, G_TAU_MANUFACTURER) if gains is None else np.asarray(gains, dtype=float)
        if g.shape != (3,) or not np.all(np.isfinite(g)) or np.any(g <= 0):
            raise IdentificationError(
                f"drive gains must be three positive numbers in N/A, not {gains}")
        if gains is None:
            log.info("IDIM-WLS with the manufacturer's drive gains 637π = %.1f N/A "
                     "(give --gains to use identified ones)", G_TAU_MANUFACTURER)
        log.info("IDIM-WLS on %d equations", sum(b.n_rows for b in blocks))
        wsol = idim_wls(blocks, g, weighting=opts.weighting)
        timings["solve"] = time.perf_counter() - t_solve
        result = _wls_result(model, wsol, g, blocks, bag_names)
        solver_diag = {"joint_sigma": [float(x) for x in wsol.joint_sigma]}
        if essential:
            t_e = time.perf_counter()
            ess_res = essential_parameters(
                lambda act: idim_wls(blocks, g, active=act, weighting=opts.weighting),
                len(model.names), opts.r_sigma, start=wsol)
            timings["essential"] = time.perf_counter() - t_e
            result.essential = _wls_result(model, ess_res.solution, g, blocks, bag_names)
        final_chi, final_g = wsol.chi_full(), g
    if ess_res is not None and result.essential is not None:
        result.essential.removed = [str(model.names[k]) for k in ess_res.removed]
        result.essential.diagnostics = {"stopped_because": ess_res.stopped_because,
                                        "ratios": [float(x) for x in ess_res.ratios]}
        result.removed = list(result.essential.removed)

    vals: list[ValidationResult] = []
    t_v = time.perf_counter()
    for rec in validation:
        m = resolve_payload(rec, payload_mass, opts.payload_tolerance_kg)
        if rec.condition == "loaded" and method == "wls" and result.payloads:
            m = next((p.value for p in result.payloads if p.tagged == m), m)
        obs, _, _ = observe(rec, model, opts, m)
        v = cross_validate(obs, final_chi, final_g, m, np.asarray(result.residual_rms),
                           joint_names=JOINT_NAMES)
        vals.append(v)
        warnings.extend(v.warnings)
    if vals:
        timings["validation"] = time.perf_counter() - t_v
    result.validation = [v.to_json(JOINT_NAMES) for v in vals]
    result.validation_details = vals
    if result.condition_number > opts.warn_condition:
        warnings.append(f"condition number of the scaled observation matrix is "
                        f"{result.condition_number:.3g}: some base parameters are poorly excited "
                        "(see their %σ; --essential keeps the well-identified ones)")
    result.warnings = warnings
    timings["total"] = time.perf_counter() - t_all
    result.diagnostics = {
        "samples_used": int(sum(r["n_used"] for r in reports)),
        "samples_dropped": int(sum(r["n_paired"] - r["n_used"] + r["n_unpaired_joint_states"]
                                   + r["n_unpaired_current_reference"] for r in reports)),
        "segments": int(sum(r["n_segments"] for r in reports)),
        "rows": int(sum(b.n_rows for b in blocks)),
        "solver": solver_diag,
        "decimation": opts.decimation,
        "bags": reports,
        "timings_s": {k: round(v, 4) for k, v in timings.items()},
        "options": dict(vars(opts)),
    }
    result.observations = blocks
    return result


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
    """Identify drive gains and base parameters from tagged bags (DESIGN §6).

    ``payload_mass`` (kg) overrides/checks the loaded bags' tags; ``method`` "tls" (gains
    identified, payload known) or "wls" (``gains`` given in N/A, default the manufacturer's 2001;
    payload mass of loaded bags estimated); ``essential`` adds the essential-parameter reduction
    (Sect. 5.2). ``validation_bags`` are cross-validated, not used for identification.
    """
    if not bag_paths:
        raise IdentificationError("no bag given")
    t_read = [0.0]

    def lazily(paths: Sequence[str | Path]) -> Iterator[Record]:
        for p in paths:
            log.info("reading %s", p)
            t0 = time.perf_counter()
            rec = read_record(p)
            t_read[0] += time.perf_counter() - t0
            yield rec

    res = identify_records(lazily(bag_paths), payload_mass, method, gains, essential, options,
                           model, lazily(validation_bags))
    # reading happens inside identify_records' loop: its total already includes it
    res.diagnostics["timings_s"]["read"] = round(t_read[0], 4)
    return res
