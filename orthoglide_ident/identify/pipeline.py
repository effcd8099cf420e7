"""The offline identification end to end: bags → records → observation → solve → result.

Reading is records.py, the observation of a record observe.py, the methods solve.py, the
diagnostics diagnostics.py: this module only orders them for bags and records.

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
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from orthoglide_ident.errors import ExcitationError, IdentificationError, OrthoglideError
from orthoglide_ident.identify.columns.layout import ColumnLayout, column_layout
from orthoglide_ident.identify.columns.payload_unknowns import check_one_payload, used_columns
from orthoglide_ident.identify.diagnostics import bag_report, finish_result
from orthoglide_ident.identify.observe.equations import Observations
from orthoglide_ident.identify.observe.rows import IdentificationModel, observe
from orthoglide_ident.identify.observe.sampling import (
    ALIASED,
    AUTO_HELD,
    SLOW_STEP_S,
    best_reading,
    lag_says_sampled,
)
from orthoglide_ident.identify.options import IdentifyOptions
from orthoglide_ident.identify.records.record import Record, read_record, record_payload
from orthoglide_ident.identify.records.robot_checks import current_at_limit
from orthoglide_ident.identify.solve.answer import Solved, min_rows
from orthoglide_ident.identify.solve.factors import RecordFactors
from orthoglide_ident.identify.solve.filter_bound import bound_filter_bias, second_options
from orthoglide_ident.identify.solve.methods import DEFAULT_METHOD, get, solve
from orthoglide_ident.identify.validate.agreement import disagreement
from orthoglide_ident.identify.validate.cross_validation import ValidationResult, cross_validate
from orthoglide_ident.identify.validate.joint_side import joint_side_rms
from orthoglide_ident.identify.validate.records import (
    by_joint,
    check_record,
    fingerprint,
    misfit_warnings,
    noise_by_joint,
    other_readings,
    undetermine_at_limit,
)
from orthoglide_ident.model.robot import Payload
from orthoglide_ident.results import IdentificationResult, RecordReport

log = logging.getLogger("orthoglide_ident.identify")

__all__ = ["Record", "fingerprint", "identify", "identify_records", "observe", "read_record",
           "resolve_payload"]


Progress = Callable[..., None]  # (stage, done, total, unit): progress.Stages or a test's


def _tell(progress: Progress | None, what: str, done: float, total: float, unit: str) -> None:
    if progress is not None:
        progress(what, done, total, unit)


def _size_mb(path: str | Path) -> float:
    """A bag's size in MB (a directory's files summed); 0 when it cannot be told."""
    p = Path(path)
    try:
        files = [p] if p.is_file() else [f for f in p.rglob("*") if f.is_file()]
        return sum(f.stat().st_size for f in files) / 1e6
    except OSError:
        return 0.0


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



def _check_request(opts: IdentifyOptions, method: str, payload_mass: float | None) -> None:
    opts.validate()
    get(method)  # IdentificationError for an unknown method
    if payload_mass is not None and not (np.isfinite(payload_mass) and payload_mass > 0):
        raise IdentificationError(
            f"--payload-mass must be a positive mass in kg, not {payload_mass}")


def _observe_all(records: Iterable[Record], model: IdentificationModel, layout: ColumnLayout,
                 opts: IdentifyOptions, payload_mass: float | None,
                 add_timings: Callable[[dict[str, float]], None],
                 partial: list[tuple[str, Payload]] | None = None, alts: list | None = None,
                 progress: Progress | None = None
                 ) -> tuple[list[Observations], list[RecordReport], list[RecordChecks], list[str],
                            list[str]]:
    """Each record to its observation rows (one record's raw samples in memory at a time):
    the rows, the per-bag reports, what the solve checks of each record, the warnings and the
    bag names; the loaded records' payloads appended to ``partial`` (one payload whose
    parameters are partly unknown); to ``alts``, per record, its other readings of a slow step
    whose reading is open (:func:`_other_readings`), else None."""
    if isinstance(records, Sequence):  # in memory: check every tag before the long steps
        for r in records:
            resolve_payload(r, payload_mass, opts.input.payload_tolerance_kg)
    blocks: list[Observations] = []
    reports: list[RecordReport] = []
    checks: list[RecordChecks] = []
    warnings: list[str] = []
    bag_names: list[str] = []
    seen: dict[str, tuple[str, int]] = {}  # fingerprint -> source, first stamp
    partial = [] if partial is None else partial
    for rec in records:
        new, lines = check_record(rec, model, seen)  # positions beyond the limits: refused
        if not new:  # a copy: counted once
            warnings.extend(lines)
            log.info("%s", lines[-1])
            continue
        m = resolve_payload(rec, payload_mass, opts.input.payload_tolerance_kg)
        p = record_payload(rec, m, opts.input.payload_known)
        if p is not None:
            partial.append((rec.source, p))
            check_one_payload(partial)
        bag_names.append(rec.source)
        warnings.extend(lines)
        obs, rep, ts = observe(rec, model, opts, m, progress, layout=layout)
        add_timings(ts)
        check_moves(obs, model, opts, "bag")
        blocks.append(obs)
        reports.append(bag_report(rep, rec.source, rec.condition, m, obs.rows_per_joint(),
                                  rec.sources))
        # the record's, however it is read (its other readings too)
        checks.append(RecordChecks(noise_by_joint(rec, model),
                                   current_at_limit(rec, chatter_only=True)))
        if alts is not None:
            alts.append(other_readings(rec, model, opts, m, rep, layout=layout))
        del rec  # a lazily read bag's raw samples can go now
    if not blocks:
        raise IdentificationError("no bag given")
    return blocks, reports, checks, warnings, bag_names


@dataclass(frozen=True)
class RecordChecks:
    """What the solve checks of a record beside its rows: the current's noise per joint
    (validate/records.noise_by_joint) and the joints whose current chatters at its limit
    (records/robot_checks.current_at_limit)."""

    current_noise: tuple[np.ndarray, float]  # σ per joint (A), the log's rate
    at_limit: dict[str, str]  # joint -> why


def check_moves(obs: Observations, model: IdentificationModel, opts: IdentifyOptions,
                what: str) -> None:
    """ExcitationError when no joint of a record moves: a robot holding still gives no equation of
    its dynamics (every row is below the velocity dead band), only the friction's sign noise."""
    rows = obs.rows_per_joint()
    moving = max(rows, default=0)
    # few rows of many samples: still; few rows of few samples is a short record (check_rows)
    if moving < min_rows(obs.W.shape[2]) and moving < obs.n_samples / 2:
        raise ExcitationError(
            f"{what} {obs.source}: the robot hardly moves in this record (at most {max(rows)} of "
            f"{obs.n_samples} decimated samples of any joint above the velocity dead band, "
            f"velocity_deadband_mps {opts.observe.velocity_deadband_mps:g}): it holds no equation "
            "of the dynamics; "
            "leave it out or record exciting motion")


def identify_records(
    records: Iterable[Record],
    payload_mass: float | None = None,
    method: str = DEFAULT_METHOD,
    gains: Sequence[float] | None = None,
    essential: bool = False,
    options: IdentifyOptions | None = None,
    *,
    model: IdentificationModel,
    validation: Iterable[Record] = (),
    progress: Progress | None = None,
) -> IdentificationResult:
    """Identify from records; see :func:`identify`. With ``current_sampling: auto`` records
    in memory whose identified lag comes out negative are read again as sampled
    (observe/sampling.py; ``identify`` reads the bags again).

    ``records`` may be a generator (``identify`` reads bags lazily, one at a time, so that only
    one record's raw samples are in memory at once).
    """
    opts = options or IdentifyOptions()
    _check_request(opts, method, payload_mass)
    if isinstance(records, Sequence):  # auto may read them again, as sampled
        kw = dict(payload_mass=payload_mass, method=method, gains=gains, essential=essential,
                  model=model, progress=progress)
        result = _identify_once(records, options=opts, validation=list(validation), **kw)
        why = sampling_rerun(result, opts)
        if why is not None:
            log.info("%s", why)
            result = _identify_once(records, options=opts.replace(current_sampling="sampled"),
                                    validation=list(validation), **kw)
            result.warnings.insert(0, why)
        _bound_filter_bias(result, records, opts, kw)
        return result
    return _identify_once(records, payload_mass, method, gains, essential, opts, model=model,
                          validation=validation, progress=progress)


def _bound_filter_bias(result: IdentificationResult, records: Iterable[Record],
                       opts: IdentifyOptions, kw: dict) -> None:
    """A slow log's gains with the derivative filter's bias bound in their σ
    (solve/filter_bound.py): the same ``records`` (read once, only then), read as ``result``
    read them, solved again at a higher cut-off."""

    def solve_again(f_q: float, f_d: float) -> IdentificationResult | None:
        o = second_options(result.record_reports, opts, f_q, f_d)
        try:
            return _identify_once(records, options=o, **dict(kw, essential=False))
        except OrthoglideError:
            return None

    bound_filter_bias(result, solve_again, SLOW_STEP_S, opts.solve.max_gain_rel_std)


def sampling_rerun(result: IdentificationResult, opts: IdentifyOptions) -> str | None:
    """Why a result read with ``current_sampling: auto`` must be read again as sampled (its
    identified lag is negative: observe/sampling.lag_says_sampled), or None. Only when every
    record was read held by auto's default (none tagged or set held by the robot file)."""
    if opts.input.current_sampling != "auto":
        return None
    bags = result.record_reports
    if not bags or any(not b.current_sampling_why.startswith(AUTO_HELD) for b in bags):
        return None
    return lag_says_sampled(result.current_lag)


def _identify_once(
    records: Iterable[Record],
    payload_mass: float | None = None,
    method: str = DEFAULT_METHOD,
    gains: Sequence[float] | None = None,
    essential: bool = False,
    options: IdentifyOptions | None = None,
    *,
    model: IdentificationModel,
    validation: Iterable[Record] = (),
    progress: Progress | None = None,
) -> IdentificationResult:
    """:func:`identify_records` with each record's current sampling as resolved once."""
    opts = options or IdentifyOptions()
    timings: dict[str, float] = {}
    t_all = time.perf_counter()
    # the columns beside W, once: the robot itself is never wrapped (columns/layout.py)
    layout = column_layout(model, opts.solve.screw_lead_m, opts.solve.lag_model == "auto")

    def add(ts: dict[str, float]) -> None:
        for k, v in ts.items():
            timings[k] = timings.get(k, 0.0) + v

    payloads: list[tuple[str, Payload]] = []
    alts: list = []  # per record, its other readings when open (observe/sampling.py)
    blocks, reports, checks, warnings, bag_names = _observe_all(
        records, model, layout, opts, payload_mass, add, payloads, alts, progress)
    t_solve = time.perf_counter()

    chains: list[str] = []  # the records' drive chains compared on the rows solved

    def solve_rows(blocks, reports):
        cols, b = _payload_or_not(model, layout, blocks, payloads)
        o = _at_first_rate(opts, reports[0])
        cols, b = _lag_or_paper(cols, b, reports)
        factors = [dataclasses.replace(RecordFactors.from_observations(x), at_limit=by_joint(
            model, c.at_limit)) for x, c in zip(b, checks)]
        chains.append(disagreement(factors, model.nominal_gains, list(model.joint_names)))
        try:
            return cols, b, o, solve(factors, model, o, method, gains, essential, bag_names,
                                     progress=progress, layout=cols)
        except (ExcitationError, IdentificationError) as exc:  # two drive chains: the cause
            if chains[-1]:
                raise type(exc)(f"{chains[-1]} (the solve then says: {exc})") from None
            raise

    (solved_layout, blocks, opts, solved), reports = _solve_reading(solve_rows, blocks, reports,
                                                                    alts, warnings)
    chain = chains[-1]
    add(solved.timings)
    timings["solve"] = time.perf_counter() - t_solve - timings.get("essential", 0.0)
    result = solved.result
    if chain:
        result.warnings.append(chain)
    _joint_side_residual(result, blocks, solved, model, checks, opts)
    undetermine_at_limit(result, [c.at_limit for c in checks])

    _attach_validation(result, validation, solved, model, solved_layout, _as_read(opts, reports),
                       payload_mass, warnings, timings)
    timings["total"] = time.perf_counter() - t_all
    finish_result(result, solved, reports, warnings, opts, timings)
    result.observations = blocks
    result.observations_chi = solved.chi
    return result


def _at_first_rate(opts: IdentifyOptions, first: RecordReport) -> IdentifyOptions:
    """The options at the first record's rate: it fixes what the solve needs in samples (the
    σ's decimation gain)."""
    return opts.replace(filter_cutoff_hz=first.filter_cutoff_hz, decimation=first.decimation,
                        decimation_cutoff_hz=first.decimation_cutoff_hz)


def _attach_validation(result: IdentificationResult, validation: Iterable[Record],
                       solved: Solved, model: IdentificationModel, layout: ColumnLayout,
                       opts: IdentifyOptions, payload_mass: float | None, warnings: list[str],
                       timings: dict[str, float]) -> None:
    """The validation records' rows (Fig. 5) and their warnings, into ``result``."""
    t_v = time.perf_counter()
    vals = _validate(validation, solved, model, layout, opts, payload_mass)
    if vals:
        timings["validation"] = time.perf_counter() - t_v
    for v in vals:
        warnings.extend(v.warnings)
    result.validation = [v.row(model.joint_names) for v in vals]
    result.validation_details = vals


def _solve_reading(solve_rows: Callable, blocks: list[Observations],
                   reports: list[RecordReport], alts: list, warnings: list[str]
                   ) -> tuple[tuple, list[RecordReport]]:
    """``solve_rows`` on the records' reading, or the best of their open readings
    (observe/sampling.best_reading, its line into ``warnings``); a refusal of a slow log read
    as sampled also names what a point-sampled log cannot undo (sampling.ALIASED)."""
    try:
        if any(a is not None for a in alts):
            out, reports, line = best_reading(solve_rows, blocks, reports, alts)
            warnings.append(line)
            return out, reports
        return solve_rows(blocks, reports), reports
    except ExcitationError as exc:
        if any(a is not None for a in alts) or any(r.current_sampling == "sampled"
                                                   and r.period_s > SLOW_STEP_S
                                                   for r in reports):
            raise ExcitationError(f"{exc}; {ALIASED}") from None
        raise


def _as_read(opts: IdentifyOptions, reports: list[RecordReport]) -> IdentifyOptions:
    """The options that read other records (validation) as these were read: sampled, at the
    half tick chosen, when all were read sampled."""
    if {r.current_sampling for r in reports} != {"sampled"}:
        return opts
    shift_ms = max(r.current_shift_ms for r in reports)
    loop_hz = 0.5e3 / shift_ms if shift_ms > 0 else opts.input.current_loop_hz
    return opts.replace(current_sampling="sampled", current_loop_hz=loop_hz)


def _payload_or_not(model: IdentificationModel, layout: ColumnLayout,
                    blocks: list[Observations], payloads: list[tuple[str, Payload]]
                    ) -> tuple[ColumnLayout, list[Observations]]:
    """The layout and rows with only the unknown payload columns some loaded record fills (a
    payload known by its mass, Sect. 4.3), named at that payload's frame: with every payload
    known, the rows are the robot's own (zero columns would make W_tot rank deficient)."""
    if not layout.has_payload_unknowns:
        return layout, blocks
    start, n = layout.payload_slice.start, layout.n_payload
    keep = used_columns([b.W for b in blocks], start, n)
    frames = {p.frame for _, p in payloads if p.unknown}
    reduced = layout.keeping(keep)
    if keep and frames:
        reduced = reduced.at_frame(model, frames.pop())
    drop = [start + k for k in range(n) if k not in keep]
    if drop:
        blocks = [dataclasses.replace(b, W=np.delete(b.W, drop, axis=2)) for b in blocks]
    return reduced, blocks


def _lag_or_paper(layout: ColumnLayout, blocks: list[Observations],
                  reports: list[RecordReport]) -> tuple[ColumnLayout, list[Observations]]:
    """The layout and rows with the lag columns only when every segment used had its instrument:
    rows with a zero lag column would still hold the lag's force and bias τ and the gains
    (a third of the rows without it halved τ on the simulator). Otherwise the paper's model."""
    col = layout.lag_column
    if col is None:
        return layout, blocks
    lacking = [f"{r.bag} ({r.n_not_repeating} of {r.n_segments} segments)"
               for r in reports if r.n_not_repeating]
    if not lacking:
        return layout, blocks
    log.info("the current-loop lag is not modelled: %s do not repeat a periodic trajectory "
             "(lag_model: auto needs every segment to)", ", ".join(lacking))
    cols = np.r_[col:col + len(layout.joint_names)]
    out = [dataclasses.replace(b, W=np.delete(b.W, cols, axis=2)) for b in blocks]
    return layout.without_lag(), out


def _joint_side_residual(result: IdentificationResult, blocks: list[Observations],
                         solved: Solved, model: IdentificationModel,
                         checks: list[RecordChecks], opts: IdentifyOptions) -> None:
    """Behind a transmission, the residual per joint, joint-side (Nᵀ ε), into ``result``, and
    the motors fitted far worse than their current noise said (validate/records.py)."""
    noises = [c.current_noise for c in checks]
    t = model.transmission
    if t is None or solved.chi.shape[0] != blocks[0].W.shape[2]:
        return
    misfit_warnings(result, solved.g_tau, model, noises, opts)
    masses = [next((p.value for p in result.payloads if b.source in p.bags), b.payload_mass)
              if get(result.method).gains_given else b.payload_mass for b in blocks]
    rms, _ = joint_side_rms(blocks, solved.chi, solved.g_tau, masses, t.N)
    result.residual_rms_joint_side = rms
    result.residual_joint_names = list(t.joints)


def _validate(records: Iterable[Record], solved: Solved, model: IdentificationModel,
              layout: ColumnLayout, opts: IdentifyOptions, payload_mass: float | None
              ) -> list[ValidationResult]:
    """Cross-validation (Fig. 5) of the solution on records not used to identify it, observed
    with the columns solved (``layout``)."""
    result, out = solved.result, []
    for rec in records:
        m = resolve_payload(rec, payload_mass, opts.input.payload_tolerance_kg)
        if rec.condition == "loaded" and get(result.method).gains_given and result.payloads:
            m = next((p.value for p in result.payloads if p.tagged == m), m)
        obs, _, _ = observe(rec, model, opts, m, layout=layout)
        check_moves(obs, model, opts, "validation bag")
        out.append(cross_validate(obs, solved.chi, solved.g_tau, m,
                                  np.asarray(result.residual_rms), joint_names=model.joint_names))
        if result.consistency is not None:  # the consistent model forward-simulated on it
            from orthoglide_ident.identify.validate.direct_dynamics import validate

            result.consistency.direct_dynamics.append(validate(
                rec, model, result.consistency.answer.chi_st,
                solved.g_tau, m, opts))
    return out



def identify(
    bag_paths: Sequence[str | Path],
    payload_mass: float | None = None,
    method: str = DEFAULT_METHOD,
    gains: Sequence[float] | None = None,
    essential: bool = False,
    options: IdentifyOptions | None = None,
    *,
    model: IdentificationModel,
    validation_bags: Sequence[str | Path] = (),
    progress: Progress | None = None,
) -> IdentificationResult:
    """Identify drive gains and base parameters from tagged bags (docs/design/architecture.md).

    ``model``: the robot (model/registry.load_robot at the CLI or node edge; never defaulted).
    ``payload_mass`` (kg) overrides/checks the loaded bags' tags; ``method`` a name of
    methods.METHODS: "tls" (gains identified, payload known) or "wls" (``gains`` given in N/A or
    N·m/A, default the robot's nominal ones; payload mass of loaded bags estimated);
    ``essential`` adds the essential-parameter reduction (Sect. 5.2). ``validation_bags`` are
    cross-validated, not used for identification. ``progress(stage, done, total, unit)``
    (progress.Stages at the CLI's edge; None: silent) hears how far each long step is.
    """
    if not bag_paths:
        raise IdentificationError("no bag given")
    t_read = [0.0]
    opts = options or IdentifyOptions()

    def lazily(paths: Sequence[str | Path], what: str) -> Iterator[Record]:
        if not paths:
            return
        sizes = [_size_mb(p) for p in paths]  # a record's reading and observing go with its size
        for k, p in enumerate(paths):
            _tell(progress, what, sum(sizes[:k]), sum(sizes), "MB")
            log.info("reading %s", p)
            t0 = time.perf_counter()
            rec = read_record(p, model, opts, progress)
            log.info("%s: %s", p, rec.sources)
            t_read[0] += time.perf_counter() - t0
            yield rec  # observed before the next one is asked for
        _tell(progress, what, sum(sizes), sum(sizes), "MB")

    def records() -> Iterator[Record]:
        return lazily(bag_paths, "reading and observing the records")

    def validation() -> Iterator[Record]:
        return lazily(validation_bags, "reading and observing the validation records")

    res = identify_records(records(), payload_mass, method, gains, essential, opts,
                           model=model, validation=validation(), progress=progress)
    why = sampling_rerun(res, opts)
    if why is not None:  # read the bags again, as sampled at their stamps
        log.info("%s", why)
        t_first = res.diagnostics.timings_s.get("total", 0.0)
        res = identify_records(records(), payload_mass, method, gains, essential,
                               opts.replace(current_sampling="sampled"), model=model,
                               validation=validation(), progress=progress)
        res.warnings.insert(0, why)
        res.diagnostics.timings_s["first_reading_held"] = round(t_first, 4)
    again = lazily(bag_paths, "reading the records again (a slow log's filter bound)")
    _bound_filter_bias(res, again, opts, dict(payload_mass=payload_mass, method=method,
                                              gains=gains, model=model))
    # reading happens inside identify_records' loop: its total already includes it
    res.diagnostics.timings_s["read"] = round(t_read[0], 4)
    return res
