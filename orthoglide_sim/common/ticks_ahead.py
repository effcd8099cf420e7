"""Ticks of the simulated robot computed ahead of their deadline, published at it (no ROS here).

A tick of the driver (session.DriverSession) is plant + controller: ~50 us of compiled calls and
numpy when its caches are warm, ~110-180 us when each tick runs alone after a millisecond in which
every other process of the machine went through the core (bench/driver_cost.py). ``TicksAhead``
computes up to ``block`` ticks back to back, once every ``block`` ticks, wherever their inputs are
already known, and hands them out one per deadline:

- under ``pid`` and ``pid_ff`` nothing comes from outside: every tick can be computed ahead;
- under ``ctc`` a tick is computed ahead only once its own feed-forward is in (the ctc sends it
  ~40 ms ahead); a tick whose feed-forward has not come is computed at its own deadline, with the
  session's hold rule, exactly as when every tick ran alone;
- under ``external`` no tick is (its command is computed from the tick's own joint state).

Nothing is published early: a tick's joint state and current go out at its deadline, as a real
robot's would. What changes is when a change reaches the plant: a parameter set while ticks are
computed ahead (payload, trajectory, controller, current limit, reset) applies from the first tick
not yet computed, at most ``block`` ticks (10 ms) later. The setpoint of tick k + lead is taken
when tick k is computed, so setpoints go out ``lead`` to ``lead + block`` ticks ahead.

The ticks handed out are the very ticks a tick-by-tick run gives (same states, currents, noise
draws, counters): tests/sim/common/test_ticks_ahead.py.
"""
from __future__ import annotations

from collections import deque
from typing import NamedTuple, Protocol

import numpy as np

AHEAD_TICKS = 10  # computed together at most: 10 ms, the longest a parameter change waits


class Tick(NamedTuple):
    k: int
    q_meas: np.ndarray  # (3,) m, the encoder reading at t_k
    v_tau: np.ndarray  # (3,) A, the current held over [t_k, t_k+1)


class Session(Protocol):
    """What TicksAhead asks of a tick-by-tick session (orthoglide.session.DriverSession)."""

    k: int  # the next tick
    lead: int  # ticks the setpoints go out ahead
    fault: str | None  # why the plant stopped; None while it runs

    def ready_ahead(self, limit: int) -> int: ...
    def setpoint(self, k: int) -> tuple: ...
    def step(self) -> tuple[np.ndarray, np.ndarray]: ...


class TicksAhead:
    """Ticks of ``session`` computed before their deadline (``block`` at most at a time)."""

    def __init__(self, session: Session, block: int = AHEAD_TICKS):
        self.session = session
        self.block = block
        self.ticks: deque[Tick] = deque()
        self.setpoints: list[tuple[int, tuple]] = []  # (tick, (q_d, qd_d, qdd_d)) not yet published

    def take(self) -> Tick | None:
        """The next tick: computed ahead, or now (at its deadline) if its input had not come;
        None once the plant has stopped (``session.fault``, also set by a refused input)."""
        if not self.ticks:
            self._compute(1)
        return self.ticks.popleft() if self.ticks else None

    def refill(self, until: int | None = None) -> None:
        """Once every computed tick is out: compute the ticks whose inputs are in, ``block`` at
        most and none from ``until`` on (the run's end)."""
        if self.ticks:
            return
        n = self.session.ready_ahead(self.block)
        if until is not None:
            n = min(n, until - self.session.k)
        self._compute(n)

    def take_setpoints(self) -> list[tuple[int, tuple]]:
        """The setpoints of the ticks computed since the last call, to publish now."""
        out, self.setpoints = self.setpoints, []
        return out

    def _compute(self, n: int) -> None:
        s = self.session
        for _ in range(n):
            if s.fault:
                return  # the plant stopped: nothing after the tick that stopped it
            k = s.k
            self.setpoints.append((k + s.lead, s.setpoint(k + s.lead)))
            q, v = s.step()
            self.ticks.append(Tick(k, q, v))
