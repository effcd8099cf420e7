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


def run_arm(plant: MujocoPlant, pid: PID, q_ref: np.ndarray, qd_ref: np.ndarray,
            noise: np.ndarray, limits: MotionLimits,
            drive: DriveState | None = None) -> LoopResult:
    """Track the sampled reference (N, n) from the plant's current state under the common closed
    loop; ``noise`` (N, n) A; ``drive``: the unmodelled effects' states, None: none."""
    arm = ArmDrives(plant, limits, drive)
    return run_closed_loop(arm.read, lambda k, q: pid.current(q, q_ref[k], qd_ref[k]),
                           arm.advance, noise, plant.truth.encoder_resolution,
                           current_limit=pid.current_limit)
