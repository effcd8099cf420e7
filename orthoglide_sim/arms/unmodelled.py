"""Drive effects the identification's model lacks (issue 48), as options of the arm's simulator.

The IDIM (paper eq. 8) has a rigid joint driven directly by a motor whose torque is g_tau times
the current reference held over the tick, a viscous and a Coulomb friction. A real drive adds:

- **joint elasticity**: a spring (and its damping) between the motor and the link, the motor's
  rotor inertia (the truth's armature) on the motor side. The encoder reads the motor, as a
  robot's motor encoders do: the identification sees the motor's position, the link moves
  behind it. Stiffness K_j = J_j (2π f_e)² on each joint's inertia J_j (the unloaded mass
  matrix diagonal at the box centre, armature included): a joint resonance at f_e, as a
  harmonic drive's (tens of Hz on a UR5-sized arm);
- **backlash**: a gap of ``backlash`` rad in that spring (no torque while the motor crosses it),
  at every torque reversal; without an elasticity the contact has the stiffness of a resonance
  at BACKLASH_CONTACT_HZ;
- **a second-order current loop**: the motor current follows the reference (plus its noise)
  through ω²/(s² + 2ζωs + ω²), ω = 2π f_c, instead of being the reference at once;
- **Stribeck friction**: besides the truth's Coulomb friction f_c, a static excess
  Δ = ``stribeck`` f_c that decays with the speed, −Δ exp(−(q̇/v_s)²) sign(q̇).

Each is off by default; with all off the simulator runs its usual loop, unchanged. With any on,
the loop steps MuJoCo one TIMESTEP at a time so that the spring, the current loop and the
Stribeck term are updated every step (the spring explicitly, the motor by semi-implicit Euler:
stable for the resonances used here, up to ~150 Hz; 250 Hz diverges on the UR5's wrist).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import expm

BACKLASH_CONTACT_HZ = 150.0  # Hz, the contact's stiffness of a backlash without an elasticity
STRIBECK_SMOOTHING = 1.0e-3  # rad/s, tanh() stands for sign() within this band


@dataclass(frozen=True)
class Unmodelled:
    """Which unmodelled effects the plant has, and their sizes (see the module docstring)."""

    elasticity_hz: float = 0.0  # joint resonance f_e, Hz (0: a rigid joint)
    elasticity_damping: float = 0.2  # damping ratio ζ_e of the spring (a harmonic drive's)
    backlash: float = 0.0  # rad, the whole gap
    current_loop_hz: float = 0.0  # natural frequency f_c of the current loop, Hz (0: ideal)
    current_loop_damping: float = 0.7  # its damping ratio ζ_c
    stribeck: float = 0.0  # static excess Δ / f_c
    stribeck_velocity: float = 0.02  # rad/s, v_s

    @property
    def any(self) -> bool:
        return bool(self.elasticity_hz or self.backlash or self.current_loop_hz or self.stribeck)

    @property
    def two_mass(self) -> bool:
        """A motor state of its own (a spring or a gap between motor and link)."""
        return bool(self.elasticity_hz or self.backlash)

    def describe(self) -> str:
        parts = []
        if self.elasticity_hz:
            parts.append(f"joint elasticity {self.elasticity_hz:g} Hz "
                         f"(ζ {self.elasticity_damping:g})")
        if self.backlash:
            parts.append(f"backlash {self.backlash:g} rad")
        if self.current_loop_hz:
            parts.append(f"2nd-order current loop {self.current_loop_hz:g} Hz "
                         f"(ζ {self.current_loop_damping:g})")
        if self.stribeck:
            parts.append(f"Stribeck +{self.stribeck:g} f_c below {self.stribeck_velocity:g} rad/s")
        return ", ".join(parts) or "none"


def current_loop_matrices(f_hz: float, zeta: float, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Exact discretisation over ``dt`` of ï = ω²(u − i) − 2ζω i̇ with u held: x' = Φ x + Γ u,
    x = (i, i̇)."""
    w = 2.0 * np.pi * f_hz
    A = np.array([[0.0, 1.0, 0.0], [-w * w, -2.0 * zeta * w, w * w], [0.0, 0.0, 0.0]])
    E = expm(A * dt)
    return E[:2, :2], E[:2, 2]


class DriveState:
    """The states the unmodelled effects add, per joint (n,): motor angle and speed, current
    and its rate; ``torque_on_link`` gives what the motor side applies to the link each step."""

    def __init__(self, fx: Unmodelled, inertia: np.ndarray, armature: np.ndarray,
                 frictionloss: np.ndarray, dt: float):
        self.fx, self.dt = fx, dt
        self.J_m = np.asarray(armature, float)
        f_e = fx.elasticity_hz or BACKLASH_CONTACT_HZ
        self.K = np.asarray(inertia, float) * (2.0 * np.pi * f_e) ** 2
        # ζ_e on the motor-link pair's reduced inertia J_m J_l / (J_m + J_l), J_l = J - J_m
        J_l = np.maximum(np.asarray(inertia, float) - self.J_m, 1e-6)
        self.D = 2.0 * fx.elasticity_damping * np.sqrt(self.K * self.J_m * J_l / (self.J_m + J_l))
        self.half_gap = 0.5 * fx.backlash
        self.delta_s = fx.stribeck * np.asarray(frictionloss, float)
        if fx.current_loop_hz:
            self.Phi, self.Gamma = current_loop_matrices(fx.current_loop_hz,
                                                         fx.current_loop_damping, dt)
        self.i = self.di = self.theta = self.omega = None

    def start(self, q: np.ndarray, qd: np.ndarray, current: np.ndarray, torque: np.ndarray) -> None:
        """Steady state at t_0: the current at its reference, the spring carrying ``torque``."""
        self.i, self.di = np.asarray(current, float).copy(), np.zeros_like(current)
        deflection = torque / self.K + np.sign(torque) * self.half_gap
        self.theta, self.omega = q + deflection, np.asarray(qd, float).copy()

    def current(self, u: np.ndarray) -> np.ndarray:
        """The motor current over the next step under the reference ``u`` (A)."""
        if not self.fx.current_loop_hz:
            return u
        x = self.Phi @ np.vstack([self.i, self.di]) + np.outer(self.Gamma, u)
        self.i, self.di = x[0], x[1]
        return self.i

    def spring(self, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """Torque (n,) the motor side applies to the link: K dz(θ − q) + D (θ̇ − q̇) in contact."""
        e = self.theta - q
        dz = np.sign(e) * np.maximum(np.abs(e) - self.half_gap, 0.0)
        return self.K * dz + np.where(dz != 0.0, self.D * (self.omega - qd), 0.0)

    def stribeck(self, qd: np.ndarray) -> np.ndarray:
        """The Stribeck excess acting on the link (against its motion)."""
        if not self.fx.stribeck:
            return np.zeros_like(qd)
        v_s = self.fx.stribeck_velocity
        return -self.delta_s * np.exp(-(qd / v_s) ** 2) * np.tanh(qd / STRIBECK_SMOOTHING)

    def advance_motor(self, motor_torque: np.ndarray, spring: np.ndarray) -> None:
        """Semi-implicit Euler of J_m θ̈ = g i − spring over one step."""
        self.omega = self.omega + self.dt * (motor_torque - spring) / self.J_m
        self.theta = self.theta + self.dt * self.omega
