"""Sampled-data simulation: 1 kHz controller with zero-order hold, plant integrated by RK4.

Timing of one controller tick k (t_k = k T, T = 1 ms):
  1. the encoder is read: q_meas[k] = round(q(t_k) / 1 um) * 1 um;
  2. the controller computes the current reference v_tau[k] (A) from q_meas and the reference;
  3. during [t_k, t_k+1) the drive applies tau = g_tau_true * i(t) with the motor current i(t):
     the held reference u = v_tau[k] + n[k] (n: current noise, held with the reference), or with
     a current-loop lag tau_i the first-order response i(t) = u + (i(t_k) - u) exp(-(t - t_k) /
     tau_i) in its closed form (the loop is stiff for RK4 at 0.25 ms steps; its exact solution is
     evaluated at the RK4 stages). A plant profile may add the drive's friction the IDIM lacks:
     Stribeck breakaway near zero velocity and a ball-screw friction ripple at the screw lead;
  4. the plant (orthoglide_sim.orthoglide.plant, Pinocchio) is integrated with SUBSTEPS RK4 steps.
(q_meas[k], v_tau[k]) carry the same stamp t_k. The profile (true_parameters.PlantProfile) also
sets the current noise and the encoder's resolution and noise; "nominal" is the IDIM-like plant.

The integrator works on the 15 tree coordinates; every RELIFT_TICKS ticks the tree is put back
exactly on the closed loop from the actuator state (kinematics.tree_state), so the constraint
drift of the integration (~1e-10 rad per 0.1 s) never accumulates. A position outside the actuator
stroke or a non-finite state raises WorkspaceError: a simulated robot does not leave its workspace.

Controllers (all with the same linear part, a triple closed-loop pole at OMEGA = 100 rad/s on a
nominal foot mass M_NOMINAL = 10 kg): Kp = 3 M w^2, Kd = 3 M w, Ki = M w^3, so
Kp = 3.0e5 N/m, Kd = 3.0e3 N s/m, Ki = 1.0e7 N/(m s):
  - "pid":    F = Kp e + Ki int(e) - Kd v_est                       (simple PID, D on measurement)
  - "pid_ff": F = Kp e + Ki int(e) + Kd (qd_ref - v_est)            (PID with velocity feed-forward)
  - "ctc":    "pid_ff" plus a model feed-forward current per tick (computed elsewhere, e.g. the
              ctc node: the split computed-torque control of the paper's Sect. 5.2)
  - "external": v_tau given per tick (e.g. received on a topic).
v_est is the backward difference of the quantised position. The force command is converted to a
current with the manufacturer's gain 637 pi ~ 2001 N/A: v_tau = F / 2001.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from orthoglide_ident.errors import WorkspaceError
from orthoglide_ident.model.orthoglide.geometry import G_TAU_MANUFACTURER
from orthoglide_sim.orthoglide.plant import ACTUATED, Plant
from orthoglide_sim.orthoglide.truth import PROFILES, PlantProfile, TrueParameters

TICK = 1.0e-3  # s, controller period (1 kHz)
SUBSTEPS = 4  # RK4 steps per tick (4 kHz): 0.05 um from a 20 kHz integration over 2 s
RELIFT_TICKS = 100  # ticks between exact re-projections of the tree on the closed loop
ENCODER_RESOLUTION = PROFILES["nominal"].encoder_resolution  # m
CURRENT_NOISE_STD = PROFILES["nominal"].current_noise_std  # A, white, held over the tick
OMEGA = 100.0  # rad/s, bandwidth of the linear part
M_NOMINAL = 10.0  # kg
KP = 3.0 * M_NOMINAL * OMEGA**2
KD = 3.0 * M_NOMINAL * OMEGA
KI = M_NOMINAL * OMEGA**3
CONTROLLERS = ("pid", "pid_ff", "ctc", "external")
# Mechanical stroke of each actuator (m): the safe box [-0.04, 0.12] of the trajectories plus
# 20 mm. Beyond it a real Orthoglide hits its end stops; the simulator stops with an error.
STROKE = (-0.06, 0.14)


@dataclass(frozen=True)
class DriveModel:
    """What lies between the current reference and the plant's joints: true gains, current loop,
    and the screw's friction beyond the plant's (fv, fs tanh, tauoff) of the actuated joints.

    The drive's friction, per actuator, on top of the plant's: (a_st exp(-(qd / v_st)^2)
    + a_r sin(2 pi q / lead + phase)) tanh(qd / v_s), i.e. a Stribeck term (``stribeck`` = a_st,
    set by ``stribeck_amplitude`` from the breakaway force wanted) and the ball screw's friction
    ripple (``ripple_amplitude`` = a_r at the screw lead), both turning with the plant's smooth
    Coulomb sign. Forces in N, (3,) or scalars. All zero: an ideal drive.
    """

    g_tau: np.ndarray  # (3,) true drive gains N/A
    ripple_amplitude: np.ndarray | float = 0.0  # N, (3,) or scalar; 0 = off
    ripple_lead: float = 0.01  # m
    ripple_phase: np.ndarray = field(default_factory=lambda: np.array([0.0, 2.1, 4.2]))
    current_lag_s: float = 0.0  # s, first-order current loop time constant; 0 = ideal
    stribeck: np.ndarray | float = 0.0  # N, (3,) or scalar, Stribeck amplitude; 0 = off
    stribeck_velocity: float = 3.0e-3  # m/s
    coulomb_velocity: float = 1.0e-3  # m/s, the plant's smooth sign (tanh) scale

    @property
    def has_friction(self) -> bool:
        return bool(np.any(self.ripple_amplitude) or np.any(self.stribeck))

    def friction(self, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """The drive's own friction (3,) N at actuator positions q, velocities qd (against qd)."""
        if not self.has_friction:
            return np.zeros(3)
        s = np.tanh(np.asarray(qd) / self.coulomb_velocity)
        level = self.stribeck * np.exp(-(np.asarray(qd) / self.stribeck_velocity) ** 2)
        level = level + self.ripple_amplitude * np.sin(
            2.0 * np.pi * np.asarray(q) / self.ripple_lead + self.ripple_phase
        )
        return level * s

    def force(self, current: np.ndarray, q: np.ndarray, qd: np.ndarray | None = None) -> np.ndarray:
        """Actuator forces (3,) N for the current in the motors (3,) A at actuator positions q (and
        velocities qd, needed when the drive has friction of its own)."""
        f = self.g_tau * current
        if self.has_friction:
            f = f - self.friction(q, np.zeros(3) if qd is None else qd)
        return f

    def motor_current(self, i0: np.ndarray, u: np.ndarray, t: float | np.ndarray) -> np.ndarray:
        """Motor current (3,) A a time t (s) after the reference stepped to the held u, from i0."""
        if self.current_lag_s <= 0.0:
            return np.asarray(u, float) + 0.0 * np.asarray(i0, float)
        return u + (i0 - u) * np.exp(-np.asarray(t) / self.current_lag_s)


def drive_model(params: TrueParameters, ripple: bool | None = None,
                profile: str | PlantProfile | None = None) -> DriveModel:
    """DriveModel from TrueParameters and a plant profile (default ``params.profile``).

    ``ripple``: None = the profile's screw ripple; False = none; True = the profile's, or the
    "realistic" profile's ripple when the profile has none.
    """
    prof = profile if isinstance(profile, PlantProfile) else params.plant_profile(profile)
    fs = np.array([params.values[f"fs_1{i}"] for i in (1, 2, 3)])
    v_s = params.coulomb_velocity["prismatic"]
    amp, lead = prof.ripple_amplitude, prof.ripple_lead
    if ripple is True and amp <= 0:
        amp, lead = PROFILES["realistic"].ripple_amplitude, PROFILES["realistic"].ripple_lead
    if ripple is False:
        amp = 0.0
    return DriveModel(
        np.asarray(params.g_tau, dtype=float),
        amp * fs,
        lead,
        current_lag_s=prof.current_lag_s,
        stribeck=stribeck_amplitude(prof.stribeck_breakaway, v_s, prof.stribeck_velocity) * fs,
        stribeck_velocity=prof.stribeck_velocity,
        coulomb_velocity=v_s,
    )


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


def quantise(q: np.ndarray, resolution: float = ENCODER_RESOLUTION) -> np.ndarray:
    return np.round(np.asarray(q) / resolution) * resolution


class Integrator:
    """The plant's state over controller ticks: ``tick(current)`` integrates [t_k, t_k+1) under a
    held current reference (SUBSTEPS RK4 steps on the tree coordinates).

    With a current-loop lag the motor current is state too (``current``, A): it starts equal to
    the first reference (or ``current0``) and follows each held reference u by its exact
    first-order solution i(t) = u + (i0 - u) exp(-t / tau_i). The loop is too stiff for RK4 to
    sample (tau_i ~ 0.12 ms, steps of 0.25 ms), so each RK4 step is given stage currents built from
    the closed form's integrals over the step: the start value, and mid and end values chosen so
    that RK4's weights reproduce ∫ i dt and ∫ (h - t) i dt exactly — the impulse and the
    displacement the current gives over the step (to the order of the state's own variation).
    """

    def __init__(self, plant: Plant, drive: DriveModel, q0: np.ndarray, qd0: np.ndarray,
                 substeps: int = SUBSTEPS, current0: np.ndarray | None = None):
        self.plant, self.drive, self.substeps = plant, drive, int(substeps)
        self.ticks = 0
        self.Q, self.V = plant.lift(np.asarray(q0, float), np.asarray(qd0, float))
        self.current = None if current0 is None else np.asarray(current0, float).copy()
        h = TICK / self.substeps
        # exp(-t / tau_i) at the stage instants t = s h + (0, h/2, h) of every RK4 step, and at T
        lag = drive.current_lag_s
        self._decay = None
        if lag > 0:  # stage currents u + (i0 - u) c: c for (start, middle, end) of every RK4 step
            r, E = lag / h, np.exp(-h / lag)
            mu0 = r * (1.0 - E)  # (1/h) ∫ e^(-t/tau) dt over a step
            mu1 = r - r * r * (1.0 - E)  # (1/h²) ∫ (h - t) e^(-t/tau) dt
            c_mid = 0.5 * (6.0 * mu1 - 1.0)  # RK4: (c_start + 2 c_mid) / 6 = mu1
            c_end = 6.0 * mu0 - 1.0 - 4.0 * c_mid  # (c_start + 4 c_mid + c_end) / 6 = mu0
            start = np.exp(-np.arange(self.substeps) * h / lag)
            self._decay = start[:, None] * np.array([[1.0, c_mid, c_end]])  # (substeps, 3)
            self._decay_tick = float(np.exp(-TICK / lag))

    @property
    def q(self) -> np.ndarray:
        """Actuator positions (3,) m at the current tick."""
        return self.Q[ACTUATED].copy()

    @property
    def qd(self) -> np.ndarray:
        """Actuator velocities (3,) m/s at the current tick."""
        return self.V[ACTUATED].copy()

    def _acceleration(self, Q: np.ndarray, V: np.ndarray, current: np.ndarray) -> np.ndarray:
        return self.plant.tree_acceleration(
            Q, V, self.drive.force(current, Q[ACTUATED], V[ACTUATED])
        )

    def tick(self, current: np.ndarray) -> np.ndarray:
        """Integrate one tick under the reference ``current`` (3,) A; returns the actuator
        accelerations (3,) at its start. Raises WorkspaceError if the robot leaves its stroke or
        the state is not finite."""
        h = TICK / self.substeps
        u = np.asarray(current, float)
        Q, V = self.Q, self.V
        if self._decay is None:
            stages = None
        else:  # motor current at (start, middle, end) of every RK4 step: u + (i0 - u) e^(-t/tau)
            i0 = u if self.current is None else self.current
            stages = u + self._decay[:, :, None] * (i0 - u)
        qdd0 = None
        for k in range(self.substeps):
            ia, im, ib = (u, u, u) if stages is None else stages[k]
            a1 = self._acceleration(Q, V, ia)
            if qdd0 is None:
                qdd0 = a1[ACTUATED].copy()
            V2 = V + 0.5 * h * a1
            a2 = self._acceleration(Q + 0.5 * h * V, V2, im)
            V3 = V + 0.5 * h * a2
            a3 = self._acceleration(Q + 0.5 * h * V2, V3, im)
            V4 = V + h * a3
            a4 = self._acceleration(Q + h * V3, V4, ib)
            Q = Q + (h / 6.0) * (V + 2.0 * V2 + 2.0 * V3 + V4)
            V = V + (h / 6.0) * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
        self._check(Q, V, current)
        self.Q, self.V = Q, V
        self.current = u.copy() if stages is None else u + self._decay_tick * (stages[0, 0] - u)
        self.ticks += 1
        if self.ticks % RELIFT_TICKS == 0:
            self.Q, self.V = self.plant.lift(Q[ACTUATED], V[ACTUATED])
        return qdd0

    def _check(self, Q: np.ndarray, V: np.ndarray, current: np.ndarray) -> None:
        q = Q[ACTUATED]
        if not (np.all(np.isfinite(Q)) and np.all(np.isfinite(V))):
            raise WorkspaceError(
                f"the simulated robot's state is not finite after tick {self.ticks} "
                f"(current {np.round(current, 3).tolist()} A): stopped"
            )
        out = (q < STROKE[0]) | (q > STROKE[1])
        if np.any(out):
            j = int(np.argmax(out))
            raise WorkspaceError(
                f"q1{j + 1} = {q[j] * 1e3:.1f} mm left the actuator stroke "
                f"[{STROKE[0] * 1e3:.0f}, {STROKE[1] * 1e3:.0f}] mm at tick {self.ticks} "
                f"(current {np.round(current, 3).tolist()} A): the simulated robot stopped"
            )


@dataclass
class PID:
    """The 1 kHz linear part: PID on the quantised position, D on the measurement's backward
    difference, force converted to current with the manufacturer's gain."""

    q_meas_prev: np.ndarray  # (3,) m
    integral: np.ndarray  # (3,) m s, integral of the position error
    velocity_ff: bool = False  # True: "pid_ff" (Kd acts on qd_ref - v_est)

    def current(self, q_meas: np.ndarray, q_ref: np.ndarray, qd_ref: np.ndarray) -> np.ndarray:
        """One controller tick: v_tau (3,) A."""
        e = q_ref - q_meas
        self.integral = self.integral + e * TICK
        v_est = (q_meas - self.q_meas_prev) / TICK
        self.q_meas_prev = q_meas
        qd_term = qd_ref if self.velocity_ff else 0.0
        return (KP * e + KI * self.integral + KD * (qd_term - v_est)) / G_TAU_MANUFACTURER

    @classmethod
    def preloaded(cls, plant: Plant, q0, qd0, qdd0, velocity_ff: bool = False) -> PID:
        """A PID whose integrator already holds the force needed on the reference at t_0."""
        q0, qd0 = np.asarray(q0, float), np.asarray(qd0, float)
        tau0 = plant.inverse_dynamics(q0, qd0, np.asarray(qdd0, float))
        return cls(quantise(q0) - qd0 * TICK, tau0 / KI, velocity_ff)


@dataclass
class ClosedLoopResult:
    q_meas: np.ndarray  # (N, 3) m
    v_tau: np.ndarray  # (N, 3) A
    q: np.ndarray  # (N, 3) m, true
    qd: np.ndarray  # (N, 3) m/s, true
    qdd: np.ndarray  # (N, 3) m/s², true, at t_k under the held force


def simulate_closed_loop(
    q_ref,
    qd_ref,
    qdd_ref,
    plant: Plant,
    drive: DriveModel,
    controller: str = "pid",
    noise: np.ndarray | None = None,
    feedforward: np.ndarray | None = None,
    resolution: float = ENCODER_RESOLUTION,
    encoder_noise: np.ndarray | None = None,
    integrator: type[Integrator] = Integrator,
) -> ClosedLoopResult:
    """Run the plant under "pid", "pid_ff" or "ctc" along a sampled reference (N, 3) at 1 kHz.

    ``noise`` (N, 3) A: current noise held with each tick's reference; ``feedforward`` (N, 3) A:
    the model feed-forward current of "ctc" for each tick; ``resolution`` (m) and
    ``encoder_noise`` (N, 3) m: the encoder (position + noise, then quantised); ``integrator``:
    the plant's integration (Integrator, or reduced_plant.ReducedIntegrator). The plant starts
    on the reference (q, qd at t_0) with the controller's integrator pre-loaded.
    """
    if controller not in ("pid", "pid_ff", "ctc"):
        raise ValueError(
            f"controller must be 'pid', 'pid_ff' or 'ctc' for a recorded run, got {controller!r}"
        )
    q_ref, qd_ref = np.asarray(q_ref, float), np.asarray(qd_ref, float)
    N = len(q_ref)
    noise = np.zeros((N, 3)) if noise is None else np.asarray(noise, float)
    ff = np.zeros((N, 3)) if feedforward is None else np.asarray(feedforward, float)
    enc = None if encoder_noise is None else np.asarray(encoder_noise, float)
    sim = integrator(plant, drive, q_ref[0], qd_ref[0])
    pid = PID.preloaded(plant, q_ref[0], qd_ref[0], qdd_ref[0], velocity_ff=controller != "pid")
    # the feed-forward brings its share
    pid.integral = pid.integral - ff[0] * G_TAU_MANUFACTURER / KI
    out = ClosedLoopResult(*(np.empty((N, 3)) for _ in range(5)))
    for k in range(N):
        out.q[k], out.qd[k] = sim.q, sim.qd
        out.q_meas[k] = quantise(out.q[k] if enc is None else out.q[k] + enc[k], resolution)
        out.v_tau[k] = pid.current(out.q_meas[k], q_ref[k], qd_ref[k]) + ff[k]
        out.qdd[k] = sim.tick(out.v_tau[k] + noise[k])
    return out
