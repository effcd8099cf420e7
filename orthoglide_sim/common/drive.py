"""The one drive model: what lies between the current reference and the plant's joints.

Every simulated robot's drive applies ``DriveModel.force``: the true gain times the motor current,
less the drive's own friction beyond the plant's when it has some (the Orthoglide's ball screws:
a Stribeck breakaway and a friction ripple at the screw lead). The motor current follows the held
reference at once, or through a first-order current loop (``current_lag_s``; its closed form
``motor_current``). The serial arms' unmodelled effects (a second-order current loop, joint
elasticity, backlash: orthoglide_sim/arms/unmodelled.py) act between this drive's current and the
link.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class DriveModel:
    """True gains, current loop, and the drive's friction beyond the plant's (fv, fs tanh,
    tauoff) of the actuated joints.

    The drive's friction, per actuator, on top of the plant's: (a_st exp(-(qd / v_st)^2)
    + a_r sin(2 pi q / lead + phase)) tanh(qd / v_s), i.e. a Stribeck term (``stribeck`` = a_st,
    set by ``stribeck_amplitude`` from the breakaway force wanted) and the ball screw's friction
    ripple (``ripple_amplitude`` = a_r at the screw lead), both turning with the plant's smooth
    Coulomb sign. Forces in N (N·m), (n,) or scalars. All zero: an ideal drive, force = g_tau i.
    """

    g_tau: np.ndarray  # (n,) true drive gains N/A (N·m/A)
    ripple_amplitude: np.ndarray | float = 0.0  # N, (n,) or scalar; 0 = off
    ripple_lead: float = 0.01  # m
    ripple_phase: np.ndarray = field(default_factory=lambda: np.array([0.0, 2.1, 4.2]))
    current_lag_s: float = 0.0  # s, first-order current loop time constant; 0 = ideal
    stribeck: np.ndarray | float = 0.0  # N, (n,) or scalar, Stribeck amplitude; 0 = off
    stribeck_velocity: float = 3.0e-3  # m/s
    coulomb_velocity: float = 1.0e-3  # m/s, the plant's smooth sign (tanh) scale

    @property
    def has_friction(self) -> bool:
        return bool(np.any(self.ripple_amplitude) or np.any(self.stribeck))

    def friction(self, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """The drive's own friction (n,) at actuator positions q, velocities qd (against qd)."""
        if not self.has_friction:
            return np.zeros(np.shape(q))
        s = np.tanh(np.asarray(qd) / self.coulomb_velocity)
        level = self.stribeck * np.exp(-(np.asarray(qd) / self.stribeck_velocity) ** 2)
        level = level + self.ripple_amplitude * np.sin(
            2.0 * np.pi * np.asarray(q) / self.ripple_lead + self.ripple_phase
        )
        return level * s

    def force(self, current: np.ndarray, q: np.ndarray, qd: np.ndarray | None = None) -> np.ndarray:
        """Actuator forces (n,) for the current in the motors (n,) A at actuator positions q (and
        velocities qd, needed when the drive has friction of its own)."""
        f = self.g_tau * current
        if self.has_friction:
            f = f - self.friction(q, np.zeros(np.shape(q)) if qd is None else qd)
        return f

    def motor_current(self, i0: np.ndarray, u: np.ndarray, t: float | np.ndarray) -> np.ndarray:
        """Motor current (n,) A a time t (s) after the reference stepped to the held u, from i0."""
        if self.current_lag_s <= 0.0:
            return np.asarray(u, float) + 0.0 * np.asarray(i0, float)
        return u + (i0 - u) * np.exp(-np.asarray(t) / self.current_lag_s)


def stribeck_amplitude(
    breakaway: float, coulomb_velocity: float, stribeck_velocity: float
) -> float:
    """Amplitude a (fraction of fs) of the Stribeck term for a breakaway force fs (1 + breakaway):
    the peak over qdot > 0 of tanh(qdot / v_s) (1 + a exp(-(qdot / v_st)^2)) is 1 + breakaway."""
    if breakaway <= 0:
        return 0.0
    v = np.linspace(1e-3, 6.0, 6000) * max(stribeck_velocity, coulomb_velocity)
    s, g = np.tanh(v / coulomb_velocity), np.exp(-(v / stribeck_velocity) ** 2)
    lo, hi = 0.0, 1.0
    while np.max(s * (1.0 + hi * g)) < 1.0 + breakaway:
        hi *= 2.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if np.max(s * (1.0 + mid * g)) < 1.0 + breakaway else (lo, mid)
    return 0.5 * (lo + hi)
