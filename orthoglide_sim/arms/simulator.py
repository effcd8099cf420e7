"""The simulated serial arm's 1 kHz controller and drive around the MuJoCo plant.

Per tick k (t_k = k TICK), as orthoglide_sim/orthoglide/simulator.py does for the Orthoglide:

1. the encoder reads q_meas = quantise(q(t_k)) (``ArmTruth.encoder_resolution``);
2. the joint PID with velocity feed-forward, a triple pole at -ω (ω = OMEGA = 100 rad/s, the
   paper's linear part) tuned on each joint's inertia J_j (the unloaded plant's mass matrix
   diagonal at the box centre, as a commissioning engineer tunes on the robot; the same gains
   with any payload), D on a low-passed velocity (VELOCITY_FILTER):
       torque = Kp e + Ki ∫e + Kd (q̇_ref - v_est),  Kp = 3 J ω², Kd = 3 J ω, Ki = J ω³,
   e = q_ref - q_meas, v_est the backward difference of q_meas;
3. the current reference v_tau = torque / g_nominal (the manufacturer's gain the controller is
   configured with), clipped to the drive's current limit (URDF effort / g_nominal);
4. the drive applies g_tau (v_tau + noise) (the true gain, white current noise held over the
   tick) during [t_k, t_k+1): zero-order hold, SUBSTEPS MuJoCo RK4 steps.

With unmodelled effects (orthoglide_sim/arms/unmodelled.py: joint elasticity, backlash, a
second-order current loop, Stribeck friction) step 4 is taken one MuJoCo step at a time with
those effects between the current and the link.

Leaving the stop limits (arm_limits) or a non-finite state raises WorkspaceError: a simulated
robot that leaves its workspace is an error, not a number.
"""
from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from orthoglide_ident.errors import WorkspaceError
from orthoglide_sim.arms.limits import MotionLimits
from orthoglide_sim.arms.plant import TIMESTEP, MujocoPlant
from orthoglide_sim.arms.unmodelled import DriveState

TICK = 1.0e-3  # s, controller period (1 kHz)
SUBSTEPS = int(round(TICK / TIMESTEP))  # MuJoCo steps per tick
OMEGA = 100.0  # rad/s, bandwidth of the linear part
VELOCITY_FILTER = 2.0e-3  # s, first-order low-pass of the velocity estimate (1 / (5 OMEGA))


def quantise(q: np.ndarray, resolution: np.ndarray) -> np.ndarray:
    """Encoder reading: q rounded to the nearest count, per joint."""
    return np.round(q / resolution) * resolution


def joint_inertia(plant: MujocoPlant, q: np.ndarray) -> np.ndarray:
    """(n,) diagonal of the plant's mass matrix (armature included) at q, kg·m²."""
    d = mujoco.MjData(plant.model)
    d.qpos[plant.dof] = q
    mujoco.mj_forward(plant.model, d)
    M = np.zeros((plant.model.nv, plant.model.nv))
    mujoco.mj_fullM(plant.model, d, M)
    return np.diag(M)[plant.dof]


@dataclass
class ArmPID:
    """The 1 kHz joint PID (see the module docstring); arrays (n,), torques N·m, currents A."""

    kp: np.ndarray
    ki: np.ndarray
    kd: np.ndarray
    nominal_gain: np.ndarray  # N·m/A
    current_limit: np.ndarray  # A
    q_prev: np.ndarray  # last encoder reading
    integral: np.ndarray  # ∫ e dt, rad·s
    v_filtered: np.ndarray  # low-passed velocity estimate, rad/s
    alpha: float = 1.0  # velocity filter coefficient, TICK / (TICK + tau_v); 1 = no filter

    @classmethod
    def tuned(cls, inertia: np.ndarray, nominal_gain: np.ndarray, current_limit: np.ndarray,
              q0: np.ndarray, qd0: np.ndarray, torque0: np.ndarray, omega: float = OMEGA,
              velocity_filter: float = VELOCITY_FILTER) -> ArmPID:
        """Triple pole at -omega on each joint's ``inertia``; the integrator pre-loaded with the
        torque ``torque0`` the reference needs at t_0 (the plant starts on the reference)."""
        J = np.asarray(inertia, float)
        ki = J * omega**3
        return cls(3 * J * omega**2, ki, 3 * J * omega, np.asarray(nominal_gain, float),
                   np.asarray(current_limit, float), np.asarray(q0, float).copy(), torque0 / ki,
                   np.asarray(qd0, float).copy(), TICK / (TICK + velocity_filter))

    def current(self, q_meas: np.ndarray, q_ref: np.ndarray, qd_ref: np.ndarray) -> np.ndarray:
        """One tick: the current reference v_tau (n,) A."""
        e = q_ref - q_meas
        self.integral = self.integral + e * TICK
        v_est = (q_meas - self.q_prev) / TICK
        self.q_prev = q_meas
        self.v_filtered = self.v_filtered + self.alpha * (v_est - self.v_filtered)
        torque = self.kp * e + self.ki * self.integral + self.kd * (qd_ref - self.v_filtered)
        return np.clip(torque / self.nominal_gain, -self.current_limit, self.current_limit)


@dataclass
class LoopResult:
    """Per tick (N, n): what the controller logged and what the plant did."""

    q_meas: np.ndarray  # encoder readings, rad
    v_tau: np.ndarray  # current references, A (held over [t_k, t_k+1))
    q: np.ndarray  # true positions at t_k, rad
    qd: np.ndarray  # true velocities at t_k, rad/s
    current: np.ndarray  # currents in the motors over the tick: v_tau + noise, A
    saturated: int  # ticks at which some joint's current reference hit its limit


def _check(plant: MujocoPlant, limits: MotionLimits, k: int, v_tau: np.ndarray) -> None:
    q, qd = plant.q, plant.qd
    names = plant.truth.arm.joint_names
    diverged = plant.data.warning[mujoco.mjtWarning.mjWARN_BADQACC].number > 0
    if diverged or not (np.all(np.isfinite(q)) and np.all(np.isfinite(qd))):
        raise WorkspaceError(f"the simulated arm's state is not finite after tick {k} (current "
                             f"{np.round(v_tau, 3).tolist()} A): stopped")
    out = (q < limits.stop_lower) | (q > limits.stop_upper)
    if np.any(out):
        j = int(np.argmax(out))
        raise WorkspaceError(
            f"{names[j]} = {q[j]:.3f} left its limits [{limits.stop_lower[j]:.3f}, "
            f"{limits.stop_upper[j]:.3f}] at tick {k} (current "
            f"{np.round(v_tau, 3).tolist()} A): the simulated arm stopped"
        )


def run_closed_loop(plant: MujocoPlant, pid: ArmPID, q_ref: np.ndarray, qd_ref: np.ndarray,
                    noise: np.ndarray, limits: MotionLimits,
                    drive: DriveState | None = None) -> LoopResult:
    """Track the sampled reference (N, n) from the plant's current state; ``noise`` (N, n) A;
    ``drive``: the unmodelled effects' states (orthoglide_sim/arms/unmodelled.py), None: none."""
    N, n = q_ref.shape
    g_tau = plant.truth.drive_array("g_tau")
    resolution = plant.truth.encoder_resolution
    out = LoopResult(*(np.empty((N, n)) for _ in range(5)), saturated=0)
    for k in range(N):
        out.q[k], out.qd[k] = plant.q, plant.qd
        # the encoder is on the motor: behind a spring or a gap, the motor's angle
        behind = drive is not None and drive.fx.two_mass
        out.q_meas[k] = quantise(drive.theta if behind else out.q[k], resolution)
        v = pid.current(out.q_meas[k], q_ref[k], qd_ref[k])
        out.v_tau[k] = v
        out.current[k] = v + noise[k]
        out.saturated += bool(np.any(np.abs(v) >= pid.current_limit))
        if drive is None:
            plant.step(g_tau * out.current[k], SUBSTEPS)
        else:
            _step_unmodelled(plant, drive, g_tau, out.current[k])
        _check(plant, limits, k, v)
    return out


def _step_unmodelled(plant: MujocoPlant, drive: DriveState, g_tau: np.ndarray,
                     current: np.ndarray) -> None:
    """One tick of SUBSTEPS steps, the unmodelled effects updated at every step."""
    for _ in range(SUBSTEPS):
        motor_torque = g_tau * drive.current(current)
        q, qd = plant.q, plant.qd
        on_link = drive.stribeck(qd)
        if drive.fx.two_mass:
            spring = drive.spring(q, qd)
            drive.advance_motor(motor_torque, spring)
            on_link = on_link + spring
        else:
            on_link = on_link + motor_torque
        plant.step(on_link, 1)
