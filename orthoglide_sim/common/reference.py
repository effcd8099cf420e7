"""The reference a controller tracks, per tick, from a chain of trajectories blended into each
other (the Orthoglide's driver session, the arms' session)."""
from __future__ import annotations

import numpy as np

from orthoglide_ident.errors import ConfigError
from orthoglide_sim.common.closed_loop import TICK
from orthoglide_sim.common.trajectories import get_trajectory

BLEND_TIME = 2.0  # s, a new trajectory blends in over this time (quintic weight)


def _blend_weight(s: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Quintic 0 -> 1 on s in [0, 1] with zero first and second derivatives at both ends."""
    s = np.clip(s, 0.0, 1.0)
    return s**3 * (10 - 15 * s + 6 * s**2), 30 * s**2 * (1 - s) ** 2, 60 * s * (1 - s) * (1 - 2 * s)


class Reference:
    """The reference tracked by the controller, per tick, from a chain of trajectories.

    The first trajectory's time 0 is tick ``start_tick``.
    ``switch(name, k)`` starts trajectory ``name`` (its time 0) at tick k and blends the old one
    into it over BLEND_TIME: r = (1 - w) r_old + w r_new with a quintic weight w. Both stay in the
    safe box, which is convex, so the blend does too; velocity and acceleration stay bounded.
    """

    CACHE_TICKS = 256  # single ticks are served from blocks evaluated at once (a few us per tick)

    def __init__(self, name: str, resolve=get_trajectory, start_tick: int = 0):
        self._resolve = resolve  # name -> trajectory with .evaluate(t); another robot's designs
        self._chain = [(start_tick, resolve(name), name)]  # (first tick, trajectory, name)
        self._cache: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}

    @property
    def name(self) -> str:
        return self._chain[-1][2]

    def switch(self, name: str, k: int) -> None:
        traj = self._resolve(name)  # ConfigError on an unknown name
        if len(self._chain) > 1:
            k1 = self._chain[-1][0] + round(BLEND_TIME / TICK)
            raise ConfigError(
                f"trajectory {self.name} is still blending in until tick {k1}; switch again "
                f"in {(k1 - k) * TICK:.1f} s"
            )
        self._chain.append((k, traj, name))
        self._cache.clear()

    def at(self, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(q_d, qd_d, qdd_d) (3,) each at one tick, from a cached block of CACHE_TICKS ticks."""
        block = k // self.CACHE_TICKS
        if block not in self._cache:
            if len(self._cache) > 4:
                self._cache.pop(min(self._cache))
            self._cache[block] = self.evaluate(
                block * self.CACHE_TICKS + np.arange(self.CACHE_TICKS)
            )
        i = k - block * self.CACHE_TICKS
        return tuple(v[i] for v in self._cache[block])

    def settle(self, k: int) -> None:
        """Forget the old trajectory once the blend is over at the current tick k."""
        if len(self._chain) > 1 and k >= self._chain[-1][0] + round(BLEND_TIME / TICK):
            self._chain = self._chain[-1:]
            self._cache.clear()

    def evaluate(self, k: np.ndarray | int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(q_d, qd_d, qdd_d), each (N, 3) in m, m/s, m/s², at ticks k (N,)."""
        k = np.atleast_1d(np.asarray(k))
        k0, old, _ = self._chain[0]
        q, qd, qdd = old.evaluate((k - k0) * TICK)
        if len(self._chain) == 1:
            return q, qd, qdd
        k1, new, _ = self._chain[-1]
        t_new = np.maximum(k - k1, 0) * TICK
        w, wd, wdd = (x[:, None] for x in _blend_weight(t_new / BLEND_TIME))
        wd, wdd = wd / BLEND_TIME, wdd / BLEND_TIME**2
        qn, qdn, qddn = new.evaluate(t_new)
        dq, dqd, dqdd = qn - q, qdn - qd, qddn - qdd
        return q + w * dq, qd + w * dqd + wd * dq, qdd + w * dqdd + 2 * wd * dqd + wdd * dq
