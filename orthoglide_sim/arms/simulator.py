"""The simulated serial arm's 1 kHz controller and drive around the MuJoCo plant.

Per tick k (t_k = k TICK), the common closed loop (orthoglide_sim/common/closed_loop.py) that the
Orthoglide runs too:

1. the encoder reads q_meas = quantise(q(t_k)) (``ArmTruth.encoder_resolution``);
2. the joint PID with velocity feed-forward, a triple pole at -ω (ω = OMEGA = 100 rad/s, the
   paper's linear part) tuned on each joint's inertia J_j (the unloaded plant's mass matrix
   diagonal at the box centre, as a commissioning engineer tunes on the robot; the same gains
   with any payload), D on a low-passed velocity (VELOCITY_FILTER):
       torque = Kp e + Ki ∫e + Kd (q̇_ref - v_est),  Kp = 3 J ω², Kd = 3 J ω, Ki = J ω³,
   e = q_ref - q_meas, v_est the backward difference of q_meas;
   On an arm where that PID would be over MAX_STIFFNESS times too stiff somewhere along the run
   (ρ(M(q)⁻¹ diag J), stiffness: the inertia down tenfold, or the joints' coupling) the same
   triple pole is placed on the mass matrix at the measured pose instead (ScheduledPID), as a
   big arm's controller does; the joint PID chattered at its current limit there;
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

import mujoco
import numpy as np

from orthoglide_ident.errors import WorkspaceError
from orthoglide_sim.arms.limits import MotionLimits
from orthoglide_sim.arms.plant import TIMESTEP, MujocoPlant
from orthoglide_sim.arms.unmodelled import DriveState
from orthoglide_sim.common.closed_loop import (
    OMEGA,
    PID,
    TICK,
    LoopResult,
    run_closed_loop,
)
from orthoglide_sim.common.drive import DriveModel

SUBSTEPS = int(round(TICK / TIMESTEP))  # MuJoCo steps per tick
VELOCITY_FILTER = 2.0e-3  # s, first-order low-pass of the velocity estimate (1 / (5 OMEGA))
# ρ(M(q)⁻¹ diag(J)) along a run above this: the decentralised PID tuned on J is that many times
# too stiff somewhere (inertia down, or the joints' coupling), its loop at 1 kHz unstable, the
# current chattering at its limit: the arm gets the mass-matrix PID (ScheduledPID) instead.
# Measured along the references: UR3 designed 2.6, UR5 3.2-3.5, Panda designed 7.6 (all stable,
# unsaturated), UR10 designed 15.1 (chattering on 53 % of the ticks, dithered friction biasing
# its gains 4-7 σ: docs/benchmarks.md)
MAX_STIFFNESS = 10.0


def mass_matrix(plant: MujocoPlant, q: np.ndarray) -> np.ndarray:
    """(n, n) MuJoCo's mass matrix (armature included) of the plant's joints at q."""
    d = mujoco.MjData(plant.model)
    d.qpos[plant.dof] = q
    mujoco.mj_forward(plant.model, d)
    M = np.zeros((plant.model.nv, plant.model.nv))
    mujoco.mj_fullM(plant.model, d, M)
    return M[np.ix_(plant.dof, plant.dof)]


def joint_inertia(plant: MujocoPlant, q: np.ndarray) -> np.ndarray:
    """(n,) diagonal of the plant's mass matrix (armature included) at q, kg·m²."""
    return np.diag(mass_matrix(plant, q))


def arm_pid(inertia: np.ndarray, nominal_gain: np.ndarray, current_limit: np.ndarray,
            q_prev: np.ndarray, qd0: np.ndarray, torque0: np.ndarray, omega: float = OMEGA,
            velocity_filter: float = VELOCITY_FILTER) -> PID:
    """The joint PID of the module docstring (torques N·m, currents A, arrays (n,)): triple pole
    at -omega on each joint's ``inertia``, velocity feed-forward, D on the low-passed velocity
    (starting at ``qd0``), clipped to ``current_limit``; the integrator pre-loaded with the
    torque ``torque0`` the reference needs at t_0 (the plant starts on the reference)."""
    return PID.tuned(np.asarray(inertia, float), np.asarray(nominal_gain, float),
                     np.asarray(q_prev, float).copy(), torque0, omega, velocity_ff=True,
                     current_limit=np.asarray(current_limit, float),
                     velocity_filter=velocity_filter, v0=qd0)


def stiffness(plant: MujocoPlant, q: np.ndarray, inertia: np.ndarray) -> float:
    """max over the poses q (m, n) of ρ(M(q)⁻¹ diag(inertia)): how much stiffer than tuned the
    decentralised PID on ``inertia`` is there (1: as tuned)."""
    D = np.diag(np.asarray(inertia, float))
    return max(float(np.abs(np.linalg.eigvals(np.linalg.solve(mass_matrix(plant, x), D))).max())
               for x in np.atleast_2d(q))


class ScheduledPID:
    """The triple pole at -omega on the mass matrix at the measured pose (what a big arm's
    controller does: its inertia varies tenfold along a run): per tick
        torque = M(q_meas) (3 ω² e + 3 ω (q̇_ref - v_est)) + τ_I,  τ_I += diag M(q_meas) ω³ e dt,
    v_est low-passed as arm_pid's, the current clipped as arm_pid's. ``plant``: the unloaded
    plant the controller's model is (as arm_pid is tuned unloaded); τ_I starts at ``torque0``."""

    def __init__(self, plant: MujocoPlant, nominal_gain: np.ndarray, current_limit: np.ndarray,
                 q_prev: np.ndarray, qd0: np.ndarray, torque0: np.ndarray,
                 omega: float = OMEGA, velocity_filter: float = VELOCITY_FILTER):
        self.model, self.dof = plant.model, plant.dof
        self.data = mujoco.MjData(plant.model)
        self.M = np.zeros((plant.model.nv, plant.model.nv))
        self.nominal_gain, self.current_limit = nominal_gain, np.asarray(current_limit, float)
        self.q_prev, self.v_filtered = np.asarray(q_prev, float).copy(), np.array(qd0, float)
        self.tau_i, self.omega, self.velocity_filter = np.array(torque0, float), omega, \
            velocity_filter

    def mass(self, q: np.ndarray) -> np.ndarray:
        self.data.qpos[self.dof] = q
        mujoco.mj_forward(self.model, self.data)
        mujoco.mj_fullM(self.model, self.data, self.M)
        return self.M[np.ix_(self.dof, self.dof)]

    def current(self, q_meas: np.ndarray, q_ref: np.ndarray, qd_ref: np.ndarray,
                dt: float = TICK) -> np.ndarray:
        M, w, e = self.mass(q_meas), self.omega, q_ref - q_meas
        self.tau_i = self.tau_i + np.diag(M) * w**3 * e * dt
        v_est = (q_meas - self.q_prev) / dt
        self.q_prev = q_meas
        self.v_filtered = self.v_filtered + dt / (dt + self.velocity_filter) * (
            v_est - self.v_filtered)
        tau = M @ (3 * w**2 * e + 3 * w * (qd_ref - self.v_filtered)) + self.tau_i
        return np.clip(tau / self.nominal_gain, -self.current_limit, self.current_limit)


def check_limits(plant: MujocoPlant, limits: MotionLimits, k: int, current: np.ndarray) -> None:
    """WorkspaceError if the arm left its stop limits or its state is not finite after tick k."""
    q, qd = plant.q, plant.qd
    names = plant.truth.arm.joint_names
    diverged = plant.data.warning[mujoco.mjtWarning.mjWARN_BADQACC].number > 0
    if diverged or not (np.all(np.isfinite(q)) and np.all(np.isfinite(qd))):
        raise WorkspaceError(f"the simulated arm's state is not finite after tick {k} (current "
                             f"{np.round(current, 3).tolist()} A): stopped")
    out = (q < limits.stop_lower) | (q > limits.stop_upper)
    if np.any(out):
        j = int(np.argmax(out))
        raise WorkspaceError(
            f"{names[j]} = {q[j]:.3f} left its limits [{limits.stop_lower[j]:.3f}, "
            f"{limits.stop_upper[j]:.3f}] at tick {k} (current "
            f"{np.round(current, 3).tolist()} A): the simulated arm stopped"
        )


class ArmDrives:
    """The arm's side of the common closed loop: what the encoders read (``read``) and one tick
    of the drives and the MuJoCo plant (``advance``), stopped at the stop limits.

    ``effects``: the unmodelled effects' states (orthoglide_sim/arms/unmodelled.py), None: none.
    """

    def __init__(self, plant: MujocoPlant, limits: MotionLimits,
                 effects: DriveState | None = None):
        self.plant, self.limits, self.effects = plant, limits, effects
        self.drive = DriveModel(plant.truth.drive_array("g_tau"))
        # the encoder is on the motor: behind a spring or a gap, the motor's angle
        self.behind = effects is not None and effects.fx.two_mass

    def read(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        q = self.plant.q
        return q, self.plant.qd, self.effects.theta if self.behind else q

    def advance(self, k: int, current: np.ndarray, steps: int = SUBSTEPS) -> None:
        """The current (n,) A held over ``steps`` MuJoCo steps; WorkspaceError off the limits."""
        if self.effects is None:
            self.plant.step(self.drive.force(current, self.plant.q), steps)
        else:
            self._step_unmodelled(current, steps)
        check_limits(self.plant, self.limits, k, current)

    def _step_unmodelled(self, current: np.ndarray, steps: int) -> None:
        """One tick of single MuJoCo steps, the unmodelled effects updated at every step."""
        plant, fx = self.plant, self.effects
        for _ in range(steps):
            q, qd = plant.q, plant.qd
            motor_torque = self.drive.force(fx.current(current), q)
            on_link = fx.stribeck(qd)
            if fx.fx.two_mass:
                spring = fx.spring(q, qd)
                fx.advance_motor(motor_torque, spring)
                on_link = on_link + spring
            else:
                on_link = on_link + motor_torque
            plant.step(on_link, 1)


def run_arm(plant: MujocoPlant, pid: PID | ScheduledPID, q_ref: np.ndarray, qd_ref: np.ndarray,
            noise: np.ndarray, limits: MotionLimits,
            drive: DriveState | None = None) -> LoopResult:
    """Track the sampled reference (N, n) from the plant's current state under the common closed
    loop; ``noise`` (N, n) A; ``drive``: the unmodelled effects' states, None: none."""
    arm = ArmDrives(plant, limits, drive)
    return run_closed_loop(arm.read, lambda k, q: pid.current(q, q_ref[k], qd_ref[k]),
                           arm.advance, noise, plant.truth.encoder_resolution,
                           current_limit=pid.current_limit)
