"""The serial arm's plant on MuJoCo: the same URDF loaded by MuJoCo's own compiler, with the
truth's inertials, armature, damping, friction loss and offsets, and a payload body.

Why it is independent of what identifies it: MuJoCo parses the URDF itself, builds its own
kinematic tree and integrates its own forward dynamics (composite rigid body mass matrix, RNE
bias, soft-constraint friction loss), none of which shares code with Pinocchio's regressor that
the identification uses. The one fact shared is the truth's numbers, checked after loading:
body masses, centres of mass and full inertia tensors equal the truth to round-off
(``inertial_errors``), and MuJoCo's inverse dynamics equals Pinocchio's RNEA of the same truth to
~1e-12 (tests/sim/arms/test_mujoco_plant.py).

MuJoCo options: gravity ``arm_truth.GRAVITY`` along -z; RK4 at TIMESTEP (4 steps per 1 kHz
tick: against 1/32 ms steps the velocity after a tick differs by 2e-9 to 1e-7 rad/s rms on the
UR5's exciting motion, an equivalent torque below 1e-3 of the current noise's); no contacts
(geometry is stripped: ``discardvisual``, collision meshes removed, no contacts), no joint-limit
constraints (leaving the limits is the simulator's WorkspaceError instead); the inertials exactly
as given (``balanceinertia="false"``, ``inertiafromgeom="false"``, static links not fused so the
payload frame exists). Friction loss is MuJoCo's soft constraint (time constant
FRICTION_TIMECONST): it turns smoothly through zero velocity within ~0.01 rad/s, as a real
joint's friction does, and is fs sign(q̇) outside that band. A locked joint (``arm.locked``: a
gripper's fingers) is welded: its body moved to the locked value along the joint's axis, the joint
and the mimic constraint MuJoCo made of it deleted.
"""
from __future__ import annotations

import logging
import re

import mujoco
import numpy as np

from orthoglide_ident.errors import ConfigError
from orthoglide_sim.arms.truth import ArmPayload, ArmTruth, RigidBody

TIMESTEP = 2.5e-4  # s: 4 RK4 steps per 1 kHz controller tick
# s, time constant of the friction-loss constraint (MuJoCo's default 0.02 s spreads the turn
# through zero over ~0.15 rad/s on the UR5's exciting motion; 2 ms keeps it within ~0.01 rad/s,
# a real joint's Stribeck scale, and is 8 steps: stable)
FRICTION_TIMECONST = 2.0e-3
PAYLOAD_BODY = "payload"
INERTIAL_TOLERANCE = 1e-12  # relative: what MuJoCo's principal-axes storage loses to round-off
_log = logging.getLogger("orthoglide_sim.mujoco")


def route_warnings() -> None:
    """MuJoCo's warnings to this logger (by default it prints them and writes MUJOCO_LOG.TXT in
    the working directory); a diverged state is the simulator's WorkspaceError anyway."""
    if mujoco.get_mju_user_warning() is None:
        mujoco.set_mju_user_warning(lambda msg: _log.warning("MuJoCo: %s", msg))


def _mujoco_urdf(text: str) -> str:
    """The URDF with MuJoCo's compiler options inserted (what a <mujoco> URDF extension does);
    a <mujoco> element the URDF has already (the bundled closed chains') is replaced: MuJoCo
    refuses two, and these options include its fusestatic/discardvisual."""
    opts = ('<mujoco><compiler balanceinertia="false" inertiafromgeom="false" fusestatic="false" '
            'discardvisual="true" autolimits="true"/></mujoco>')
    text = re.sub(r"<!--.*?-->", "", text, flags=re.S)  # a comment may name <robot> or <mujoco>
    text = re.sub(r"<mujoco\b[^>]*/>|<mujoco\b.*?</mujoco>", "", text, count=1, flags=re.S)
    # no contacts, so no geoms: a collision mesh MuJoCo cannot open (package://) is dropped too
    text = re.sub(r"<collision\b[^>]*/>|<collision\b.*?</collision>", "", text, flags=re.S)
    start = text.find("<robot")
    end = text.find(">", start)
    if start < 0 or end < 0:
        raise ConfigError("URDF without a <robot> element")
    return text[:end + 1] + opts + text[end + 1:]


def _set_inertial(body, rb: RigidBody) -> None:
    I = rb.inertia
    body.explicitinertial = True
    body.mass = rb.mass
    body.ipos = rb.com
    body.fullinertia = [I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]]


def _weld(spec: mujoco.MjSpec, locked: dict[str, float]) -> None:
    """Each locked joint's body moved to the joint's value (a slide along, a hinge about its
    axis in the body frame), then the joint and any equality naming it deleted."""
    for eq in [e for e in spec.equalities if e.name1 in locked or e.name2 in locked]:
        spec.delete(eq)
    for name, value in locked.items():
        joint = spec.joint(name)
        if joint is None:
            raise ConfigError(f"locked joint {name!r} is not a joint of the MuJoCo model")
        body, axis = joint.parent, np.asarray(joint.axis, float)
        R = np.empty(9)
        mujoco.mju_quat2Mat(R, np.asarray(body.quat, float))
        if joint.type == mujoco.mjtJoint.mjJNT_SLIDE:
            body.pos = np.asarray(body.pos, float) + R.reshape(3, 3) @ axis * value
        else:
            turn, quat = np.empty(4), np.empty(4)
            mujoco.mju_axisAngle2Quat(turn, axis / np.linalg.norm(axis), value)
            mujoco.mju_mulQuat(quat, np.asarray(body.quat, float), turn)
            body.quat = quat
        spec.delete(joint)


def build_spec(truth: ArmTruth, payload: ArmPayload | None = None) -> mujoco.MjSpec:
    """The MuJoCo specification of the arm with the truth's numbers (and ``payload`` as a body
    welded to its frame)."""
    try:
        spec = mujoco.MjSpec.from_string(_mujoco_urdf(truth.arm.urdf_text))
    except ValueError as exc:
        raise ConfigError(f"MuJoCo cannot load {truth.arm.urdf_path}: {exc}") from None
    _weld(spec, truth.arm.locked)
    spec.option.timestep = TIMESTEP
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_RK4
    spec.option.gravity = [0.0, 0.0, -truth.gravity]
    off = mujoco.mjtDisableBit
    # no contacts, no joint-limit constraints, and no silent reset to q = 0 on a diverged state
    spec.option.disableflags |= off.mjDSBL_CONTACT | off.mjDSBL_LIMIT | off.mjDSBL_AUTORESET
    for body in spec.bodies:
        if body.name in truth.bodies:
            _set_inertial(body, truth.bodies[body.name])
    for name, drive in truth.drives.items():
        joint = spec.joint(name)
        joint.limited = mujoco.mjtLimited.mjLIMITED_FALSE
        joint.armature = drive.armature
        joint.damping = [drive.damping] + [0.0] * (len(joint.damping) - 1)
        joint.frictionloss = drive.frictionloss
        joint.solref_friction = [FRICTION_TIMECONST, 1.0]
    if payload is not None:
        frame = spec.body(payload.frame)
        if frame is None:
            raise ConfigError(f"payload frame {payload.frame!r} is not a link of {truth.arm.name}")
        _set_inertial(frame.add_body(name=PAYLOAD_BODY), payload.body)
    return spec


class JointStates:
    """The joint state of a MuJoCo plant (``model``, ``data``, ``dof``: its joints' velocity
    addresses, one DOF each), shared by the arm's and the coupled wrist's plants."""

    model: mujoco.MjModel
    data: mujoco.MjData
    dof: np.ndarray

    def reset(self, q: np.ndarray, qd: np.ndarray) -> None:
        mujoco.mj_resetData(self.model, self.data)
        self.data.qpos[self.dof] = q
        self.data.qvel[self.dof] = qd
        mujoco.mj_forward(self.model, self.data)

    @property
    def q(self) -> np.ndarray:
        return self.data.qpos[self.dof].copy()

    @property
    def qd(self) -> np.ndarray:
        return self.data.qvel[self.dof].copy()


class MujocoPlant(JointStates):
    """One MuJoCo model and data of the arm: the state, a step under held joint torques, inverse
    dynamics. Joint order: ``truth.arm.joint_names``; torques N·m (N), positions rad (m)."""

    def __init__(self, truth: ArmTruth, payload: ArmPayload | None = None):
        self.truth, self.payload = truth, payload
        route_warnings()
        self.model = build_spec(truth, payload).compile()
        self.data = mujoco.MjData(self.model)
        m = self.model
        ids = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, j) for j in truth.arm.joint_names]
        if m.nv != len(ids) or m.nq != m.nv:
            raise ConfigError(f"{truth.arm.name}: MuJoCo model has nq={m.nq}, nv={m.nv} for "
                              f"{len(ids)} actuated joints")
        self.dof = np.array([m.jnt_dofadr[i] for i in ids])
        self.offset = truth.drive_array("offset")
        worst = max(self.inertial_errors().items(), key=lambda kv: kv[1])
        if worst[1] > INERTIAL_TOLERANCE:  # MuJoCo must not have changed the truth's inertials
            raise ConfigError(f"MuJoCo changed the inertial of body {worst[0]} by {worst[1]:.1e} "
                              "(relative) while loading it")


    @property
    def time(self) -> float:
        return float(self.data.time)

    def step(self, tau: np.ndarray, nstep: int) -> None:
        """``nstep`` steps of TIMESTEP under the joint torques ``tau`` (n,) held constant; the
        joints' offset torques act against them (tau_motor = ... + tauoff)."""
        self.data.qfrc_applied[self.dof] = np.asarray(tau, float) - self.offset
        mujoco.mj_step(self.model, self.data, nstep)

    # dynamics --------------------------------------------------------------------------------
    def inverse_dynamics(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray,
                         friction: bool = False) -> np.ndarray:
        """(m, n) motor torques for samples (m, n): MuJoCo's mj_inverse (M(q) q̈ with armature,
        bias, damping) plus the offset; ``friction``: + frictionloss·sign(q̇), the soft
        constraint's value away from zero velocity (mj_inverse's own constraint force
        depends on the acceleration's history, not on the state alone)."""
        q, qd, qdd = (np.atleast_2d(np.asarray(x, float)) for x in (q, qd, qdd))
        m, d = self.model, mujoco.MjData(self.model)
        m_fl = m.dof_frictionloss.copy()
        m.dof_frictionloss[:] = 0.0
        try:
            out = np.empty_like(q)
            for k in range(q.shape[0]):
                d.qpos[self.dof], d.qvel[self.dof], d.qacc[self.dof] = q[k], qd[k], qdd[k]
                mujoco.mj_inverse(m, d)
                out[k] = d.qfrc_inverse[self.dof]
        finally:
            m.dof_frictionloss[:] = m_fl
        out += self.offset
        if friction:
            out += m_fl[self.dof] * np.sign(qd)
        return out

    def body_inertial(self, name: str) -> RigidBody:
        """A body's inertial as MuJoCo holds it after compiling (mass, body_ipos, and the full
        inertia rebuilt from its principal moments body_inertia and axes body_iquat)."""
        i = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_BODY, name)
        if i < 0:
            raise ConfigError(f"no body {name!r} in the MuJoCo model")
        R = np.empty(9)
        mujoco.mju_quat2Mat(R, self.model.body_iquat[i])
        R = R.reshape(3, 3)
        return RigidBody(float(self.model.body_mass[i]), self.model.body_ipos[i].copy(),
                         R @ np.diag(self.model.body_inertia[i]) @ R.T)

    def inertial_errors(self) -> dict[str, float]:
        """Relative error of every body's mass, CoM and full inertia against the truth (and the
        payload's): max over the 10 numbers of |MuJoCo - truth| / max(|truth|)."""
        expected = dict(self.truth.bodies)
        if self.payload is not None:
            expected[PAYLOAD_BODY] = self.payload.body
        errs = {}
        for name, rb in expected.items():
            got = self.body_inertial(name)
            a = np.concatenate([[got.mass], got.com, got.inertia.ravel()])
            b = np.concatenate([[rb.mass], rb.com, rb.inertia.ravel()])
            errs[name] = float(
                np.max(np.abs(a - b) / np.maximum(np.abs(b), 1e-300 + np.abs(b).max() * 1e-3))
            )
        return errs
