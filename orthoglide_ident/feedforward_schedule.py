"""When the ctc computes each tick's feed-forward, and what it says when it falls behind.

The controller publishes each setpoint ``setpoint_lead`` ticks before its tick (50 ms by
default); the model feed-forward of tick k (control.feedforward_currents: the reference in the
middle of tick k, so it needs the setpoint of k + 1 too) must reach the controller before tick k,
or the controller's PID runs that tick on the feed-forward of another one (the driver holds the
previous one). :class:`FeedforwardSchedule` decides which ticks are computed together:

- a tick is *ready* once its successor's setpoint is in; ready ticks are computed in batches of
  at least ``batch`` (one vectorised model call), and at once, whatever their number, when the
  earliest is due within twice ``margin_ns`` — so batching never costs lateness;
- a tick whose successor will never come (a later setpoint skips it) is dropped: no feed-forward
  is better than one of the wrong reference;
- every tick sent is accounted for: its lead (stamp − now at sending) and, for the first tick
  sent less than ``margin_ns`` ahead, one message with the cause — the setpoint itself arrived
  late (the controller's lead or the transport), or it waited in the ctc (its thread not
  scheduled, or the model call slow) — said once; a later fall, after the ctc was ahead again,
  at most every 10 s (on a busy machine it comes and goes; the node's periodic log counts every
  tick sent late).

Stamps are the controller's tick times on the system clock (the driver in real time, a
ros2_control controller manager); ``now_ns`` is the same clock (time.time_ns()). Stamps far
from it (a simulated clock) switch the deadline rules off: batches of ``batch`` only.
No ROS here: the ctc node (nodes/ctc.py) feeds it; tests drive it with invented clocks.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from orthoglide_ident.ticks import TICK_NS

WALL_CLOCK_NS = 3_600_000_000_000  # stamps further than 1 h from now are not the system clock
REPEAT_NS = 10_000_000_000  # a new fall is said at most this often (the periodic log counts all)


@dataclass
class Run:
    """Consecutive ticks to compute together: ``stamps`` (n,) ns of the ticks, ``ref``
    (n + 1, 3, n_j) their setpoints (q_d, q̇_d, q̈_d) and the next tick's."""

    stamps: np.ndarray
    ref: np.ndarray


# the leads are counted in 0.1 ms bins (a bounded memory however long it runs)
LEAD_BIN_NS = 100_000
# 0 .. 0.5 s ahead; a late tick counts in the first bin, a longer lead in the last
LEAD_BINS = 5_000


@dataclass
class LeadStats:
    """Feed-forward ticks sent, their lead at sending (stamp − now) and the late ones, since
    ``reset``; the leads as their exact minimum and a histogram of 0.1 ms bins (the median)."""

    sent: int = 0
    late: int = 0  # sent after their tick had started (useless to the controller)
    short: int = 0  # sent less than the margin ahead
    dropped: int = 0  # never computed: the next tick's setpoint never came
    lead_min_ns: int | None = None
    histogram: np.ndarray = field(default_factory=lambda: np.zeros(LEAD_BINS, np.int64))

    def add(self, lead_ns: np.ndarray, short: np.ndarray) -> None:
        self.sent += int(lead_ns.size)
        self.late += int(np.sum(lead_ns <= 0))
        self.short += int(np.sum(short))
        if lead_ns.size:
            low = int(lead_ns.min())
            self.lead_min_ns = low if self.lead_min_ns is None else min(self.lead_min_ns, low)
            bins = np.clip(lead_ns // LEAD_BIN_NS, 0, LEAD_BINS - 1)
            self.histogram += np.bincount(bins, minlength=LEAD_BINS)

    def merge(self, other: LeadStats) -> None:
        """Add ``other``'s counts (a longer window from shorter ones)."""
        self.sent += other.sent
        self.late += other.late
        self.short += other.short
        self.dropped += other.dropped
        if other.lead_min_ns is not None:
            self.lead_min_ns = other.lead_min_ns if self.lead_min_ns is None else min(
                self.lead_min_ns, other.lead_min_ns)
        self.histogram += other.histogram

    def lead_ms(self) -> tuple[float, float] | None:
        """(min, median) lead in ms of the ticks sent on the system clock, None if none: the
        median to the 0.1 ms bin (its middle)."""
        n = int(self.histogram.sum())
        if not n:
            return None
        k = int(np.searchsorted(np.cumsum(self.histogram), (n + 1) / 2))
        return self.lead_min_ns * 1e-6, (k + 0.5) * LEAD_BIN_NS * 1e-6

    def summary(self) -> str:
        if not self.sent:
            return "no feed-forward sent"
        text = f"{self.sent} ticks sent"
        lead = self.lead_ms()
        if lead is not None:
            text += f", lead at sending min {lead[0]:.1f} / median {lead[1]:.1f} ms"
        return text + f", {self.short} less than the margin ahead, {self.late} late" + (
            f", {self.dropped} dropped (no next setpoint)" if self.dropped else "")


class FeedforwardSchedule:
    """Pending setpoints -> runs of ticks to compute now; accounting of what was sent."""

    def __init__(self, batch: int, margin_ns: int, tick_ns: int = TICK_NS):
        if batch < 1 or margin_ns < 0:
            raise ValueError(f"batch >= 1 and margin >= 0 needed, got {batch}, {margin_ns}")
        self.batch, self.margin_ns, self.tick_ns = batch, margin_ns, tick_ns
        self._ref: dict[int, np.ndarray] = {}  # stamp -> (3, n_j)
        self._arrived: dict[int, int] = {}  # stamp -> receive time (ns)
        self.stats = LeadStats()
        self.total = LeadStats()  # since start
        self._behind = False  # a "falling behind" message was given and not yet cleared
        self._said_ns: int | None = None  # when the last one was given

    def add(self, stamp_ns: int, ref: np.ndarray, received_ns: int) -> None:
        """The setpoint (3, n_j) of tick ``stamp_ns``, received at ``received_ns``."""
        self._ref[int(stamp_ns)] = np.asarray(ref, float)
        self._arrived[int(stamp_ns)] = int(received_ns)

    def pending(self) -> int:
        return len(self._ref)

    def _wall_clock(self, stamp: int, now_ns: int) -> bool:
        return abs(stamp - now_ns) < WALL_CLOCK_NS

    def take(self, now_ns: int) -> list[Run]:
        """The runs to compute now (see the module doc); their ticks leave the schedule."""
        if len(self._ref) < 2:
            return []
        stamps = np.array(sorted(self._ref), dtype=np.int64)
        gaps = np.flatnonzero(np.diff(stamps) != self.tick_ns)
        runs = np.split(stamps, gaps + 1)
        ready = sum(len(r) - 1 for r in runs)
        first = int(stamps[0])
        urgent = self._wall_clock(first, now_ns) and first - now_ns <= 2 * self.margin_ns
        out: list[Run] = []
        if ready >= self.batch or (urgent and ready):
            for r in runs:
                if len(r) > 1:
                    out.append(Run(r[:-1], np.stack([self._ref[int(t)] for t in r])))
            for s in (self.stats, self.total):  # a run's last tick before a gap: no successor
                s.dropped += len(runs) - 1
            for r in runs[:-1]:
                self._arrived.pop(int(r[-1]), None)
            keep = int(stamps[-1])  # the newest waits for its successor
            for t in stamps[:-1]:
                if int(t) != keep:
                    del self._ref[int(t)]
        return out

    def sent(self, stamps: np.ndarray, now_ns: int) -> str | None:
        """Account for feed-forward of ``stamps`` sent at ``now_ns``; the one-line reason the
        first time ticks go out less than the margin ahead (None otherwise)."""
        stamps = np.asarray(stamps, dtype=np.int64)
        arrived = np.array([self._arrived.pop(int(t), now_ns) for t in stamps], dtype=np.int64)
        if not stamps.size or not self._wall_clock(int(stamps[0]), now_ns):
            for s in (self.stats, self.total):
                s.sent += int(stamps.size)
            return None
        lead = stamps - now_ns
        short = lead < self.margin_ns
        for s in (self.stats, self.total):
            s.add(lead, short)
        if not short.any():
            self._behind = False  # ahead again: a next fall is reported again
            return None
        if self._behind or (self._said_ns is not None and now_ns - self._said_ns < REPEAT_NS):
            return None
        self._behind, self._said_ns = True, now_ns
        k = int(np.argmax(short))
        return self._cause(int(stamps[k]), int(arrived[k]), now_ns)

    def _cause(self, stamp: int, arrived: int, now_ns: int) -> str:
        ms = 1e-6
        at_arrival, waited = (stamp - arrived) * ms, (now_ns - arrived) * ms
        head = (
            f"falling behind: the feed-forward of tick {stamp} went out "
            f"{(stamp - now_ns) * ms:.1f} ms before its tick (margin {self.margin_ns * ms:.0f} ms)"
        )
        if at_arrival < self.margin_ns * ms:
            return (f"{head}: its setpoint arrived only {at_arrival:.1f} ms ahead (the "
                    "controller's setpoint_lead is too short, or the setpoints are delayed on "
                    "their way)")
        return (f"{head}: its setpoint arrived {at_arrival:.1f} ms ahead but waited "
                f"{waited:.1f} ms in the ctc (its thread was not scheduled in time: a busy "
                "machine; see the ctc's CPU in its periodic log)")

    def reset_stats(self) -> LeadStats:
        """The stats since the last reset (for a periodic log), and start anew."""
        out, self.stats = self.stats, LeadStats()
        return out
