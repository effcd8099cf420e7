"""The closed chain's truth on Pinocchio: the second implementation that checks the MuJoCo plant.

Pinocchio loads the same URDF; its bodies are replaced by the truth's rigid bodies (and a
payload) placed by their link frames, the actuated joints get the truth's armature, and the
loops are rigid constraints (``RigidConstraintModel``: CONTACT_3D for a point loop, CONTACT_6D
for a frame loop) solved exactly by ``constraintDynamics`` (proximal iterations: a planar
chain's point loop has a row that stays zero, which a plain KKT solve cannot take). The tree
joints' friction enters as joint torques: -fv q̇ - tauoff [- fs sign(q̇)].

``standard_vector`` maps the truth onto the product's standard parameters (``RobotModel``
names ``xx_<label>`` ... ``tauoff_<label>``), so that the general model's rows times it are
the truth's actuated torques.

Layouts: tree states (q, v, a) in Pinocchio's joint order (= the URDF's movable joints,
``truth.arm.tree_joints``); actuated torques in ``truth.arm.joint_names`` order.
"""
from __future__ import annotations

import numpy as np
import pinocchio as pin

from orthoglide_ident.errors import ConfigError
from orthoglide_sim.arms.pinocchio_truth import pin_inertia
from orthoglide_sim.arms.truth import ArmPayload
from orthoglide_sim.chains.truth import ChainTruth

PROXIMAL = (1e-13, 1e-10, 50)  # accuracy, mu, iterations of constraintDynamics' proximal solver


def chain_model(truth: ChainTruth, payload: ArmPayload | None = None) -> pin.Model:
    """Pinocchio's model of the URDF with the truth's bodies, payload and actuated armature."""
    arm = truth.arm
    try:
        model = pin.buildModelFromXML(arm.urdf_text)
    except (RuntimeError, ValueError) as exc:
        raise ConfigError(f"Pinocchio cannot load {arm.urdf_path}: {exc}") from None
    model.gravity = pin.Motion(np.asarray(arm.gravity, float), np.zeros(3))
    names = [model.names[i] for i in range(1, model.njoints)]
    if names != list(arm.tree_joints) or model.nv != len(names):
        raise ConfigError(
            f"{arm.name}: Pinocchio's joints {names} are not the tree's {arm.tree_joints}"
        )
    inertias = [pin.Inertia.Zero() for _ in range(model.njoints)]
    attached = list(truth.bodies.items()) + ([(payload.frame, payload.body)] if payload else [])
    for link, rb in attached:
        f = model.frames[model.getFrameId(link)]
        inertias[f.parentJoint] = inertias[f.parentJoint] + f.placement.act(pin_inertia(rb))
    for i in range(1, model.njoints):
        model.inertias[i] = inertias[i]
    for j in arm.joint_names:
        model.armature[model.joints[model.getJointId(j)].idx_v] = truth.drives[j].armature
    return model


class ChainDynamics:
    """Exact constrained forward dynamics of the truth (Pinocchio), per state."""

    def __init__(self, truth: ChainTruth, payload: ArmPayload | None = None):
        self.truth = truth
        self.model = model = chain_model(truth, payload)
        self.data = model.createData()
        arm = truth.arm
        iv = {model.names[i]: model.joints[i].idx_v for i in range(1, model.njoints)}
        self.S_a = np.array([iv[j] for j in arm.joint_names])
        self.fv, self.fs, self.tauoff = (np.zeros(model.nv) for _ in range(3))
        for j in arm.joint_names:
            d = truth.drives[j]
            self.fv[iv[j]], self.fs[iv[j]], self.tauoff[iv[j]] = d.damping, d.frictionloss, d.offset
        for j in arm.passive_names:
            p = truth.passive[j]
            self.fv[iv[j]], self.fs[iv[j]], self.tauoff[iv[j]] = p.damping, p.frictionloss, p.offset
        kinds = {"point": pin.ContactType.CONTACT_3D, "frame": pin.ContactType.CONTACT_6D}
        models = []
        for loop in arm.loops:
            a, b = (model.frames[model.getFrameId(f)] for f in (loop.frame_a, loop.frame_b))
            models.append(
                pin.RigidConstraintModel(
                    kinds[loop.kind],
                    model,
                    a.parentJoint,
                    a.placement,
                    b.parentJoint,
                    b.placement,
                    pin.ReferenceFrame.LOCAL,
                )
            )
        self.constraints = pin.StdVec_RigidConstraintModel(models)
        self.constraint_data = pin.StdVec_RigidConstraintData([c.createData() for c in models])
        pin.initConstraintDynamics(model, self.data, self.constraints, self.constraint_data)
        self.prox = pin.ProximalSettings(*PROXIMAL)

    def tree_torque(self, v: np.ndarray, tau_a: np.ndarray, friction: bool = False) -> np.ndarray:
        """(nv,) joint torques: the actuated ones on their joints, every joint's friction."""
        tau = -self.fv * v - self.tauoff - (self.fs * np.sign(v) if friction else 0.0)
        tau[self.S_a] += tau_a
        return tau

    def forward(
        self, q: np.ndarray, v: np.ndarray, tau_a: np.ndarray, friction: bool = False
    ) -> np.ndarray:
        """(nv,) tree accelerations under actuated torques ``tau_a`` with the loops held rigid."""
        return pin.constraintDynamics(
            self.model,
            self.data,
            q,
            v,
            self.tree_torque(v, tau_a, friction),
            self.constraints,
            self.constraint_data,
            self.prox,
        ).copy()

    def rk4(self, q: np.ndarray, v: np.ndarray, tau_a: np.ndarray, dt: float,
            n: int) -> tuple[np.ndarray, np.ndarray]:
        """n RK4 steps of dt under tau_a held (friction loss off): the state (q, v) after them."""
        for _ in range(n):
            k1q, k1v = v, self.forward(q, v, tau_a)
            k2q, k2v = (
                v + 0.5 * dt * k1v,
                self.forward(q + 0.5 * dt * k1q, v + 0.5 * dt * k1v, tau_a),
            )
            k3q, k3v = (
                v + 0.5 * dt * k2v,
                self.forward(q + 0.5 * dt * k2q, v + 0.5 * dt * k2v, tau_a),
            )
            k4q, k4v = v + dt * k3v, self.forward(q + dt * k3q, v + dt * k3v, tau_a)
            q = q + dt / 6.0 * (k1q + 2 * k2q + 2 * k3q + k4q)
            v = v + dt / 6.0 * (k1v + 2 * k2v + 2 * k3v + k4v)
        return q, v


def standard_vector(truth: ChainTruth, robot) -> np.ndarray:
    """χ_st of the truth in ``robot.standard_names`` order (robot: the product's PinocchioRobot
    of the same description): each body's 10 inertial parameters at its link frame, each
    joint's ia, fv, fs, tauoff. (A payload is the model's known column: ``with_payload``.)"""
    arm = truth.arm
    bodies = {b["label"]: b for b in robot.to_json()["bodies"]}
    link_joint = {j.child: j.name for j in arm.joints + arm.passive}
    values = {}
    for label, b in bodies.items():
        rb_std = truth.bodies[b["link"]].standard() if b["link"] in truth.bodies else np.zeros(10)
        for k, kind in enumerate(("xx", "xy", "xz", "yy", "yz", "zz", "mx", "my", "mz", "m")):
            values[f"{kind}_{label}"] = rb_std[k]
        joint = b["joint"] or link_joint.get(b["link"])
        fr = truth.drives.get(joint) or truth.passive.get(joint)
        if fr is not None:
            values[f"fv_{label}"], values[f"fs_{label}"] = fr.damping, fr.frictionloss
            values[f"tauoff_{label}"] = fr.offset
            values[f"ia_{label}"] = getattr(fr, "armature", 0.0)
    missing = [n for n in robot.standard_names if n not in values]
    if missing:
        raise ConfigError(f"standard_vector: no truth for {missing}")
    return np.array([values[n] for n in robot.standard_names])


def rigid_loop_currents(truth: ChainTruth, payload: ArmPayload | None, q_ref: np.ndarray,
                        qd_ref: np.ndarray, qdd_ref: np.ndarray) -> np.ndarray:
    """v_tau (N, n_a) A of the simulator's PID (chain_record.tuned_pid) driving the rigid-loop
    truth along the reference (N, n_a), no noise, no friction loss: ChainDynamics.rk4 at the
    plant's step, the loop re-closed after each tick (MuJoCo's kinematics: ChainPlant.assemble).
    What a rigid five-bar needs; the MuJoCo plant's currents on the same run differ from them
    by the loop's softness alone when the truth has no friction loss and exact encoders."""
    from orthoglide_sim.arms import simulator as asim
    from orthoglide_sim.arms.plant import TIMESTEP
    from orthoglide_sim.chains.plant import ChainPlant
    from orthoglide_sim.chains.record import tuned_pid
    from orthoglide_sim.common.closed_loop import quantise

    plant, dyn = ChainPlant(truth, payload), ChainDynamics(truth, payload)
    pid = tuned_pid(plant, q_ref[0], qd_ref[0], qdd_ref[0])
    plant.reset(q_ref[0], qd_ref[0])
    q, v = plant.data.qpos.copy(), plant.data.qvel.copy()
    g, res = truth.drive_array("g_tau"), truth.encoder_resolution
    out = np.empty_like(q_ref)
    for k in range(len(q_ref)):
        out[k] = pid.current(quantise(q[plant.dof], res), q_ref[k], qd_ref[k])
        q, v = dyn.rk4(q, v, g * out[k], TIMESTEP, asim.SUBSTEPS)
        q = plant.assemble(q[plant.dof], q)
        v = plant.rate_map(q) @ v[plant.dof]
    return out
