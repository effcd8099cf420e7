"""Online identification: the offline pipeline fed while the recordings run
(docs/design/architecture.md §1, §7).

    live = LiveIdentification(IdentifyOptions.from_yaml("config/identification.yaml"),
                              model=load_robot("orthoglide"))  # the robot: always passed
    live.start_recording("run-1", "unloaded", 0.0)
    live.add_joint_states(stamps_ns, ["q11", "q12", "q13"], q)           # any batch size
    live.add_current_reference(stamps_ns, ["q11", "q12", "q13"], v_tau)  # arrives independently
    live.stop_recording()
    live.start_recording("run-2", "loaded", 1.983) ...
    live.estimate()   # about once a second: gains ± σ, seconds used, lag, one-line status
    live.result()     # the IdentificationResult identify_records gives on the same records
                      # (to 1e-6 with lag_model: off; within σ with the lag, below)

Each recording is one record (like one bag). Samples are paired by stamp once both topics are
``live_pairing_slack_s`` past them (pairing.py), split at real gaps, and every continuous segment
runs through a :class:`~stream.SegmentStream` about every ``live_block_s`` of data: the same
filtering, W, reversal bridging and FIR decimation as ``observe.observe``, exact across blocks.
The decimated equations are folded into per-condition, per-joint R factors (factors.py), so
memory and CPU per second of data stay constant; ``result()`` solves them with the offline
solver (solve.py); the raw samples of the recording under way are kept until its stop only,
where offline's record checks run on them (validate/records.py: a recording refused there is
left out and result() answers with the reason until the next recording starts); a recording
slower than SLOW_STEP_S keeps its samples (a few kB/s), which result() solves again at a higher
derivative filter's cut-off to bound its bias in the gains' σ, as offline (solve/filter_bound.py;
estimate() streams without). Non-finite
samples are dropped and split the record (offline
``nonfinite: drop``); nothing here raises on bad or insufficient data: warnings and ``status``
say what is wrong. Never imports rclpy.

The current-loop lag (``lag_model: auto``, current_lag.py) needs the record's periods: offline a
row's instrument is the mean of v̇_τ over all the other periods, live over the previous ones
(current_lag.LiveLagInstrument), so each segment's first ticks are held until its trajectory has
repeated 4 times (6 s for the simulator's 1.5 s period) and the two answers differ by the
instruments' noise, within the gains' σ. A segment used that does not repeat leaves the lag out
of the whole identification, as offline.
"""
from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from orthoglide_ident.errors import (
    ConfigError,
    DataError,
    ExcitationError,
    IdentificationError,
    OrthoglideError,
)
from orthoglide_ident.identify.columns.current_lag import MAX_SEARCH_S
from orthoglide_ident.identify.columns.drive_terms import screw_mask
from orthoglide_ident.identify.columns.layout import ColumnLayout, bound_to, column_layout
from orthoglide_ident.identify.columns.payload_unknowns import (
    check_one_payload,
)
from orthoglide_ident.identify.diagnostics import bag_report, finish_result
from orthoglide_ident.identify.live.recording import LiveRecording
from orthoglide_ident.identify.observe.rows import IdentificationModel, observe
from orthoglide_ident.identify.observe.sampling import SLOW_STEP_S, best_reading
from orthoglide_ident.identify.observe.stream import DecimatedRows
from orthoglide_ident.identify.options import IdentifyOptions
from orthoglide_ident.identify.records.record import payload_knowledge
from orthoglide_ident.identify.records.robot_checks import current_at_limit
from orthoglide_ident.identify.solve.answer import limits, min_rows, tls_model
from orthoglide_ident.identify.solve.factors import RecordFactors
from orthoglide_ident.identify.solve.filter_bound import bound_filter_bias, second_options
from orthoglide_ident.identify.solve.methods import DEFAULT_METHOD, solve
from orthoglide_ident.identify.solve.tls import check_excitation
from orthoglide_ident.identify.validate.agreement import disagreement
from orthoglide_ident.identify.validate.records import (
    by_joint,
    check_record,
    misfit_warnings,
    noise_by_joint,
    other_readings,
    undetermine_at_limit,
)
from orthoglide_ident.model.robot import Payload
from orthoglide_ident.results import IdentificationResult, RecordReport

MAX_LOGGED_WARNINGS = 200  # the first ones, kept for result().warnings
MAX_PENDING_WARNINGS = 1000  # waiting for drain_warnings()


@dataclass
class LiveEstimate:
    """What a user watches about once a second while recording.

    Gains in N/A (N·m/A for a revolute joint) with their relative standard deviation (fraction;
    empty until identified), seconds of data folded in per condition, s_c/s_(c-1) of W_tot
    (``singular_ratio``), the condition number of the scaled W, residual rms per joint (N or
    N·m), the lag (s of received data not
    yet folded in) and a one-line ``status``; ``ok`` when the gains pass every excitation check,
    ``enough_data`` when moreover every gain's σ is below ``live_enough_gain_rel_std``.
    """

    status: str
    joint_names: tuple[str, ...] = ()
    ok: bool = False
    enough_data: bool = False
    gains: tuple[float, ...] = ()  # empty until identified
    gains_rel_std: tuple[float, ...] = ()
    seconds_loaded: float = 0.0
    seconds_unloaded: float = 0.0
    singular_ratio: float = math.nan
    condition_number: float = math.nan
    residual_rms: tuple[float, ...] = ()
    lag_s: float = 0.0
    equations: tuple[int, ...] = ()
    recording: str | None = None  # condition of the recording under way
    gain_units: tuple[str, ...] = ()
    samples: str = ""  # the recording under way (or the last): samples in, used, its steps

    @property
    def known(self) -> bool:
        """The gains have been identified (TLS could be solved)."""
        return bool(self.gains)

    def message_fields(self, warnings: Sequence[str] = ()) -> dict:
        """Fields of orthoglide_msgs/LiveIdentification (header excluded)."""
        known = self.known
        return {
            "status": self.status + (f" | {self.samples}" if self.samples else ""),
            "enough_data": self.enough_data,
            "joint_names": list(self.joint_names),
            "gain_units": list(self.gain_units),
            "drive_gains": [float(g) for g in self.gains] if known else [],
            "drive_gains_rel_std": [float(s) for s in self.gains_rel_std] if known else [],
            "unloaded_seconds": float(self.seconds_unloaded),
            "loaded_seconds": float(self.seconds_loaded),
            "singular_ratio": float(self.singular_ratio),
            "condition_number": float(self.condition_number),
            "residual_rms": [float(r) for r in self.residual_rms] if known else [],
            "lag": float(self.lag_s), "warnings": list(warnings),
        }

    def line(self) -> str:
        """The estimate in one line (a log or a terminal)."""
        units = self.gain_units or ("N/A",) * len(self.gains)
        g = "gains —" if not self.known else "  ".join(
            f"{n} {v:8.5g} {u} ±{100 * s:.2f} %"  # a motor's 0.41704 N·m/A too
            for n, v, s, u in zip(self.joint_names, self.gains, self.gains_rel_std, units))
        return (f"{g} | {self.seconds_unloaded:.0f} s unloaded, {self.seconds_loaded:.0f} s "
                f"loaded, lag {self.lag_s:.1f} s | {self.status}"
                + (f" | {self.samples}" if self.samples else ""))


@dataclass
class _Version:
    n: int = 0  # folds so far
    estimate: LiveEstimate | None = None
    at: tuple = ()  # (folds, condition recorded) the estimate was made at


class LiveIdentification:
    """IDIM-TLS identification fed topic by topic while the recordings run.

    ``options`` as offline (``decimation_filter`` must be ``fir``); ``model`` the robot (passed,
    never defaulted). See the module docstring for the calls; every ``add_*`` returns the
    warnings it raised, and :meth:`drain_warnings` returns all warnings since its last call (use
    either).
    Not thread-safe: call it from one thread (a node with a multi-threaded executor holds a lock
    or puts the subscriptions in one mutually exclusive callback group).
    """

    def __init__(self, options: IdentifyOptions | None = None, *, model: IdentificationModel):
        self.opts = options or IdentifyOptions()
        self.opts.validate()
        if self.opts.observe.decimation_filter != "fir":
            raise ConfigError("live identification needs decimation_filter: fir (cheby1's IIR "
                              "decimation depends on the whole segment)")
        # a transmission's joint-side channels are mapped to its motors on arrival (issue 33)
        self.transmission = model.transmission
        self.model = model  # the robot itself; the columns beside its W: the layout, built once
        self.layout = column_layout(model, self.opts.solve.screw_lead_m,
                                    self.opts.solve.lag_model == "auto")
        self._payloads: list[tuple[str, Payload]] = []  # the loaded recordings' (Sect. 4.3)
        self.n_b = self.layout.n_columns
        self._factors: dict[LiveRecording, RecordFactors] = {}  # one per record, as offline
        self._seconds: dict[str, float] = {"loaded": 0.0, "unloaded": 0.0}
        self._recordings: list[LiveRecording] = []
        self._current: LiveRecording | None = None
        self._pending_warnings: list[str] = []
        self._n_undrained_lost = 0
        self._log: list[str] = []
        self._n_ignored = 0
        self._version = _Version()
        # what the record checks keep (validate/records.py, as offline): the recordings' content
        # fingerprints, their current noise, an untagged slow log's other readings, and the
        # refusal of the last recording (answered until the next recording starts)
        self._seen: dict[str, tuple[str, int]] = {}
        self._noises: dict[LiveRecording, tuple[np.ndarray, float]] = {}
        self._at_limit: dict[LiveRecording, dict[str, str]] = {}  # current_at_limit's
        self._alts: dict[LiveRecording, list] = {}
        # a slow recording's samples (step above SLOW_STEP_S: a few kB/s), kept past its stop:
        # result() observes them again at the derivative filter's second cut-off to bound its
        # bias in the gains' σ, as offline (solve/filter_bound.py)
        self._slow: dict[LiveRecording, object] = {}
        self.refused: str | None = None

    # --- recordings ---------------------------------------------------------------------------
    @property
    def recording(self) -> bool:
        return self._current is not None

    def start_recording(self, source: str, condition: str, payload_mass: float = 0.0,
                        payload: Payload | None = None) -> None:
        """Start a record: ``condition`` "loaded" (payload of ``payload_mass`` kg) or "unloaded";
        ``payload``: its frame, centre of mass and inertia (the bag tag's), None for a point mass
        at the robot's payload frame.

        Raises IdentificationError on a wrong condition or a loaded record without a mass; a
        recording still running is stopped first (with a warning).
        """
        if condition not in ("loaded", "unloaded"):
            raise IdentificationError(f"condition must be loaded or unloaded, not {condition!r}")
        mass = 0.0 if condition == "unloaded" else float(payload_mass)
        if condition == "loaded" and not (math.isfinite(mass) and mass > 0):
            raise IdentificationError(
                f"{source} is loaded without a payload mass: give the weighed mass in kg")
        if self._current is not None:
            self._warn([f"{self._current.source}: still recording when {source} started: "
                        "stopped"])
            self.stop_recording()
        self.refused = None  # a recording refused is left out; the next one is answered again
        lag = self.layout.lag_column is not None and not self._lag_left_out()
        model, bound = self.model, None
        if condition == "loaded":
            p = payload_knowledge(source, payload, mass, self.opts.input.payload_known)
            check_one_payload(self._payloads + [(source, p)])
            self._payloads.append((source, p))
            model, bound = bound_to(model, self.layout, p), p
        self._current = LiveRecording(source, condition, mass, self.opts, model, self.layout,
                                      self._fold, lag, self.transmission, payload, bound)
        self._recordings.append(self._current)

    def stop_recording(self) -> list[str]:
        """End the record under way: pair and process everything received, run the offline
        record checks on it (validate/records.check_record: positions beyond the limits refuse
        it, a copy of an earlier one is counted once) and, on an uneven clock, observe it again
        by the offline rules; its warnings."""
        rec, self._current = self._current, None
        if rec is None:
            return []
        out = rec.close()
        record = rec.raw_record()
        if record is not None:
            out += self._check(rec, record)
            if rec in self._factors and rec.uneven:
                out += self._rebuild(rec, record)
            if rec in self._factors and rec.report().period_s > SLOW_STEP_S:
                self._slow[rec] = record  # small at this rate; result()'s second solve
        rec.release()
        return self._warn(out)

    def _check(self, rec: LiveRecording, record) -> list[str]:
        """The offline record checks on what was received; a refused recording or a copy is
        left out of the live data (its equations dropped), the refusal kept for result()."""
        try:
            new, lines = check_record(record, self.model, self._seen)
        except DataError as exc:
            self.refused = str(exc).splitlines()[0]
            self._leave_out(rec)
            return [f"{self.refused} (refused: left out of the live data)"]
        if not new:
            self._leave_out(rec)
            return lines
        self._noises[rec] = noise_by_joint(record, self.model)
        self._at_limit[rec] = current_at_limit(record, chatter_only=True)
        return lines

    def _leave_out(self, rec: LiveRecording) -> None:
        """A recording's equations out of the live data, as if it had not been recorded."""
        if self._factors.pop(rec, None) is not None:
            self._version.n += 1
        self._slow.pop(rec, None)
        self._seconds[rec.condition] -= rec.seconds
        self._recordings.remove(rec)
        self._payloads = [(s, p) for s, p in self._payloads if s != rec.source]

    def _rebuild(self, rec: LiveRecording, record) -> list[str]:
        """An uneven clock's recording observed again whole by the offline rules (rows.observe:
        the period is the mean step of the whole record, gaps against the local step, no lag
        instrument) and its factors replaced: live = offline at its end. An untagged slow log
        (current_sampling: auto) is also read sampled (validate/records.other_readings), and
        result() keeps the better reading by offline's rule (sampling.best_reading)."""
        try:
            obs, rep, _ = observe(record, self.model, self.opts, rec.payload_mass,
                                  layout=self.layout)
            alts = other_readings(record, self.model, self.opts, rec.payload_mass, rep,
                                  layout=self.layout)
        except OrthoglideError as exc:  # the streamed equations stay; say why
            return [f"{rec.source}: not observed again by the offline rules ({exc}): the "
                    "equations of its uneven clock streamed with its first steps' mean are used"]
        self._seconds[rec.condition] -= rec.seconds
        seconds = obs.n_samples * obs.decimation * rep.period_s
        rec.adopt(rep, obs.rows_per_joint(), obs.n_samples, seconds)
        self._seconds[rec.condition] += seconds
        self._factors[rec] = RecordFactors.from_observations(obs)
        if alts:
            self._alts[rec] = [(d, RecordFactors.from_observations(o), r) for d, o, r in alts]
        self._version.n += 1
        return []

    def add_joint_states(self, stamps_ns: Sequence[int] | np.ndarray, names: Sequence[str],
                         positions: np.ndarray) -> list[str]:
        """Samples of /orthoglide/joint_states: stamps (ns), joint names, positions (n, 3) m."""
        return self._add("q", stamps_ns, names, positions)

    def add_current_reference(self, stamps_ns: Sequence[int] | np.ndarray,
                              names: Sequence[str], currents: np.ndarray) -> list[str]:
        """Samples of /orthoglide/current_reference: stamps (ns), names, v_tau (n, 3) A."""
        return self._add("v", stamps_ns, names, currents)

    def _add(self, topic: str, stamps_ns, names, values) -> list[str]:
        rec = self._current
        if rec is None:
            self._n_ignored += int(np.size(stamps_ns))
            if self._n_ignored == int(np.size(stamps_ns)):
                return self._warn(["samples received while not recording: ignored "
                                   "(call start_recording first)"])
            return []
        out = rec.add(topic, stamps_ns, names, values)
        if rec.due():
            out += rec.process()
        return self._warn(out)

    def process(self) -> list[str]:
        """Pair and process what has arrived (the add_* calls do it every live_block_s)."""
        return self._warn(self._current.process() if self._current is not None else [])

    def drain_warnings(self) -> list[str]:
        """Every warning since the last call (lost ticks, NaN, names, excitation, saturation);
        the newest MAX_PENDING_WARNINGS when more have piled up undrained."""
        out, self._pending_warnings = self._pending_warnings, []
        if self._n_undrained_lost:
            out.insert(0, f"{self._n_undrained_lost} older warnings were not drained in time")
            self._n_undrained_lost = 0
        return out

    def _warn(self, messages: list[str]) -> list[str]:
        self._pending_warnings.extend(messages)
        extra = len(self._pending_warnings) - MAX_PENDING_WARNINGS
        if extra > 0:
            del self._pending_warnings[:extra]
            self._n_undrained_lost += extra
        room = MAX_LOGGED_WARNINGS - len(self._log)
        self._log.extend(messages[:max(room, 0)])
        return messages

    def _fold(self, rec: LiveRecording, rows: DecimatedRows, seconds: float) -> None:
        f = self._factors.get(rec)
        if f is None:
            f = self._factors[rec] = RecordFactors(rec.condition, rec.payload_mass, self.n_b,
                                                   n_joints=self.model.n_joints)
        f.add_source(rec.source)
        f.fold(rows.X, rows.keep, rows.t, rec.source,
               rec.opts.observe.decimation * rec.period_ns * 1e-9, rows.q, rows.qd,
               rec.opts.observe.decimation, screw_mask(self.model))
        self._seconds[rec.condition] += seconds
        self._version.n += 1

    # --- answers ------------------------------------------------------------------------------
    def _folded(self) -> list[RecordFactors]:
        """Factors of every condition with decimated samples (equations kept or not)."""
        return [f for f in self._factors.values() if f.n_samples > 0]

    def _lag_left_out(self) -> bool:
        """A segment used did not repeat a periodic trajectory: no lag instrument for its rows."""
        return any(r.rep.n_not_repeating for r in self._recordings)

    def _solvable(self, factors: list[RecordFactors]
                  ) -> tuple[list[RecordFactors], ColumnLayout]:
        """The factors and layout to solve: without the lag columns when a segment used has no
        instrument (pipeline._lag_or_paper: all or nothing, the paper's drive model)."""
        factors, layout = self._payload_columns(factors)
        col = layout.lag_column
        if col is None or not self._lag_left_out():
            return factors, layout
        cols = np.arange(col, col + self.model.n_joints)
        return [f.without_columns(cols) for f in factors], layout.without_lag()

    def _payload_columns(self, factors: list[RecordFactors]
                         ) -> tuple[list[RecordFactors], ColumnLayout]:
        """Without the unknown payload columns no recording fills (pipeline._payload_or_not)."""
        layout = self.layout
        if not layout.has_payload_unknowns:
            return factors, layout
        start, n = layout.payload_slice.start, layout.n_payload
        keep = tuple(k for k in range(n)
                     if any(np.any(R[:, start + k]) for f in factors for R in f.R))
        reduced = layout.keeping(keep)
        frames = {p.frame for _, p in self._payloads if p.unknown}
        if keep and frames:
            reduced = reduced.at_frame(self.model, frames.pop())
        drop = np.array([start + k for k in range(n) if k not in keep], dtype=int)
        if drop.size:
            factors = [f.without_columns(drop) for f in factors]
        return factors, reduced

    @property
    def lag_s(self) -> float:
        """Seconds of received data whose equations are not folded in yet."""
        return self._current.lag_s if self._current is not None else 0.0

    def result(self, method: str = DEFAULT_METHOD, essential: bool = False,
               gains: Sequence[float] | None = None,
               payload_mass: float | None = None) -> IdentificationResult:
        """IDIM-TLS (or WLS with ``gains`` N/A) on everything folded in: the IdentificationResult
        ``identify_records`` gives on the same records (once they are stopped). ``payload_mass``
        (kg) checks the masses given to start_recording, as ``--payload-mass`` checks bag tags.
        Raises the product's errors with a one-line reason (e.g. no loaded data, the last
        recording refused by the record checks)."""
        if self.refused is not None:
            raise DataError(f"{self.refused} (the recording is left out of the live data: "
                            "record it again)")
        recs = [r for r in self._recordings
                if r in self._factors and self._factors[r].n_samples > 0]
        if not recs:
            raise IdentificationError("no equations yet: record the trajectories unloaded and "
                                      "loaded with the weighed payload")
        if payload_mass is not None:
            self._with_payload(recs, payload_mass)
        chains: list[str] = []

        def solve_rows(factors: list[RecordFactors], reports: list[RecordReport],
                       opts: IdentifyOptions = self.opts, essential: bool = essential) -> tuple:
            """As pipeline's: the records' drive chains compared on the rows solved."""
            if payload_mass is not None:
                factors = [dataclasses.replace(f, payload_mass=payload_mass) if f.loaded
                           else f for f in factors]
            factors, layout = self._solvable(factors)
            model = self.model
            if len(factors) == len(recs):  # one per recording, in recs' order
                factors = [dataclasses.replace(f, at_limit=by_joint(
                    model, self._at_limit.get(r, {}))) for f, r in zip(factors, recs)]
            chains.append(disagreement(factors, model.nominal_gains, list(model.joint_names)))
            try:
                return model, factors, opts, solve(
                    factors, model, opts, method, gains, essential,
                    [r.source for r in self._recordings if r.n_decimated], layout=layout)
            except (ExcitationError, IdentificationError) as exc:  # two drive chains: the cause
                if chains[-1]:
                    raise type(exc)(f"{chains[-1]} (the solve then says: {exc})") from None
                raise

        warnings = list(self._log)
        readings = [(self._factors[r], r.report(), self._alts.get(r)) for r in recs]
        (model, factors, _, solved), reports = self._solve_reading(
            solve_rows, readings, warnings, [r.report() for r in self._recordings])
        result = solved.result
        if chains[-1]:
            result.warnings.append(chains[-1])
        if solved.chi.shape[0] == factors[0].n_b:  # behind a transmission: a reduction misfit
            cutoff = reports[0].decimation_cutoff_hz or recs[0].opts.observe.decimation_cutoff_hz
            misfit_warnings(result, solved.g_tau, model,
                            [self._noises[r] for r in recs if r in self._noises],
                            self.opts.replace(decimation_cutoff_hz=cutoff))
        undetermine_at_limit(result, [self._at_limit.get(r, {}) for r in recs])
        finish_result(result, solved, reports, warnings, self.opts, dict(solved.timings))
        bound_filter_bias(result, self._solve_again(solve_rows, recs, result), SLOW_STEP_S,
                          self.opts.solve.max_gain_rel_std)
        return result

    def _solve_again(self, solve_rows, recs: list[LiveRecording], result: IdentificationResult):
        """filter_bound's ``solve_again`` on the live data: the slow recordings' samples kept
        observed again by the offline rules at the second cut-offs, read as ``result`` read
        them (filter_bound.second_options); None (said) when a recording's are not kept (a
        fast one among slow ones) or refused there."""
        def again(f_q: float, f_d: float) -> IdentificationResult | None:
            o = second_options(result.record_reports, self.opts, f_q, f_d)
            if any(r not in self._slow for r in recs):
                return None
            try:
                readings = [self._observe(r, o) for r in recs]
                return self._solve_reading(
                    lambda f, r: solve_rows(f, r, o, False), readings, [])[0][3].result
            except OrthoglideError:
                return None
        return again

    def _observe(self, rec: LiveRecording, o: IdentifyOptions) -> tuple:
        """A kept recording observed by the offline rules with ``o``: (factors, report, its
        other readings when open), as ``_solve_reading`` takes them."""
        record = self._slow[rec]
        obs, rep, _ = observe(record, self.model, o, rec.payload_mass, layout=self.layout)
        alts = other_readings(record, self.model, o, rec.payload_mass, rep, layout=self.layout)
        return (RecordFactors.from_observations(obs),
                bag_report(rep, rec.source, rec.condition, rec.payload_mass,
                           obs.rows_per_joint()),
                alts and [(d, RecordFactors.from_observations(x), r) for d, x, r in alts])

    def _solve_reading(self, solve_rows, readings: list[tuple], warnings: list[str],
                       every: list[dict] | None = None) -> tuple[tuple, list[dict]]:
        """``solve_rows`` on the recordings' ``readings`` ((factors, report, other readings or
        None) each) as read, or, with an untagged slow log among them, on the best of its
        readings by offline's rule (sampling.best_reading); the line saying which reading the
        answer used into ``warnings`` (``every``: the reports of every recording, those without
        equations too, when none is open)."""
        factors, reports, alts = (list(x) for x in zip(*readings))
        if not any(alts):  # every recording's report, those without equations too
            reports = every or reports
            return solve_rows(factors, reports), reports
        out, reports, line = best_reading(solve_rows, factors, reports, alts)
        warnings.append(line)
        return out, reports

    def _with_payload(self, recs: list[LiveRecording], mass: float) -> None:
        """IdentificationError when ``mass`` is not the one the loaded recordings were made with
        (as --payload-mass checks bag tags)."""
        if not (math.isfinite(mass) and mass > 0):
            raise IdentificationError(f"payload mass must be a positive mass in kg, not {mass}")
        for r in recs:
            if r.condition == "loaded" and \
                    abs(r.payload_mass - mass) > self.opts.input.payload_tolerance_kg:
                raise IdentificationError(
                    f"{r.source} was recorded with a payload of {r.payload_mass:g} kg but "
                    f"{mass:g} kg is asked; check which payload was mounted")

    def estimate(self) -> LiveEstimate:
        """Gains ± σ and a one-line status from the data folded in so far (never raises)."""
        v = self._version
        rec = self._current
        key = (v.n, rec.condition if rec is not None else None,
               int(rec.held_s) if rec is not None else 0)  # a hold says how long it has held
        if v.estimate is None or v.at != key:
            v.estimate, v.at = self._estimate(), key
        est = v.estimate
        est.lag_s = self.lag_s
        est.recording = self._current.condition if self._current is not None else None
        last = self._current or (self._recordings[-1] if self._recordings else None)
        est.samples = last.samples_line() if last is not None else ""
        return est

    def _estimate(self) -> LiveEstimate:
        factors = self._folded()
        model = self.model
        rows = tuple(int(sum(f.rows[j] for f in factors)) for j in range(model.n_joints))
        base = dict(seconds_loaded=self._seconds["loaded"],
                    seconds_unloaded=self._seconds["unloaded"], equations=rows,
                    joint_names=tuple(model.joint_names),
                    gain_units=tuple(j.gain_unit for j in model.joints))
        loaded = any(f.loaded for f in factors)
        unloaded = any(not f.loaded for f in factors)
        if self.refused is not None:
            return LiveEstimate(f"refused: {self.refused}", **base)
        if not factors:
            return LiveEstimate(self._collecting(), **base)
        now = self._current.condition if self._current is not None else None
        if not loaded:
            what = "loaded recording under way" if now == "loaded" else "record with the payload"
            return LiveEstimate(f"unloaded only: {what}", **base)
        if not unloaded:
            what = "unloaded recording under way" if now == "unloaded" else \
                "record without the payload"
            return LiveEstimate(f"loaded only: {what}", **base)
        need = min_rows(self.n_b)
        for joint, n in zip(model.joints, rows):
            if n < need:
                return LiveEstimate(
                    f"excitation too weak on {joint.name}: {n} equations above the velocity "
                    f"dead band ({self.opts.observe.velocity_deadband_mps} {joint.unit}/s), {need} "
                    "needed", **base)
        return self._solve_status(factors, base)

    def _collecting(self) -> str:
        rec = self._current
        if rec is None:
            return "no data: start a recording"
        if rec.held_s > 0:
            return (f"collecting: {rec.held_s:.0f} s held until the trajectory has repeated 4 "
                    "times (the current-loop lag's instrument, lag_model: auto; at most "
                    f"{MAX_SEARCH_S:g} s)")
        return ("collecting: the first equations come after about 1 s of data, or once the "
                "trajectory has repeated 4 times (lag_model: auto)")

    def _solve_status(self, factors: list[RecordFactors], base: dict) -> LiveEstimate:
        """TLS on the factors; status from the excitation checks (IdentifyOptions limits)."""
        opts = self.opts
        try:
            factors, layout = self._solvable(factors)
            m, _ = tls_model(factors, self.model, layout, opts)  # as result() solves it
            sol = m.full
        except (OrthoglideError, np.linalg.LinAlgError) as exc:
            return LiveEstimate(f"not identifiable yet: {exc}", **base)
        n, names = sol.chi.shape[0], self.model.joint_names
        grel = sol.rel_std[n:n + self.model.n_joints]
        est = LiveEstimate("", gains=tuple(float(x) for x in sol.g_tau),
                           gains_rel_std=tuple(float(x) for x in grel),
                           singular_ratio=sol.singular_ratio,
                           condition_number=sol.condition_number,
                           residual_rms=tuple(float(x) for x in sol.residual_rms), **base)
        try:
            if opts.solve.check_excitation:
                check_excitation(sol, limits(self.model, opts), m.names, names)
        except ExcitationError as exc:
            j = int(np.argmax(grel))
            if grel[j] > opts.solve.max_gain_rel_std and str(exc).startswith("drive gain of"):
                est.status = (f"excitation too weak on {names[j]}: its gain is known to "
                              f"{100 * grel[j]:.1f} % (> {100 * opts.solve.max_gain_rel_std:g} %); "
                              "record longer or more exciting trajectories")
            else:
                est.status = f"excitation too weak: {exc}"
            return est
        worst = float(np.max(grel))
        est.ok = True
        if worst <= opts.live.live_enough_gain_rel_std:
            est.enough_data = True
            est.status = f"gains known to {100 * worst:.2f} %: enough data"
        else:
            est.status = (f"gains known to {100 * worst:.2f} %: keep recording (enough below "
                          f"{100 * opts.live.live_enough_gain_rel_std:g} %)")
        return est

