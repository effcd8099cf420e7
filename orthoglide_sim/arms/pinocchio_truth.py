"""The serial arm on Pinocchio: the truth's inverse dynamics (the second implementation that
checks the MuJoCo plant) and the URDF's joint-torque regressor with drive columns (what the
excitation optimiser conditions, until the product's general model takes its place).

Pinocchio's URDF parser merges links fixed to a moving one into that joint's body; the truth's
rigid bodies (and a payload) are merged the same way here, each placed by its link frame.

Layouts: samples q, qd, qdd (m, n) in ``arm.joint_names`` order; the regressor is (n m, p) with
rows stacked joint by joint (eq. 20: joint 0's m samples, then joint 1's, ...). Standard
parameters per body in Pinocchio's order [m, mx, my, mz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz] about the
joint origin in the joint frame, then per joint [ia, fv, fs, tauoff] (paper Sect. 2.2).
"""
from __future__ import annotations

import numpy as np
import pinocchio as pin
from scipy.linalg import qr

from orthoglide_ident.errors import ConfigError
from orthoglide_sim.arms.description import ArmDescription
from orthoglide_sim.arms.truth import GRAVITY, ArmPayload, ArmTruth, RigidBody

PIN_INERTIAL = ("m", "mx", "my", "mz", "xx", "xy", "yy", "xz", "yz", "zz")
DRIVE = ("ia", "fv", "fs", "tauoff")


def urdf_model(arm: ArmDescription, gravity: float) -> tuple[pin.Model, np.ndarray]:
    """Pinocchio's model of the URDF (its own inertials) and the v-indices of the actuated
    joints."""
    try:
        model = pin.buildModelFromXML(arm.urdf_text)
    except (RuntimeError, ValueError) as exc:
        raise ConfigError(f"Pinocchio cannot load {arm.urdf_path}: {exc}") from None
    model.gravity = pin.Motion(np.array([0.0, 0.0, -gravity]), np.zeros(3))
    idx = np.array([model.joints[model.getJointId(j)].idx_v for j in arm.joint_names])
    if model.nv != arm.n or sorted(idx) != list(range(arm.n)):
        raise ConfigError(
            f"{arm.name}: Pinocchio model has nv={model.nv} for {arm.n} actuated joints"
        )
    return model, idx


def pin_inertia(rb: RigidBody) -> pin.Inertia:
    return pin.Inertia(rb.mass, np.asarray(rb.com, float), np.asarray(rb.inertia, float))


def truth_model(truth: ArmTruth, payload: ArmPayload | None = None) -> tuple[pin.Model, np.ndarray]:
    """Pinocchio's model of the URDF with every body replaced by the truth's links (and payload)
    fixed to it, and the truth's armature."""
    model, idx = urdf_model(truth.arm, truth.gravity)
    attached = [(link, rb) for link, rb in truth.bodies.items()]
    if payload is not None:
        attached.append((payload.frame, payload.body))
    inertias = [pin.Inertia.Zero() for _ in range(model.njoints)]
    for link, rb in attached:
        if not model.existFrame(link):
            raise ConfigError(f"{truth.arm.name}: no frame {link!r} in the Pinocchio model")
        f = model.frames[model.getFrameId(link)]
        inertias[f.parentJoint] = inertias[f.parentJoint] + f.placement.act(pin_inertia(rb))
    for i in range(1, model.njoints):
        model.inertias[i] = inertias[i]
    model.armature[idx] = truth.drive_array("armature")
    return model, idx


class TruthDynamics:
    """tau = RNEA(q, q̇, q̈) (with armature) + fv q̇ + tauoff [+ fs sign(q̇)] of the truth, per
    sample."""

    def __init__(self, truth: ArmTruth, payload: ArmPayload | None = None):
        self.model, self.idx = truth_model(truth, payload)
        self.data = self.model.createData()
        self.fv, self.fs = truth.drive_array("damping"), truth.drive_array("frictionloss")
        self.tauoff = truth.drive_array("offset")

    def torques(
        self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, friction: bool = False
    ) -> np.ndarray:
        """(m, n) joint torques for samples (m, n)."""
        q, qd, qdd = (np.atleast_2d(np.asarray(x, float)) for x in (q, qd, qdd))
        out = np.empty_like(q)
        inv = np.argsort(self.idx)  # model v-index -> actuated joint
        for k in range(q.shape[0]):
            out[k] = pin.rnea(self.model, self.data, q[k][inv], qd[k][inv], qdd[k][inv])[self.idx]
        out += self.fv * qd + self.tauoff
        return out + self.fs * np.sign(qd) if friction else out


class ArmRegressor:
    """The URDF's standard joint-torque regressor with drive columns, and its base columns.

    ``standard(q, qd, qdd)``: (n m, 10 n + 4 n) with Pinocchio's computeJointTorqueRegressor
    for the bodies and [q̈_j, q̇_j, sign(q̇_j), 1] for the joints' drives. ``base(...)``: the
    columns independent over random states (pivoted QR, the standard way), which the excitation
    criterion cond(W) needs (a regroupable column makes W rank-deficient).
    """

    def __init__(
        self, arm: ArmDescription, gravity: float = GRAVITY, n_random: int = 400, seed: int = 0
    ):
        self.arm = arm
        self.model, self.idx = urdf_model(arm, gravity)
        self.data = self.model.createData()
        bodies = [self.model.names[i] for i in range(1, self.model.njoints)]
        self.names = tuple(f"{k}_{b}" for b in bodies for k in PIN_INERTIAL) + \
            tuple(f"{k}_{j}" for j in arm.joint_names for k in DRIVE)
        rng = np.random.default_rng(seed)
        lo = np.array([max(j.lower, -np.pi) for j in arm.joints])
        hi = np.array([min(j.upper, np.pi) for j in arm.joints])
        q = rng.uniform(lo, hi, (n_random, arm.n))
        W = self.standard(q, rng.normal(size=q.shape), rng.normal(size=q.shape))
        _, R, perm = qr(W, mode="economic", pivoting=True)
        d = np.abs(np.diag(R))
        rank = int(np.sum(d > d[0] * 1e-9))
        self.base_columns = np.sort(perm[:rank])

    def standard(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        """W_st (n m, p_st), rows joint by joint; tau = W_st pi_st (``standard_vector``)."""
        q, qd, qdd = (np.atleast_2d(np.asarray(x, float)) for x in (q, qd, qdd))
        m, n = q.shape
        nb = 10 * (self.model.njoints - 1)
        Y = np.zeros((m, n, nb + 4 * n))
        inv = np.argsort(self.idx)  # model v-index -> actuated joint
        for k in range(m):
            args = [s[k][inv] for s in (q, qd, qdd)]
            Y[k, :, :nb] = pin.computeJointTorqueRegressor(self.model, self.data, *args)[self.idx]
        j = np.arange(n)
        for c, col in enumerate((qdd, qd, np.sign(qd), np.ones_like(q))):
            Y[:, j, nb + 4 * j + c] = col
        return Y.transpose(1, 0, 2).reshape(n * m, -1)

    def base(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        """W (n m, p_b): the independent columns of ``standard``."""
        return self.standard(q, qd, qdd)[:, self.base_columns]

    def standard_vector(self, truth: ArmTruth, payload: ArmPayload | None = None) -> np.ndarray:
        """pi_st of the truth (and payload) in ``names`` order: W_st pi_st = TruthDynamics with
        friction."""
        model, _ = truth_model(truth, payload)
        inertial = [model.inertias[i].toDynamicParameters() for i in range(1, model.njoints)]
        drives = [[d.armature, d.damping, d.frictionloss, d.offset]
                  for d in (truth.drives[j] for j in self.arm.joint_names)]
        return np.concatenate([np.concatenate(inertial), np.concatenate(drives)])
