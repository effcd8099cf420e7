"""Ticks computed ahead (orthoglide_sim.common.ticks_ahead) are the very ticks of a tick-by-tick
run:
the same states, currents, noise, setpoints and counters, under pid and under ctc with
feed-forwards that come early, short and late; a change applies from the first tick not yet
computed; a fault ends the ticks handed out at the tick that caused it. The driver node's order
is replayed without a clock: refill after a tick is out, inputs arriving, take at the deadline."""
from __future__ import annotations

import numpy as np

from orthoglide_sim.common.ticks_ahead import TicksAhead
from orthoglide_sim.orthoglide.session import DriverSession


def _by_tick(s: DriverSession, n: int, arrivals: dict[int, list] | None = None) -> dict:
    """Tick by tick, as the driver ran before: the inputs arrived by tick k, then tick k."""
    out = {"k": [], "q": [], "v": [], "sp": []}
    for k in range(n):
        for k_for, ff in (arrivals or {}).get(k, []):
            s.offer_feedforward(k_for, ff)
        out["sp"].append((k + s.lead, s.setpoint(k + s.lead)))
        q, v = s.step()
        out["k"].append(k)
        out["q"].append(q)
        out["v"].append(v)
    return out


def _ahead(s: DriverSession, n: int, arrivals: dict[int, list] | None = None, block: int = 10,
           refills: list | None = None) -> dict:
    """The driver's order: refill once the computed ticks are out (before sleeping to tick k),
    the inputs that arrive until tick k's deadline, then take tick k."""
    ahead = TicksAhead(s, block)
    out = {"k": [], "q": [], "v": [], "sp": []}
    for k in range(n):
        before = len(ahead.ticks)
        ahead.refill(until=n)
        if refills is not None and not before and ahead.ticks:
            refills.append((k, len(ahead.ticks)))
        for k_for, ff in (arrivals or {}).get(k, []):
            s.offer_feedforward(k_for, ff)
        tick = ahead.take()
        out["sp"] += ahead.take_setpoints()
        out["k"].append(tick.k)
        out["q"].append(tick.q_meas)
        out["v"].append(tick.v_tau)
    return out


def _same(a: dict, b: dict) -> None:
    assert a["k"] == b["k"]
    np.testing.assert_array_equal(np.array(a["q"]), np.array(b["q"]))
    np.testing.assert_array_equal(np.array(a["v"]), np.array(b["v"]))
    assert [k for k, _ in a["sp"]] == [k for k, _ in b["sp"]]
    np.testing.assert_array_equal(
        np.array([sp for _, sp in a["sp"]]), np.array([sp for _, sp in b["sp"]])
    )


def test_pid_ticks_computed_in_blocks_are_the_tick_by_tick_ones():
    runs = [
        DriverSession(payload="1.983", trajectory="exciting", controller="pid", seed=3)
        for _ in range(2)
    ]
    refills: list = []
    _same(_ahead(runs[0], 95, refills=refills), _by_tick(runs[1], 95))
    assert refills[:3] == [(0, 10), (10, 10), (20, 10)]  # ten at a time, once every ten ticks
    assert refills[-1] == (90, 5)  # none past the run's end
    assert runs[0].stats == runs[1].stats and runs[0].k == runs[1].k == 95


def _feedforwards(n: int, late: set[int], short: set[int]) -> dict[int, list]:
    """ff of tick j arrives at tick j - 40 in batches of 10 (as the ctc sends them), at j - 2
    (short) for ``short``, after its tick (too late: held) for ``late``."""
    arrivals: dict[int, list] = {}
    for j in range(n):
        ff = np.array([1e-3, -2e-3, 3e-3]) * np.sin(0.01 * j)
        at = j + 1 if j in late else j - 2 if j in short else (j - 40) // 10 * 10
        arrivals.setdefault(max(at, 0), []).append((j, ff))
    return arrivals


def test_ctc_ticks_are_computed_ahead_only_with_their_feed_forward_in():
    n, late, short = 200, {57, 58, 120}, {90, 91, 92, 150}
    arrivals = _feedforwards(n, late, short)
    runs = [DriverSession(trajectory="test1", controller="ctc", seed=1) for _ in range(2)]
    refills: list = []
    _same(_ahead(runs[0], n, arrivals, refills=refills), _by_tick(runs[1], n, arrivals))
    assert runs[0].stats == runs[1].stats
    assert (runs[0].stats.ff_missing, runs[0].stats.ff_used) == (3, n - 3)  # the late ones: held
    computed_ahead = {k for k0, m in refills for k in range(k0, k0 + m)}
    assert not computed_ahead & late  # those were computed at their own deadline (held)
    assert len(computed_ahead) > 0.9 * n


def test_external_control_is_never_computed_ahead():
    s = DriverSession(trajectory="test1", controller="external", noise=False)
    ahead = TicksAhead(s, 10)
    ahead.refill()
    assert not ahead.ticks
    assert ahead.take().k == 0 and s.k == 1


def test_a_change_applies_from_the_first_tick_not_yet_computed():
    s = DriverSession(payload="none", trajectory="exciting", controller="pid", noise=False)
    ahead = TicksAhead(s, 10)
    ahead.refill()
    ahead.take()  # tick 0 out, ticks 1..9 computed
    s.set_current_limit(0.01)  # from tick 10 on
    v = [ahead.take().v_tau for _ in range(9)]
    ahead.refill()
    v += [ahead.take().v_tau for _ in range(10)]
    assert np.abs(np.array(v[:9])).max() > 0.01
    assert np.abs(np.array(v[9:])).max() <= 0.01


def test_a_fault_ends_the_ticks_at_the_one_that_caused_it():
    s = DriverSession(payload="none", trajectory="exciting", controller="pid", noise=False,
                      current_limit=50.0)
    ahead = TicksAhead(s, 10)
    # full current on one axis: off the stroke
    s.pid.current = lambda *args: np.array([50.0, 0.0, 0.0])
    ks = []
    for _ in range(200):
        ahead.refill()
        if s.fault and not ahead.ticks:
            break
        ks.append(ahead.take().k)
    assert s.fault and "stroke" in s.fault
    # the last one out is the tick that stopped it
    assert ks == list(range(len(ks))) and s.k == ks[-1]


def test_a_refused_input_stops_the_plant_after_the_ticks_already_computed():
    s = DriverSession(trajectory="test1", controller="ctc", noise=False)
    ahead = TicksAhead(s, 10)
    for k in range(10):
        s.offer_feedforward(k, np.zeros(3))
    ahead.refill()
    s.offer_feedforward(12, [float("nan"), 0.0, 0.0])  # refused: the robot stops
    assert s.fault and "not three finite currents" in s.fault
    assert [ahead.take().k for _ in range(10)] == list(range(10))  # computed before: still out
    ahead.refill()
    assert ahead.take() is None and not ahead.ticks
