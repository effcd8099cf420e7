"""The UR5 with a coupled-wrist drive chain on MuJoCo: the arm of mujoco_plant (MuJoCo's own URDF
compiler, the truth's inertials) driven by six motors through fixed tendons (coupled_truth).

How the motor side is modelled, with MuJoCo's own elements (MuJoCo >= 3.3 has tendon armature;
4.0 here):

- motor m is a fixed tendon of length L_m = Σ_j N[m, j] q_j (``<tendon><fixed>`` with joint
  coefficients N[m, j], both signs): its velocity is MuJoCo's ten_velocity = N q̇_j, its
  Jacobian row N[m];
- its rotor inertia is the tendon's ``armature`` Ia_m: MuJoCo adds Nᵀ diag(Ia) N to the joint
  mass matrix (a rotor spinning at q̇_m stores ½ Ia q̇_m²);
- its viscous friction is the tendon's ``damping`` fv_m (force -fv q̇_m along the tendon), its
  Coulomb friction the tendon's ``frictionloss`` fs_m (the soft constraint of mujoco_plant, time
  constant FRICTION_TIMECONST, on the tendon's velocity);
- its current → torque gain is a general actuator on the tendon: force = g_m · ctrl - off_m
  (gainprm g_m, affine bias -off_m) with ctrl the motor current (A), applied through the
  tendon's Jacobian: joint torques Nᵀ τ_m.

The joints carry no armature or friction of their own. MuJoCo integrates all of it (RK4, the
same options as mujoco_plant); nothing of the identification's model is used. The motor
position is the tendon length plus the encoder offset (q_m = N q_j + offset).
"""
from __future__ import annotations

import mujoco
import numpy as np

from orthoglide_ident.errors import ConfigError
from orthoglide_sim.arms.plant import FRICTION_TIMECONST, JointStates, build_spec, route_warnings
from orthoglide_sim.arms.truth import ArmPayload
from orthoglide_sim.coupled.truth import CoupledTruth


def motor_name(truth: CoupledTruth, m: int) -> str:
    return f"motor_{truth.actuators[m]}"


def build_coupled_spec(truth: CoupledTruth, payload: ArmPayload | None = None) -> mujoco.MjSpec:
    """mujoco_plant's arm (joints bare) with one tendon and one actuator per motor."""
    spec = build_spec(truth.rigid, payload)
    names = truth.arm.joint_names
    for m, drive in enumerate(truth.motors):
        tendon = spec.add_tendon(name=motor_name(truth, m))
        for j in np.flatnonzero(truth.reduction[m]):
            tendon.wrap_joint(names[j], float(truth.reduction[m, j]))
        tendon.armature = drive.inertia
        tendon.damping = [drive.viscous] + [0.0] * (len(tendon.damping) - 1)
        tendon.frictionloss = drive.coulomb
        tendon.solref_friction = [FRICTION_TIMECONST, 1.0]
        act = spec.add_actuator(name=motor_name(truth, m), target=motor_name(truth, m),
                                trntype=mujoco.mjtTrn.mjTRN_TENDON)
        act.gainprm[0] = drive.gain
        act.biastype = mujoco.mjtBias.mjBIAS_AFFINE
        act.biasprm[0] = -drive.offset
    return spec


class CoupledPlant(JointStates):
    """One MuJoCo model and data of the coupled-wrist arm: joint and motor states, a step under
    held motor currents, inverse dynamics. Joint order ``truth.arm.joint_names``, motor order the
    rows of N."""

    def __init__(self, truth: CoupledTruth, payload: ArmPayload | None = None):
        self.truth, self.payload = truth, payload
        route_warnings()
        self.model = build_coupled_spec(truth, payload).compile()
        self.data = mujoco.MjData(self.model)
        m, n = self.model, truth.arm.n
        ids = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, j) for j in truth.arm.joint_names]
        if m.nv != n or m.nq != n or m.ntendon != n or m.nu != n:
            raise ConfigError(f"{truth.arm.name}: MuJoCo model has nq={m.nq}, nv={m.nv}, "
                              f"{m.ntendon} tendons, {m.nu} actuators for {n} joints and motors")
        self.dof = np.array([m.jnt_dofadr[i] for i in ids])

    # state (reset, q, qd: JointStates) -------------------------------------------------------
    @property
    def q_motor(self) -> np.ndarray:
        """(n,) motor positions: MuJoCo's tendon lengths + the encoder offsets, rad."""
        return self.data.ten_length.copy() + self.truth.motor_offset

    @property
    def qd_motor(self) -> np.ndarray:
        """(n,) motor velocities: MuJoCo's tendon velocities, rad/s."""
        return self.data.ten_velocity.copy()

    def step(self, current: np.ndarray, nstep: int) -> None:
        """``nstep`` MuJoCo steps under the motor currents ``current`` (n,) A held constant."""
        self.data.ctrl[:] = current
        mujoco.mj_step(self.model, self.data, nstep)
        # mj_step leaves the derived quantities (tendon lengths and velocities) at the state
        # before its last integration: bring them to the new state
        mujoco.mj_fwdPosition(self.model, self.data)
        mujoco.mj_fwdVelocity(self.model, self.data)

    def acceleration(self, q: np.ndarray, qd: np.ndarray, current: np.ndarray) -> np.ndarray:
        """(n,) MuJoCo's forward dynamics q̈ at one state under the currents (friction as the
        soft constraint computes it from the state alone: a fresh mjData)."""
        d = mujoco.MjData(self.model)
        d.qpos[self.dof], d.qvel[self.dof], d.ctrl[:] = q, qd, current
        mujoco.mj_forward(self.model, d)
        return d.qacc[self.dof].copy()

    # dynamics --------------------------------------------------------------------------------
    def motor_torques(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        """(k, n) motor torques g_m v_m that move the samples (k, n): MuJoCo's mj_inverse (rigid
        body, rotor inertia, motor damping) brought to the motors by N⁻ᵀ, plus the offsets and
        fs sign(q̇_m) (the soft friction's value away from zero velocity)."""
        q, qd, qdd = (np.atleast_2d(np.asarray(x, float)) for x in (q, qd, qdd))
        m, d = self.model, mujoco.MjData(self.model)
        fs = m.tendon_frictionloss.copy()
        m.tendon_frictionloss[:] = 0.0
        try:
            tau = np.empty_like(q)
            for k in range(q.shape[0]):
                d.qpos[self.dof], d.qvel[self.dof], d.qacc[self.dof] = q[k], qd[k], qdd[k]
                mujoco.mj_inverse(m, d)
                tau[k] = d.qfrc_inverse[self.dof]
        finally:
            m.tendon_frictionloss[:] = fs
        N = self.truth.reduction
        tau_m = np.linalg.solve(N.T, tau.T).T
        return tau_m + self.truth.motor_array("offset") + fs * np.sign(qd @ N.T)
