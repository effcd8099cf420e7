"""Tick-by-tick simulation for the driver node (no ROS here).

``DriverSession.next_tick(command)`` returns (stamp_ns, q_meas, v_tau) of the next 1 kHz tick.
With the internal controllers ("pid", "pid_ff") the closed loop is deterministic, so ticks are
computed ahead in blocks of BLOCK by one compiled scan (cheap per tick); in "external" mode every
tick applies the latest current command (zero-order hold) and integrates one tick.
"""
from __future__ import annotations

import threading
from collections import deque

import jax.numpy as jnp
import numpy as np

from orthoglide_ident.errors import ConfigError
from orthoglide_sim import plant as pl
from orthoglide_sim import simulator as sm
from orthoglide_sim.trajectories import Q_CENTER, get_trajectory
from orthoglide_sim.true_parameters import TrueParameters, load_parameters

BLOCK = 1000  # ticks computed ahead (same compiled scan as orthoglide_sim.record)


def parse_payload(value: str) -> str | float:
    """ROS parameter 'payload': none, 1.983, 1.136 or a custom mass in kg."""
    v = str(value).strip().lower()
    if v in ("none", "", "0", "0.0"):
        return "none"
    if v in ("1.983", "1.136"):
        return v
    try:
        return float(v)
    except ValueError:
        raise ConfigError(f"payload must be none, 1.983, 1.136 or a mass in kg, got {value!r}") from None


class DriverSession:
    def __init__(self, payload: str | float = "none", trajectory: str = "exciting", controller: str = "pid",
                 params: TrueParameters | None = None, seed: int = 0, noise: bool = True, start_ns: int = 0):
        if controller not in sm.CONTROLLERS:
            raise ConfigError(f"controller must be one of {', '.join(sm.CONTROLLERS)}, got {controller!r}")
        self.params = params or load_parameters()
        self.controller = controller
        self.p = pl.plant_params(self.params, payload)
        self.drive = sm.drive_model(self.params)
        self.traj = get_trajectory(trajectory) if controller != "external" else None
        self.rng = np.random.default_rng(seed)
        self.noise = noise
        self.start_ns = start_ns
        self.k = 0
        self._k_filled = 0
        self._buffer: deque = deque()
        self._lock = threading.Lock()
        if self.traj is not None:
            q0, qd0, qdd0 = (v[0] for v in self.traj.evaluate(0.0))
        else:  # external: start at rest at the centre of the safe box
            q0, qd0, qdd0 = np.full(3, Q_CENTER), np.zeros(3), np.zeros(3)
        self.x, self.ctrl = sm.initial_state(q0, qd0, qdd0, self.p, self.drive)

    def _noise(self, n: int) -> np.ndarray:
        return self.rng.normal(0.0, sm.CURRENT_NOISE_STD, (n, 3)) if self.noise else np.zeros((n, 3))

    def _fill(self) -> None:
        t = (self._k_filled + np.arange(BLOCK)) * sm.TICK
        self._k_filled += BLOCK
        q_ref, qd_ref, _ = self.traj.evaluate(t)
        out, self.x, self.ctrl = sm.run_closed_loop(
            self.x, self.ctrl, jnp.asarray(q_ref), jnp.asarray(qd_ref), jnp.asarray(self._noise(BLOCK)),
            self.p, self.drive, ff=1.0 if self.controller == "pid_ff" else 0.0)
        q_meas, v_tau = np.asarray(out[0]), np.asarray(out[1])
        self._buffer.extend(zip(q_meas, v_tau))

    def warm_up(self) -> None:
        """Compile (and for internal controllers compute the first block) before real time starts."""
        if self.controller == "external":
            sm.external_tick(self.x, jnp.zeros(3), jnp.zeros(3), self.p, self.drive)
        else:
            while len(self._buffer) < 3 * BLOCK:  # 3 s of head start for the producer thread
                self._fill()

    def next_tick(self, command: np.ndarray | None = None) -> tuple[int, np.ndarray, np.ndarray]:
        """(stamp_ns, q_meas (3,) m, v_tau (3,) A) of the next tick; ``command`` (A) in external mode."""
        stamp = self.start_ns + self.k * int(round(sm.TICK * 1e9))
        if self.controller == "external":
            v_tau = np.zeros(3) if command is None else np.asarray(command, float)
            q_meas, self.x = sm.external_tick(self.x, jnp.asarray(v_tau), jnp.asarray(self._noise(1)[0]),
                                              self.p, self.drive)
            q_meas = np.asarray(q_meas)
        else:
            with self._lock:
                if not self._buffer:
                    self._fill()
            q_meas, v_tau = self._buffer.popleft()
        self.k += 1
        return stamp, q_meas, v_tau

    def fill_ahead(self, min_ticks: int = BLOCK) -> bool:
        """Compute another block if fewer than ``min_ticks`` are buffered (call from a worker thread).
        Returns True if it computed one."""
        if self.controller == "external" or len(self._buffer) >= min_ticks:
            return False
        with self._lock:
            self._fill()
        return True

    @property
    def buffered(self) -> int:
        return len(self._buffer)
