"""One live recording (like one bag): pairing, segmentation at real gaps, segment streams.

Fed by :class:`~live.LiveIdentification`. The tick period is set from the first
``PERIOD_SAMPLES`` paired stamps by the offline rule (segments._breaks): their median step on a
steady clock (the offline pipeline takes the median over the whole record: the same for a
controller's regular ticks; a different median at the end is warned about), the mean of the
steps between gaps on an uneven one (a ~100 Hz logger's 10/12/14 ms). An uneven clock's mean
is known only at the end: every sample received is kept until the stop, where the record
checks run on them (validate/records.py, as offline) and an uneven clock's recording is rebuilt
from them by the offline observation itself (rows.observe), so that the answer is the offline one
on the same samples. A step outside (0.5, 1.5) periods ends the segment under way
(ticks.find_breaks); a segment becomes a :class:`~stream.SegmentStream` once it is long enough
to be kept (``ObserveOptions.min_segment_samples``),
and its decimated rows go to ``fold`` as they come.
With the current-loop lag in the model, a segment's ticks first pass its
:class:`~current_lag.LiveLagInstrument`, which holds them until the trajectory has repeated.
"""
from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from orthoglide_ident.errors import OrthoglideError
from orthoglide_ident.identify.columns.current_lag import LiveLagInstrument, without_instrument
from orthoglide_ident.identify.diagnostics import bag_report
from orthoglide_ident.identify.observe.stream import DecimatedRows, SegmentStream
from orthoglide_ident.identify.options import IdentifyOptions
from orthoglide_ident.identify.records.pairing import Paired, TopicBuffer, pair_upto
from orthoglide_ident.identify.records.record import Record
from orthoglide_ident.identify.records.segments import SegmentReport
from orthoglide_ident.model.transmission import Transmission
from orthoglide_ident.results import RecordReport
from orthoglide_ident.ticks import (
    BREAK_HIGH,
    BREAK_LOW,
    OFF_GRID_TOL,
    StepStats,
    find_breaks,
    find_breaks_local,
    step_stats,
)

PERIOD_SAMPLES = 200  # paired ticks whose median step sets the period
MAX_STEP_VALUES = 10_000  # distinct stamp steps kept to recompute the record's median
SILENT_TOPIC_S = 2.0  # one topic this far behind the other: say so

Fold = Callable[["LiveRecording", DecimatedRows, float], None]
Channels = tuple[tuple[str, ...], Callable[[np.ndarray], np.ndarray] | None]


def channel_maps(names: tuple[str, ...], t: Transmission | None) -> tuple[Channels, Channels]:
    """The channels the positions and the currents arrive on and their map to the model's
    ``names`` (the motors, for a transmission): q_m = N q_j + offset for joint-side positions,
    v_m = N⁻ᵀ v_j for joint-side efforts, as records.motor_side does offline."""
    if t is None:
        return (names, None), (names, None)
    q = (t.joints, t.to_actuator_position) if t.position_side == "joint" else (t.actuators, None)
    v = (t.joints, t.to_actuator_effort) if t.effort_side == "joint" else (t.actuators, None)
    return q, v


class LiveRecording:
    """A record under way: two topic buffers, the segment being built, its report.

    ``model``: the robot bound to the record's payload ``bound`` (columns/layout.bound_to,
    whose unknown kinds fill W_ul); ``layout``: the columns beside W (columns/layout.py)."""

    def __init__(self, source: str, condition: str, payload_mass: float, opts: IdentifyOptions,
                 model, layout, fold: Fold, lag: bool = False,
                 transmission: Transmission | None = None, payload=None, bound=None):
        self.source, self.condition, self.payload_mass = source, condition, payload_mass
        self.payload = payload  # as start_recording was given it (the tag's), for the rebuild
        self.opts, self.model, self.layout, self._fold = opts, model, layout, fold
        self.bound = bound
        limit = opts.live.current_warn_fraction * opts.live.current_limit_a
        self.joint_names = names = tuple(model.joint_names)
        n_j = len(names)
        (q_names, q_map), (v_names, v_map) = channel_maps(names, transmission)
        self.q = TopicBuffer("joint_states", q_names, to_model=q_map)
        self.v = TopicBuffer("current_reference", v_names, limit=limit, to_model=v_map)
        # every sample taken, until the stop: the record checks (validate/records.py) and an
        # uneven clock's rebuild run on them, then they go (release)
        self.q.kept, self.v.kept = [], []
        self.uneven = False  # the first PERIOD_SAMPLES steps are off their median grid
        self.seconds = 0.0  # of equations folded in (decimated rows x their period)
        self.rep = SegmentReport()
        self.period_ns: float | None = None
        self.equations = np.zeros(n_j, dtype=int)  # per joint, folded in
        self.n_decimated = 0  # decimated samples folded in (before the reversal selection)
        self._pre: list[Paired] = []  # paired before the period is known
        self._steps: dict[int, int] | None = {}  # histogram of paired stamp steps (ns)
        self._last_ns: int | None = None  # last paired stamp
        self._t0_ns: int | None = None
        self._done_s = 0.0  # instant (s from t0) of the newest decimated row folded
        self._processed_ns: int | None = None
        self._stream: SegmentStream | None = None
        self._seg: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []  # before the stream
        self._seg_len = 0
        self._broken = False  # the segment under way is left out (model error)
        self.lag = lag  # the segments get a lag instrument (current_lag.LiveLagInstrument)
        self._lag: LiveLagInstrument | None = None  # the segment's, holding its first ticks
        self._still = np.zeros(n_j, dtype=int)
        self._still_warned = np.zeros(n_j, dtype=bool)
        self._silent_warned = False

    # --- input --------------------------------------------------------------------------------
    def add(self, topic: str, stamps_ns, names: Sequence[str], values) -> list[str]:
        buf = self.q if topic == "q" else self.v
        out = buf.add(stamps_ns, names, values)
        if self.q.max_ns is not None and self.v.max_ns is not None:
            ahead = (self.q.max_ns - self.v.max_ns) * 1e-9
            if abs(ahead) > SILENT_TOPIC_S and not self._silent_warned:
                self._silent_warned = True
                quiet, other = ("current_reference", "joint_states") if ahead > 0 else \
                    ("joint_states", "current_reference")
                out.append(f"{quiet}: nothing new for {abs(ahead):.1f} s of {other}: its ticks "
                           "cannot be paired (is its publisher running?)")
            elif abs(ahead) < 0.5 * SILENT_TOPIC_S:
                self._silent_warned = False
        return out

    def due(self) -> bool:
        """About ``live_block_s`` of new data on both topics since the last processing."""
        if self.q.max_ns is None or self.v.max_ns is None:
            return False
        newest = min(self.q.max_ns, self.v.max_ns)
        ref = self._processed_ns
        if ref is None:
            ref = min(x for x in (self.q.t0_ns, self.v.t0_ns, newest) if x is not None)
        return (newest - ref) * 1e-9 >= self.opts.live.live_block_s

    @property
    def lag_s(self) -> float:
        newest = max(x for x in (self.q.max_ns, self.v.max_ns, 0) if x is not None)
        if self._t0_ns is None:
            first = [x for x in (self.q.t0_ns, self.v.t0_ns) if x is not None]
            return (newest - min(first)) * 1e-9 if first else 0.0
        return max((newest - self._t0_ns) * 1e-9 - self._done_s, 0.0)

    @property
    def held_s(self) -> float:
        """Seconds of the segment under way held while its period is looked for."""
        lag = self._lag
        if lag is None or lag.repeats is not None or self.period_ns is None:
            return 0.0
        return lag.n_held * self.period_ns * 1e-9

    def process(self, final: bool = False) -> list[str]:
        """Pair what both topics have passed and run it through the segments."""
        if final:
            horizon = np.inf
        elif self.q.max_ns is None or self.v.max_ns is None:
            return []
        else:
            horizon = min(self.q.max_ns, self.v.max_ns) - self.opts.live.live_pairing_slack_s * 1e9
        self._processed_ns = max(x for x in (self.q.max_ns, self.v.max_ns, 0) if x is not None)
        tol = 0 if self.q.period_ns is None else max(int((self.q.period_ns - 1) // 2), 0)
        p = pair_upto(self.q, self.v, horizon, tol)  # as segments.pairing_tolerance_ns
        self.rep.n_paired += p.stamps_ns.shape[0]
        self.rep.n_unpaired_joint_states += p.unpaired_q
        self.rep.n_unpaired_current_reference += p.unpaired_v
        self.rep.n_duplicate_stamps += p.duplicates
        out: list[str] = []
        if self.period_ns is None:
            self._pre.append(p)
            if sum(x.stamps_ns.shape[0] for x in self._pre) < PERIOD_SAMPLES and not final:
                return out
            p = self._set_period()
            if p is None:
                return out
        self._feed(p, out)
        return out

    def close(self) -> list[str]:
        """Stop: process everything, end the last segment, check the period; warnings."""
        out = self.process(final=True)
        if self.period_ns is not None:
            self._end_segment(out)
            out += self._period_check()
            if self.rep.n_segments == 0:
                n = self.opts.observe.min_segment_samples(self.period_ns * 1e-9)
                out.append(f"{self.source}: no continuous run of {n} ticks "
                           f"({n * self.period_ns * 1e-9:.2f} s) without a gap: nothing used "
                           "from this recording")
        elif self.rep.n_paired < 2:
            out.append(f"{self.source}: only {self.rep.n_paired} joint_states/current_reference "
                       "samples share a stamp: nothing to identify from this recording")
        return out

    # --- segments -----------------------------------------------------------------------------
    def _set_period(self) -> Paired | None:
        stamps = np.concatenate([x.stamps_ns for x in self._pre])
        if stamps.shape[0] < 2:
            return None
        cat = [np.concatenate([getattr(x, k) for x in self._pre]) for k in ("q", "v_tau")]
        self._pre = []
        step = self._period_rule(stamps)
        if step <= 0:
            return None
        self.period_ns = step
        self.rep.period_s = step * 1e-9
        self.opts = self.opts.at_rate(1e9 / step)  # cut-offs in Hz, lengths in s: to samples
        return Paired(stamps, cat[0], cat[1])

    def _period_rule(self, stamps: np.ndarray) -> float:
        """The offline period (segments._breaks) of the first stamps, ns: the median step on a
        steady clock, the mean step between gaps on an uneven one (its recording observed again
        at stop; no lag instrument, as offline: a period is a number of ticks)."""
        dt = np.diff(stamps)
        med = float(np.median(dt))
        if med <= 0:
            return med
        brk, _ = find_breaks_local(dt, med)
        steps = step_stats(stamps, mean_over=~brk)
        self.uneven = steps.uneven
        if not self.uneven:
            return med
        self.lag = False  # as observe's _currents: no lag instrument on an uneven clock
        return steps.mean_s * 1e9

    def release(self) -> None:
        """The samples kept go (after the stop's checks and rebuild)."""
        self.q.kept = self.v.kept = None

    def raw_record(self) -> Record | None:
        """The samples received, as the bag holds them: a Record in the model's channels, or
        None when too few (or released)."""
        q, v = self.q.kept_samples(), self.v.kept_samples()
        if q is None or v is None or q[0].shape[0] < 2:
            return None
        names = list(self.joint_names)
        return Record(self.source, q[0], names, q[1], v[0], names, v[1], self.condition,
                      self.payload_mass, payload=self.payload)

    def adopt(self, rep: SegmentReport, equations: list[int], n_decimated: int,
              seconds: float) -> None:
        """The offline observation's account of this recording (its rebuild at stop)."""
        rep.n_duplicate_stamps = self.rep.n_duplicate_stamps  # dropped on arrival, not kept
        self.rep, self.equations = rep, np.asarray(equations, int)
        self.n_decimated, self.seconds = n_decimated, seconds
        self.period_ns = rep.period_s * 1e9

    def _feed(self, p: Paired, out: list[str]) -> None:
        s = p.stamps_ns
        if s.shape[0] == 0:
            return
        if self._t0_ns is None:
            self._t0_ns = int(s[0])
        first = self._last_ns is None
        prev = s[0] - int(round(self.period_ns)) if first else self._last_ns
        dt = np.diff(np.concatenate([[prev], s]))
        if self._steps is not None:
            steps, counts = np.unique(dt[1:] if first else dt, return_counts=True)
            for a, c in zip(steps.tolist(), counts.tolist()):
                self._steps[a] = self._steps.get(a, 0) + c
            if len(self._steps) > MAX_STEP_VALUES:  # jittery stamps: no exact median to check
                self._steps = None
        brk, missing = find_breaks(dt, self.period_ns)
        self.rep.n_missing_ticks += missing
        self.rep.n_gaps += int(brk.sum())
        self._last_ns = int(s[-1])
        cuts = np.unique(np.concatenate([[0], np.flatnonzero(brk), [s.shape[0]]]))
        for a, b in zip(cuts[:-1], cuts[1:]):
            if brk[a]:
                self._end_segment(out)
            if b > a:
                self._extend(s[a:b], p.q[a:b], p.v_tau[a:b], out)

    def _extend(self, s: np.ndarray, q: np.ndarray, v: np.ndarray, out: list[str]) -> None:
        """Consecutive ticks onto the segment under way (through its lag instrument)."""
        self._seg_len += s.shape[0]
        if self._broken:
            return
        if self.lag:
            if self._lag is None:
                self._lag = LiveLagInstrument(self.period_ns * 1e-9, len(self.joint_names))
            ticks = self._lag.push(s, q, v)
            if ticks is None:
                return
            if self._lag.repeats is False:
                self._not_repeating(out)
            s, q, v = ticks
        elif self.layout.lag_column is not None:
            v = without_instrument(v)  # the lag is left out: see LiveIdentification
        self._to_stream(s, q, v, out)

    def _to_stream(self, s: np.ndarray, q: np.ndarray, v: np.ndarray, out: list[str]) -> None:
        """Ticks into the segment's stream, made once the segment is long enough to be kept."""
        try:
            if self._stream is not None:
                self._rows(self._stream.push(s, q, v), out)
                return
            self._seg.append((s, q, v))
            if self._seg_len < self.opts.observe.min_segment_samples(self.period_ns * 1e-9):
                return
            self._stream = SegmentStream(self.model, self.layout, self.opts,
                                         self.period_ns * 1e-9, self._t0_ns, self.bound)
            parts, self._seg = self._seg, []
            self._rows(self._stream.push(*(np.concatenate(x) for x in zip(*parts))), out)
        except OrthoglideError as exc:
            self._abandon(exc, out)

    def _not_repeating(self, out: list[str]) -> None:
        """The segment under way has no period: the lag is left out of the identification
        (LiveIdentification), as offline; its later segments are not held."""
        if self._seg_len < self.opts.observe.min_segment_samples(self.period_ns * 1e-9):
            return  # too short to be used: dropped, as offline
        self.lag = False
        self.rep.n_not_repeating += 1
        t = ((self._last_ns or 0) - (self._t0_ns or 0)) * 1e-9
        out.append(f"{self.source}: the segment before t = {t:.1f} s {self._lag.why}: the "
                   "current-loop lag is left out of the identification (the paper's drive model; "
                   "lag_model: auto needs every segment to repeat its trajectory)")

    def _end_segment(self, out: list[str]) -> None:
        """A gap or the end: finish the segment under way (edge trim) or drop it if short."""
        if self._lag is not None and not self._broken:
            ticks = self._lag.finish()  # held to the end: no period
            if ticks is not None:
                self._not_repeating(out)
                self._to_stream(*ticks, out)
        stream, n = self._stream, self._seg_len
        if stream is not None and not self._broken:
            try:
                self._rows(stream.finish(), out)
                self.rep.n_segments += 1
                self.rep.n_used += n
                self.rep.n_reversal_bridged += stream.n_bridged
                self.rep.n_reversal_unbridged += stream.n_unbridged
            except OrthoglideError as exc:
                self._abandon(exc, out)
        elif n and not self._broken:
            self.rep.n_short_segments_dropped += 1
            self.rep.n_samples_in_short_segments += n
        self._stream, self._seg, self._seg_len, self._broken = None, [], 0, False
        self._lag = None
        self._still[:] = 0

    def _abandon(self, exc: OrthoglideError, out: list[str]) -> None:
        t = ((self._last_ns or 0) - (self._t0_ns or 0)) * 1e-9
        out.append(f"{self.source}: {exc} (near t = {t:.1f} s): the segment under way is left "
                   "out up to the next gap")
        self._broken, self._stream, self._seg = True, None, []

    def _rows(self, rows: DecimatedRows, out: list[str]) -> None:
        """Fold decimated rows in; watch the joints' velocities."""
        if self._stream is not None:
            self._watch_still(self._stream.last_qd, out)
        if rows.r == 0:
            return
        keep = rows.keep
        self.equations += rows.r if keep is None else keep.sum(axis=1)
        self.n_decimated += rows.r
        self._done_s = float(rows.t[-1])
        seconds = rows.r * self.opts.observe.decimation * self.period_ns * 1e-9
        self.seconds += seconds
        self._fold(self, rows, seconds)

    def _watch_still(self, qd: np.ndarray, out: list[str]) -> None:
        """Warn once per run when a joint stays below the velocity dead band ``live_still_s``."""
        db = self.opts.observe.velocity_deadband_mps
        if db <= 0 or qd.shape[0] == 0:
            return
        need = int(round(self.opts.live.live_still_s / (self.period_ns * 1e-9)))
        below = np.abs(qd) < db
        for j, name in enumerate(self.joint_names):
            moving = np.flatnonzero(~below[:, j])
            runs = np.diff(np.concatenate([[-1 - self._still[j]], moving, [qd.shape[0]]])) - 1
            longest = int(runs.max())
            self._still[j] = int(runs[-1])
            if moving.size and runs[-1] < need:
                self._still_warned[j] = False
            if longest >= need and not self._still_warned[j]:
                self._still_warned[j] = True
                t = ((self._last_ns or 0) - (self._t0_ns or 0)) * 1e-9
                unit = self.model.joints[j].unit
                out.append(f"{name} has stayed below the velocity dead band ({db:g} {unit}/s) "
                           f"for {longest * self.period_ns * 1e-9:.1f} s (before t = {t:.1f} s): "
                           f"its equations there are left out; the trajectory does not excite "
                           f"{name}")

    # --- end of recording ---------------------------------------------------------------------
    def _period_check(self) -> list[str]:
        """The offline pipeline's period (median step over the record) against the one used
        (an uneven clock's recording is observed again with the offline one: nothing to say)."""
        if not self._steps or self.uneven:
            return []
        steps = np.array(sorted(self._steps))
        counts = np.array([self._steps[s] for s in steps])
        n = int(counts.sum())
        if n <= 0:
            return []
        cum = np.cumsum(counts)
        lo = steps[np.searchsorted(cum, (n - 1) // 2 + 1)]
        hi = steps[np.searchsorted(cum, n // 2 + 1)]
        median = 0.5 * (lo + hi)
        if median == self.period_ns:
            return []
        return [f"{self.source}: the tick period over the whole record is {median:.0f} ns but "
                f"{self.period_ns:.0f} ns was used from its first {PERIOD_SAMPLES} ticks: an "
                "offline identification of the same data may differ slightly"]

    def steps(self) -> StepStats | None:
        """The paired stamps' step distribution so far (as ``info`` gives it): the offline
        one once rebuilt, else from the histogram of steps (None: jittery stamps, or none)."""
        if self.rep.steps is not None:
            return self.rep.steps
        if not self._steps or self.period_ns is None:
            return None
        steps = np.array(sorted(self._steps), float)
        counts = np.array([self._steps[int(x)] for x in steps])
        cum, n = np.cumsum(counts), int(counts.sum())

        def at(share: float) -> float:
            return float(steps[min(np.searchsorted(cum, share * n), steps.size - 1)]) * 1e-9

        med = at(0.5)
        ratio = steps / self.period_ns
        even = (ratio > BREAK_LOW) & (ratio < BREAK_HIGH)
        mean = float(np.sum(steps[even] * counts[even]) / max(counts[even].sum(), 1)) * 1e-9
        off = float(counts[np.abs(steps * 1e-9 - med) > OFF_GRID_TOL * med].sum() / n)
        return StepStats(n, med, mean or med, at(0.05), at(0.95), off)

    def samples_line(self) -> str:
        """What ``info`` says of a bag, of this recording so far: samples in, paired, used (in
        segments long enough), the step distribution."""
        used = self.rep.n_used + (self._seg_len if self._stream is not None else 0)
        line = (f"{self.condition} {self.q.counts.received} samples in, {self.rep.n_paired} "
                f"paired, {used} used")
        st = self.steps()
        return line + (f"; {st.describe()}" if st is not None and st.n_steps else "")

    def report(self) -> RecordReport:
        """This recording's entry of the result's ``diagnostics.bags`` (as offline's)."""
        self.rep.n_joint_states = self.q.counts.received
        self.rep.n_current_reference = self.v.counts.received
        self.rep.n_nonfinite_dropped = self.q.counts.nonfinite + self.v.counts.nonfinite
        return bag_report(self.rep, self.source, self.condition, self.payload_mass,
                          [int(x) for x in self.equations])
