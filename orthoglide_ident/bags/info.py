"""``orthoglide-ident info BAG``: what a bag holds, whether it was closed, missing ticks."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from orthoglide_ident.errors import BagError
from orthoglide_ident.ticks import (
    BREAK_HIGH,
    BREAK_LOW,
    LOCAL_STEPS,
    OFF_GRID_TOL,
    ON_GRID,
    UNEVEN_SHARE,
    StepStats,
    find_breaks_local,
    step_stats,
)

from ._tags import BagTags
from .reader import FileStatus, _scan_bag
from .sources import BagSources, choose_sources


@dataclass
class Gaps:
    """Missing ticks in a topic's header stamps, against its median period."""

    period_s: float
    missing: int
    where: list[tuple[float, int]] = field(
        default_factory=list
    )  # (s after first stamp, ticks missing)
    steps: StepStats | None = None  # the step distribution (uneven clocks)


def find_gaps(stamps_ns: np.ndarray, period_ns: float | None = None, limit: int = 10) -> Gaps:
    """Missing ticks against the local step (ticks.find_breaks_local; on a steady clock the
    median period, or ``period_ns``), and the step distribution."""
    if len(stamps_ns) < 2:
        return Gaps(0.0, 0)
    d = np.diff(stamps_ns)
    period = float(period_ns or np.median(d))
    if period <= 0:
        return Gaps(0.0, 0)
    brk, missing = find_breaks_local(d, period)
    at = np.flatnonzero(brk & (d > period))
    k = np.rint(d[at] / period).astype(np.int64) - 1
    where = [(float((stamps_ns[i] - stamps_ns[0]) / 1e9), int(n)) for i, n in zip(at[:limit], k)]
    steps = step_stats(stamps_ns, mean_over=~brk)
    return Gaps(period / 1e9, missing, where, steps)


@dataclass
class TopicInfo:
    topic: str
    msgtype: str
    count: int
    rate_hz: float
    gaps: Gaps | None = None


@dataclass
class BagInfo:
    path: Path
    files: list[FileStatus]
    topics: list[TopicInfo]
    start_ns: int
    duration_s: float
    tags: BagTags | None
    tag_problem: str
    warnings: list[str]
    sources: BagSources | None = None
    source_problem: str = ""
    incomplete: str = ""  # orthoglide.incomplete: why the recording stopped early ("" if complete)

    def step_warnings(self) -> list[str]:
        """One warning per topic whose stamps are on an uneven clock."""
        out = []
        for t in self.topics:
            s = None if t.gaps is None else t.gaps.steps
            if s is not None and s.uneven:
                out.append(f"{t.topic}: uneven steps ({100 * s.off_grid:.1f} % more than 2 % off "
                           f"the median {s.median_s * 1e3:.3f} ms; mean rate {1 / s.mean_s:.1f} "
                           "Hz): identification uses each sample's own stamp, never the median "
                           "as the period")
        return out

    @property
    def closed(self) -> bool:
        return all(f.closed for f in self.files)

    def to_text(self) -> str:
        """Human-readable summary, as printed by ``orthoglide-ident info``."""
        lines = [f"bag:       {self.path}"]
        if self.tags is not None:
            lines.append(f"tag:       {self.tags.describe()}")
        else:
            lines.append(f"tag:       NONE: {self.tag_problem}")
        if self.incomplete:
            lines.append(f"INCOMPLETE: {self.incomplete}")
        if self.sources is not None:
            lines.append(f"q:         {self.sources.position.describe()}")
            lines.append(f"current:   {self.sources.current.describe()}")
        else:
            lines.append(f"sources:   NONE: {self.source_problem}")
        lines.append(f"duration:  {self.duration_s:.3f} s   start: {self.start_ns / 1e9:.9f} s")
        lines.append("files:")
        for f in self.files:
            state = "closed" if f.closed else f"NOT CLOSED ({f.lost})"
            lines.append(
                f"  {f.path.name:<28} {f.size / 1e6:9.2f} MB  {f.chunks:5d} chunks "
                f"{f.messages:9d} msgs  {state}"
            )
        lines.append("topics:")
        for t in self.topics:
            lines.append(f"  {t.topic:<36} {t.msgtype:<38} {t.count:9d} msgs {t.rate_hz:9.1f} Hz")
            if t.gaps is not None:
                g = t.gaps
                if g.steps is not None and g.steps.n_steps:
                    lines.append(f"    {g.steps.describe()}")
                if g.missing:
                    where = ", ".join(f"{n} at {s:.3f} s" for s, n in g.where)
                    more = " …" if len(g.where) < g.missing and len(g.where) >= 10 else ""
                    lines.append(
                        f"    {g.missing} missing ticks (period {g.period_s * 1e3:.3f} ms): "
                        f"{where}{more}"
                    )
                elif g.steps is not None and g.steps.uneven:
                    lines.append("    no missing ticks (against the local step)")
                else:
                    lines.append(f"    no missing ticks (period {g.period_s * 1e3:.3f} ms)")
        lines += [f"warning: {w}" for w in self.warnings + self.step_warnings()]
        return "\n".join(lines)


def bag_info(path: str | Path) -> BagInfo:
    """Summarise a bag directory or lone .mcap file (BagError if it is unreadable).

    Start and duration are those of the controller ticks (header stamps of the joint-state
    topics) when the bag has them; of the log (receive) times otherwise. Mixing the two made the
    duration depend on how late the last message of another topic arrived. ``sources``: where q
    and the current would be read from (None, with the reason, when the bag has none).
    """
    scan = _scan_bag(path, decode=True)
    topics = []
    ticks: list[tuple[int, int]] = []  # (first, last) header stamp of each decoded topic
    logged: list[tuple[int, int]] = []  # (first, last) log time of every topic
    for s in scan.topics.values():
        st = s.stamps_ns if s.decoded else None
        if st is not None and len(st):
            ticks.append((int(st[0]), int(st[-1])))
        if s.count:
            logged.append((s.log_start, s.log_end))
        if st is not None and len(st) > 1:  # header stamps (controller ticks); receipt is bursty
            span = (int(st[-1]) - int(st[0])) / 1e9
            rate = (len(st) - 1) / span if span > 0 else 0.0
        else:
            span = (s.log_end - s.log_start) / 1e9 if s.count > 1 else 0.0
            rate = (s.count - 1) / span if span > 0 else 0.0
        gaps = find_gaps(st) if st is not None and len(st) > 1 else None
        topics.append(TopicInfo(s.topic, s.msgtype, s.count, rate, gaps))
    try:
        sources, source_problem = choose_sources(scan.topics, scan.path, tags=scan.tags), ""
    except BagError as exc:
        sources, source_problem = None, str(exc)
    spans = ticks or logged
    start = min((a for a, _ in spans), default=0)
    duration = (max(b for _, b in spans) - start) / 1e9 if spans else 0.0
    return BagInfo(scan.path, scan.files, topics, start, duration, scan.tags, scan.tag_problem,
                   scan.warnings, sources, source_problem, scan.incomplete)


class TickCounter:
    """Streaming count of missing samples from header stamps (the recorder's live loss count):
    the rule of ``info`` (ticks.find_breaks_local) on the source's own step distribution, each
    step judged against the median of the LOCAL_STEPS steps around it, so a ~100 Hz logger on
    its own 10/12/14 ms clock is not 90 % missing against a 1 kHz tick. Where the local median
    is within ON_GRID of ``rate_hz``'s period (a 1 kHz controller), ticks of that period are
    counted (ticks.find_breaks). A step is judged once LOCAL_STEPS // 2 later steps are in;
    :meth:`finish` judges the last ones (the window reflected at the end, as find_breaks_local).
    Memory: the last LOCAL_STEPS steps, whatever the recording's length."""

    def __init__(self, rate_hz: float) -> None:
        self.period_ns = 1e9 / rate_hz if rate_hz > 0 else 0.0
        self.first: int | None = None
        self.last: int | None = None
        self.missing = 0  # in the steps judged so far
        self.backwards = 0
        self.n_steps = 0
        self.span_ns = 0.0  # sum of the steps that are not breaks (for the mean rate) ...
        self.n_even = 0  # ... and their number
        self.median_ns = 0.0  # the latest local median step
        self.off_grid = 0  # steps judged more than OFF_GRID_TOL off their local median
        self._ctx = np.empty(0)  # the last (up to) LOCAL_STEPS // 2 steps judged
        self._pending: list[float] = []  # steps not judged yet
        self._judged = 0

    def add(self, stamp_ns: int) -> None:
        last, self.last = self.last, stamp_ns
        if last is None:
            self.first = stamp_ns
            return
        d = stamp_ns - last
        self.backwards += d <= 0
        self._pending.append(float(d))
        if len(self._pending) >= 2 * LOCAL_STEPS:  # judged in batches: vectorised medians
            self._judge(final=False)

    def finish(self) -> None:
        """Judge every step still pending (the end of the recording)."""
        self._judge(final=True)

    def _judge(self, final: bool) -> None:
        half = LOCAL_STEPS // 2
        pend = np.asarray(self._pending, float)
        if self._judged == 0 and pend.size < LOCAL_STEPS:
            if final and pend.size:  # too short for a window: the median step (as find_gaps)
                self._count(pend, np.full(pend.size, float(np.median(pend))))
                self._pending = []
            return
        left = pend[half:0:-1] if self._judged == 0 else self._ctx  # reflected at the start
        real = pend if self._judged == 0 else np.concatenate([self._ctx, pend])
        right = real[-2:-half - 2:-1] if final else np.empty(0)  # ... and at the end
        full = np.concatenate([left, pend, right])
        n = pend.size if final else pend.size - half
        if n <= 0:
            return
        local = np.median(np.lib.stride_tricks.sliding_window_view(full[:n + 2 * half],
                                                                   LOCAL_STEPS), axis=1)
        self._count(pend[:n], local)
        self._ctx = np.concatenate([left, pend[:n]])[-half:]
        self._pending = list(pend[n:])

    def _count(self, dt: np.ndarray, local: np.ndarray) -> None:
        """Missing samples in steps ``dt`` judged against their local medians ``local``."""
        if self.period_ns:  # the controller's own tick where the source keeps it
            on_tick = np.abs(local / self.period_ns - 1.0) <= ON_GRID
            local = np.where(on_tick, self.period_ns, local)
        ratio = dt / np.where(local > 0, local, 1.0)
        brk = (ratio < BREAK_LOW) | (ratio > BREAK_HIGH)
        self.missing += int(np.sum(np.maximum(np.rint(ratio[brk]) - 1, 0)))
        self._judged += dt.size
        self.n_steps += dt.size
        self.span_ns += float(np.sum(dt[~brk]))
        self.n_even += int(np.sum(~brk))
        self.off_grid += int(np.sum(np.abs(dt - local) > OFF_GRID_TOL * local))
        self.median_ns = float(local[-1])

    @property
    def on_tick(self) -> bool:
        """The source ticks at ``rate_hz`` (its local step on that period's grid)."""
        return bool(self.period_ns) and abs(self.median_ns / self.period_ns - 1.0) <= ON_GRID

    def describe(self) -> str:
        """'against its own step (median 12.000 ms, mean 93.4 Hz, uneven: 66.7 % off the median)'
        or 'against 1000 Hz ticks'."""
        if not self.n_steps:
            return "no steps yet"
        if self.on_tick:
            return f"against {1e9 / self.period_ns:g} Hz ticks"
        rate = self.n_even / self.span_ns * 1e9 if self.span_ns > 0 else 0.0
        share = self.off_grid / self.n_steps
        even = (f"uneven: {100 * share:.1f} % off the local median" if share > UNEVEN_SHARE
                else "even")
        return (f"against its own step (median {self.median_ns * 1e-6:.3f} ms, mean "
                f"{rate:.1f} Hz, {even})")
