"""The ctc's feed-forward schedule (orthoglide_ident/feedforward_schedule.py) on invented clocks:
which ticks are computed together, that each is computed ahead of its tick, and the one message
with its cause when the ctc falls behind. No wall-clock timing: "now" is given."""
from __future__ import annotations

import numpy as np
import pytest

from orthoglide_ident.feedforward_schedule import FeedforwardSchedule
from orthoglide_ident.ticks import TICK_NS

T0 = 1_764_000_000_000_000_000  # a system-clock stamp (ns)
MS = 1_000_000


def _ref(k: int) -> np.ndarray:
    return np.full((3, 2), float(k))  # q_d = qd_d = qdd_d = k: says which tick it is


def _drive(schedule: FeedforwardSchedule, n: int, lead: int, wake: int, wait: int = 0,
           t0: int = T0):
    """Setpoint k published at t_k - lead ticks (t_k = t0 + k ticks), taken in wake-ups every
    ``wake`` ticks, each take handled ``wait`` ticks after its wake-up. Returns [(now, run)]
    and the messages."""
    out, said, k_next = [], [], 0
    for w in range(-lead, n + wake, wake):  # tick 0 is published lead ticks before it
        now = t0 + w * TICK_NS
        for k in range(k_next, min(n, w + 1 + lead)):  # published by now, not taken yet
            schedule.add(t0 + k * TICK_NS, _ref(k), received_ns=now)
            k_next = k + 1
        now += wait * TICK_NS
        for run in schedule.take(now):
            out.append((now, run))
            msg = schedule.sent(run.stamps, now)
            if msg:
                said.append(msg)
    return out, said


def test_every_tick_once_for_the_right_tick_and_ahead_of_it():
    sched = FeedforwardSchedule(batch=10, margin_ns=10 * MS)
    runs, said = _drive(sched, n=500, lead=50, wake=5)
    stamps = np.concatenate([r.stamps for _, r in runs])
    # every tick but the last (which waits for a successor that never comes), once, in order
    assert np.array_equal(stamps, T0 + np.arange(499) * TICK_NS)
    for i, (now, run) in enumerate(runs):
        k = (run.stamps - T0) // TICK_NS
        assert np.array_equal(run.ref[:, 0, 0], np.append(k, k[-1] + 1))  # its setpoints + the next
        assert len(run.stamps) >= 10 or i == len(runs) - 1  # batched (the end: what is left)
        assert np.all(run.stamps - now >= 10 * MS)  # well ahead of each tick
    assert said == [] and sched.total.short == 0 and sched.total.late == 0
    assert sched.total.sent == 499


def test_a_tick_due_soon_is_computed_at_once_whatever_the_batch():
    sched = FeedforwardSchedule(batch=100, margin_ns=10 * MS)
    runs, said = _drive(sched, n=300, lead=20, wake=5)
    assert runs and all(len(r.stamps) < 100 for _, r in runs)  # the batch never waited for 100
    stamps = np.concatenate([r.stamps for _, r in runs])
    assert np.array_equal(stamps, T0 + np.arange(299) * TICK_NS)
    assert said == []  # setpoints 20 ms ahead, taken within 5: never under the 10 ms margin


def test_late_setpoints_are_reported_once_with_their_cause():
    sched = FeedforwardSchedule(batch=10, margin_ns=10 * MS)
    _, said = _drive(sched, n=300, lead=4, wake=2)
    assert len(said) == 1, said
    assert "setpoint arrived only" in said[0] and "setpoint_lead" in said[0]
    assert sched.total.sent == 299 and sched.total.short > 250


def test_a_ctc_that_waits_is_reported_as_waiting_and_again_after_recovering():
    sched = FeedforwardSchedule(batch=10, margin_ns=10 * MS)
    _, said = _drive(sched, n=200, lead=50, wake=5, wait=40)  # setpoints in time, handled late
    assert len(said) == 1 and "waited" in said[0] and "not scheduled" in said[0]
    assert sched.total.late == 0 and sched.total.short > 0
    later = T0 + 1_000 * TICK_NS
    _, said_ok = _drive(sched, n=200, lead=50, wake=5, t0=later)  # ahead again: quiet
    assert said_ok == []
    _, said_soon = _drive(sched, n=100, lead=50, wake=5, wait=44, t0=later + 1_000 * TICK_NS)
    assert said_soon == []  # a new fall within 10 s of the message: counted, not said
    _, said_again = _drive(sched, n=100, lead=50, wake=5, wait=44, t0=later + 20_000 * TICK_NS)
    assert len(said_again) == 1  # later: said again


def test_a_tick_before_a_gap_is_dropped_not_computed_with_another_reference():
    sched = FeedforwardSchedule(batch=1, margin_ns=0)
    for k in (0, 1, 2, 5, 6):
        sched.add(T0 + k * TICK_NS, _ref(k), T0 - 50 * MS)
    runs = sched.take(T0 - 40 * MS)
    assert [list((r.stamps - T0) // TICK_NS) for r in runs] == [[0, 1], [5]]
    assert sched.total.dropped == 1  # tick 2: its successor 3 never came
    assert sched.pending() == 1  # tick 6 waits for 7


def test_a_simulated_clock_batches_without_deadlines():
    sched = FeedforwardSchedule(batch=10, margin_ns=10 * MS)
    for k in range(5):
        sched.add(k * TICK_NS, _ref(k), received_ns=T0)  # stamps from 0: not the system clock
    assert sched.take(T0) == []  # 4 ready < batch, and no deadline to hurry for
    for k in range(5, 12):
        sched.add(k * TICK_NS, _ref(k), received_ns=T0)
    run, = sched.take(T0)
    assert len(run.stamps) == 11 and sched.sent(run.stamps, T0) is None


def test_the_last_ticks_of_a_stream_go_out_as_they_near_without_more_setpoints():
    """Fewer than a batch ready and no setpoint after them (the controller stopped, or a pause):
    the wake-ups alone (the ctc's intake wakes every margin) send them ahead of their tick."""
    sched = FeedforwardSchedule(batch=20, margin_ns=10 * MS)
    for k in range(7):
        sched.add(T0 + k * TICK_NS, _ref(k), received_ns=T0 - 50 * MS)
    sent = []
    for now in range(T0 - 50 * MS, T0 + 1, 10 * MS):  # wake-ups every margin, nothing new
        for run in sched.take(now):
            sent.append((now, run.stamps))
    (now, stamps), = sent
    assert np.array_equal(stamps, T0 + np.arange(6) * TICK_NS)  # 6 has no successor yet
    assert T0 - now >= 10 * MS  # still ahead by the margin


def test_the_lead_statistics_min_and_median_in_bounded_memory():
    sched = FeedforwardSchedule(batch=10, margin_ns=10 * MS)
    _drive(sched, n=2000, lead=50, wake=5)  # taken every 5 ms, 50 ms ahead: leads 40..50 ms
    lead_min, lead_median = sched.total.lead_ms()
    runs, _ = _drive(FeedforwardSchedule(batch=10, margin_ns=10 * MS), n=2000, lead=50, wake=5)
    leads = np.concatenate([r.stamps - now for now, r in runs]) * 1e-6
    assert lead_min == leads.min() and abs(lead_median - np.median(leads)) <= 0.05  # 0.1 ms bins
    assert (
        f"lead at sending min {leads.min():.1f} / median {lead_median:.1f} ms"
        in sched.total.summary()
    )
    size = sched.total.histogram.nbytes
    _drive(sched, n=20_000, lead=50, wake=5, t0=T0 + 10**10)
    assert sched.total.histogram.nbytes == size and sched.total.sent == 1999 + 19_999
    window = FeedforwardSchedule(batch=10, margin_ns=10 * MS).stats
    window.merge(sched.total)
    assert window.lead_ms() == sched.total.lead_ms() and window.sent == sched.total.sent


def test_bad_settings_are_refused():
    with pytest.raises(ValueError):
        FeedforwardSchedule(batch=0, margin_ns=0)
