"""Sampled-data simulation: 1 kHz controller with zero-order hold, plant integrated by RK4 (the
common closed loop, PID, quantiser and drive model of orthoglide_sim/common/ on the Orthoglide).

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

from dataclasses import dataclass

import numpy as np

from orthoglide_ident.errors import WorkspaceError
from orthoglide_ident.model.orthoglide.geometry import G_TAU_MANUFACTURER
from orthoglide_sim.common.closed_loop import (
    OMEGA,
    PID,
    TICK,
    quantise,
    run_closed_loop,
    triple_pole,
)
from orthoglide_sim.common.drive import DriveModel, stribeck_amplitude
from orthoglide_sim.orthoglide.plant import ACTUATED, Plant
from orthoglide_sim.orthoglide.truth import PROFILES, PlantProfile, TrueParameters

SUBSTEPS = 4  # RK4 steps per tick (4 kHz): 0.05 um from a 20 kHz integration over 2 s
RELIFT_TICKS = 100  # ticks between exact re-projections of the tree on the closed loop
ENCODER_RESOLUTION = PROFILES["nominal"].encoder_resolution  # m
CURRENT_NOISE_STD = PROFILES["nominal"].current_noise_std  # A, white, held over the tick
M_NOMINAL = 10.0  # kg
KP, KI, KD = triple_pole(M_NOMINAL, OMEGA)
CONTROLLERS = ("pid", "pid_ff", "ctc", "external")
# Mechanical stroke of each actuator (m): the safe box [-0.04, 0.12] of the trajectories plus
# 20 mm. Beyond it a real Orthoglide hits its end stops; the simulator stops with an error.
STROKE = (-0.06, 0.14)


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


def preloaded_pid(plant: Plant, q0, qd0, qdd0, velocity_ff: bool = False) -> PID:
    """The 1 kHz linear part on the nominal mass, force converted to current with the
    manufacturer's gain, its integrator already holding the force needed on the reference at
    t_0."""
    q0, qd0 = np.asarray(q0, float), np.asarray(qd0, float)
    tau0 = plant.inverse_dynamics(q0, qd0, np.asarray(qdd0, float))
    return PID.tuned(M_NOMINAL, G_TAU_MANUFACTURER, quantise(q0, ENCODER_RESOLUTION) - qd0 * TICK,
                     tau0, OMEGA, velocity_ff)


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
    """Run the plant under "pid", "pid_ff" or "ctc" along a sampled reference (N, 3) at 1 kHz
    (the common closed loop, orthoglide_sim/common/closed_loop.py).

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
    pid = preloaded_pid(plant, q_ref[0], qd_ref[0], qdd_ref[0], velocity_ff=controller != "pid")
    # the feed-forward brings its share
    pid.integral = pid.integral - ff[0] * G_TAU_MANUFACTURER / KI
    return run_integrator(sim, lambda k, q: pid.current(q, q_ref[k], qd_ref[k]) + ff[k], noise,
                          resolution, enc)


def run_integrator(sim: Integrator, control, noise: np.ndarray, resolution: float,
                   encoder_noise: np.ndarray | None = None) -> ClosedLoopResult:
    """The common closed loop on the Orthoglide's integrator: the encoder reads the actuators,
    each tick's actuator accelerations at its start are logged (``qdd``)."""
    def read():
        q = sim.q
        return q, sim.qd, q

    res = run_closed_loop(read, control, lambda k, current: sim.tick(current), noise,
                          resolution, encoder_noise)
    return ClosedLoopResult(res.q_meas, res.v_tau, res.q, res.qd, res.logged)
