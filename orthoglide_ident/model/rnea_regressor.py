"""The tree's joint-torque regressor by recursive Newton–Euler, vectorised over samples.

What Pinocchio's ``computeJointTorqueRegressor``, ``frameBodyRegressor`` and
``computeFrameJacobian(..., LOCAL)`` give for one state, here for m states at once with a few
hundred numpy passes per chunk instead of m Python calls (the open tree's rows behind the
paper's eqs. 15 and 18 at every sample; the recursive regressor of Khalil & Dombre):

- forward, from the base: each joint's placement ``liMi`` = jointPlacement · joint(q), the body
  velocity v_i = liMiᵀ v_λ(i) + S_i q̇_i and acceleration a_i = liMiᵀ a_λ(i) + S_i q̈_i +
  v_i × S_i q̇_i, with a_0 = -g (gravity as an acceleration of the base, as Pinocchio), and the
  body's LOCAL Jacobian J_i = liMiᵀ J_λ(i) + S_i (a column per joint on its path to the base);
- per body, the 6 × 10 regressor Φ_i(v_i, a_i) with I a + v ×* I v = Φ_i π_i, and body i's
  columns of joint j's row: J_i[:, j]ᵀ Φ_i (the force Φ_i π_i carried back to joint j and
  projected on its axis, i.e. S_jᵀ (jXi)* Φ_i, in one product), computed from v_i, a_i and J_i
  without forming Φ_i (:meth:`RneaRegressor._efforts`).

Layout: samples last — a motion or force is (6, m) as [linear; angular] in the body frame, a
rotation (3, 3, m) — so that every operation is elementwise over long contiguous rows. A body's
parameters π = [m, mc_x, mc_y, mc_z, I_xx, I_xy, I_yy, I_xz, I_yz, I_zz] at the joint origin
(Pinocchio's ``toDynamicParameters`` order). Joints: the 1-DOF ones (revolute, unbounded
revolute, prismatic, any axis); :func:`supported` says whether a model has only those
(tree_regressor.py keeps Pinocchio's per-sample path for the others).
tests/model/test_rnea_regressor.py checks every output against Pinocchio's to 1e-12.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from orthoglide_ident.model.tree import _PRISMATIC, _REVOLUTE, _UNBOUNDED

_INERTIA_UNITS = ((0, 0), (0, 1), (1, 1), (0, 2), (1, 2), (2, 2))  # xx xy yy xz yz zz


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a × b along axis 0 of (3, ...) arrays (broadcast over the other axes)."""
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    for i, j, k in ((0, 1, 2), (1, 2, 0), (2, 0, 1)):
        np.multiply(a[j], b[k], out=out[i])
        out[i] -= a[k] * b[j]
    return out


def _rotate(R: np.ndarray, x: np.ndarray, transpose: bool = False) -> np.ndarray:
    """R x (or Rᵀ x) of vectors x (3, ..., m) by rotations R (3, 3, m)."""
    if transpose:
        R = R.transpose(1, 0, 2)
    extra = (None,) * (x.ndim - 2)  # broadcast a rotation entry over x's middle axes
    out = np.empty(x.shape)
    for i in range(3):
        np.multiply(R[i, 0][extra], x[0], out=out[i])
        out[i] += R[i, 1][extra] * x[1]
        out[i] += R[i, 2][extra] * x[2]
    return out


@dataclass
class Placement:
    """Rigid transforms of m samples, parent ← child: rotations R (3, 3, m), origins p (3, m)."""

    R: np.ndarray
    p: np.ndarray

    def act_inv(self, v: np.ndarray) -> np.ndarray:
        """Motions (6, ..., m) of the parent frame expressed in the child frame."""
        p = self.p[(slice(None),) + (None,) * (v.ndim - 2)]
        w = _rotate(self.R, v[3:], transpose=True)
        lin = _rotate(self.R, v[:3] - _cross(p, v[3:]), transpose=True)
        return np.concatenate([lin, w])


def motion_cross(v: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Spatial motion cross product v × u of (6, m) motions."""
    return np.concatenate([_cross(v[3:], u[:3]) + _cross(v[:3], u[3:]), _cross(v[3:], u[3:])])


def body_regressor(v: np.ndarray, a: np.ndarray) -> np.ndarray:
    """Φ (6, 10, m) with I a + v ×* (I v) = Φ π for motions v, a (6, m) (``pin.bodyRegressor``)."""
    m = v.shape[1]
    lin, w = v[:3], v[3:]
    alpha = a[3:]
    Y = np.zeros((6, 10, m))
    a_t = a[:3] + _cross(w, lin)  # acceleration of the point at the origin
    Y[:3, 0] = a_t
    for k in range(3):  # m c_k: α × e_k + ω × (ω × e_k) (linear), e_k × ã (angular)
        e = np.zeros((3, 1))
        e[k] = 1.0
        Y[:3, 1 + k] = _cross(alpha, e) + _cross(w, _cross(w, e))
        Y[3:, 1 + k] = _cross(e, a_t)
    for col, (i, j) in enumerate(_INERTIA_UNITS, 4):  # I α + ω × (I ω) for the unit I_ij
        ea, ew = np.zeros((3, m)), np.zeros((3, m))
        ea[i], ea[j] = alpha[j], alpha[i]
        ew[i], ew[j] = w[j], w[i]
        Y[3:, col] = ea + _cross(w, ew)
    return Y


def _combine(E: np.ndarray, P: np.ndarray) -> np.ndarray:
    """Efforts (k, n, m) of parameter vectors P (10, k) from the unit ones E (10, n, m): a
    gather when P's columns are unit vectors (plain regressor columns)."""
    if np.all(np.sum(P != 0.0, axis=0) == 1) and np.all(P.max(axis=0) == 1.0):
        return E[np.argmax(P, axis=0)]
    return np.tensordot(P, E, axes=([0], [0]))


@dataclass(frozen=True)
class _Joint:
    parent: int  # Pinocchio id of the parent joint (0: the base)
    path: tuple[int, ...]  # velocity indices of the joints from the base to this one
    R0: np.ndarray  # jointPlacement (parent joint frame ← this joint's zero frame)
    p0: np.ndarray
    S: np.ndarray  # (6,) motion subspace in the child frame
    iq: int
    iv: int
    kind: str  # "revolute" | "continuous" | "prismatic"


@dataclass
class Kinematics:
    """Per Pinocchio joint j (list index j): the body velocity and acceleration with gravity
    (6, m), the body's LOCAL Jacobian over its path's joints (6, len(path), m). Index 0 is the
    base (velocity 0, acceleration -g, no Jacobian)."""

    v: list
    a: list
    J: list


def supported(model: pin.Model) -> bool:
    """Whether every joint of ``model`` is a 1-DOF revolute or prismatic joint."""
    known = _PRISMATIC + _REVOLUTE + _UNBOUNDED
    return all(model.joints[j].shortname() in known for j in range(1, model.njoints))


class RneaRegressor:
    """Vectorised tree regressors of one Pinocchio model (1-DOF joints only)."""

    def __init__(self, model: pin.Model):
        if not supported(model):
            raise ValueError("the vectorised regressor takes 1-DOF revolute/prismatic joints only")
        self.model = model
        self.joints: list[_Joint | None] = [None]
        for j in range(1, model.njoints):
            jm = model.joints[j]
            name = jm.shortname()
            jd = jm.createData()
            jm.calc(jd, pin.neutral(model)[jm.idx_q:jm.idx_q + jm.nq])
            parent = int(model.parents[j])
            path = (self.joints[parent].path if parent else ()) + (jm.idx_v,)
            kind = "prismatic" if name in _PRISMATIC else \
                "continuous" if name in _UNBOUNDED else "revolute"
            pl = model.jointPlacements[j]
            self.joints.append(_Joint(parent, path, pl.rotation.copy(), pl.translation.copy(),
                                      np.array(jd.S).reshape(6), jm.idx_q, jm.idx_v, kind))
        self.gravity = np.array(model.gravity.vector)  # [linear; angular]

    def _placement(self, jt: _Joint, Q: np.ndarray) -> Placement:
        """liMi = jointPlacement · joint(q) for configurations Q (nq, m)."""
        m = Q.shape[1]
        if jt.kind == "prismatic":
            R = np.broadcast_to(jt.R0[:, :, None], (3, 3, m))
            return Placement(R, jt.p0[:, None] + np.outer(jt.R0 @ jt.S[:3], Q[jt.iq]))
        if jt.kind == "continuous":
            c, s = Q[jt.iq], Q[jt.iq + 1]
        else:
            c, s = np.cos(Q[jt.iq]), np.sin(Q[jt.iq])
        u = jt.S[3:]
        K = np.array([[0.0, -u[2], u[1]], [u[2], 0.0, -u[0]], [-u[1], u[0], 0.0]])
        # R0 · Rodrigues(u, q) = R0 + sin q · R0 [u]× + (1 - cos q) · R0 [u]×²
        C1, C2 = jt.R0 @ K, jt.R0 @ K @ K
        R = jt.R0[:, :, None] + C1[:, :, None] * s + C2[:, :, None] * (1.0 - c)
        return Placement(R, np.broadcast_to(jt.p0[:, None], (3, m)))

    def kinematics(self, Q: np.ndarray, V: np.ndarray, A: np.ndarray) -> Kinematics:
        """The forward pass for samples Q (m, nq), V, A (m, nv)."""
        Q, V, A = Q.T, V.T, A.T
        m = Q.shape[1]
        kin = Kinematics([np.zeros((6, m))], [np.repeat(-self.gravity[:, None], m, 1)], [None])
        for jt in self.joints[1:]:
            X = self._placement(jt, Q)
            S = jt.S[:, None]
            vj = S * V[jt.iv]
            # the parent's v, a_gf and Jacobian columns into this frame, in one pass
            parent = [kin.v[jt.parent][:, None], kin.a[jt.parent][:, None]]
            if jt.parent:
                parent.append(kin.J[jt.parent])
            moved = X.act_inv(np.concatenate(parent, axis=1))
            v = moved[:, 0] + vj
            a = moved[:, 1] + S * A[jt.iv] + motion_cross(v, vj)
            J = np.empty((6, len(jt.path), m))
            J[:, :-1] = moved[:, 2:]
            J[:, -1] = S
            kin.v.append(v)
            kin.a.append(a)
            kin.J.append(J)
        return kin

    @staticmethod
    def _efforts(v: np.ndarray, a: np.ndarray, J: np.ndarray) -> np.ndarray:
        """J[:, j]ᵀ Φ(v, a) of each of the 10 parameters (10, len(path), m): the efforts of
        the joints on a body's path, J the body's LOCAL Jacobian (6, len(path), m).

        Φ is never formed: with J = [J_l; J_a], ã = a_l + ω × v_l, and (x × y)·z = x·(y × z),
        m → J_l·ã; mc_k → (J_l × α + (J_l × ω) × ω + ã × J_a)_k; the unit inertia I_ik →
        (I_ik α)·J_a + (I_ik ω)·(J_a × ω), i.e. α_k J_a,i + ω_k B_i (+ the same with i, k
        swapped when i ≠ k), B = J_a × ω."""
        e = (slice(None), None)  # a (3, m) vector against (3, n, m) Jacobian rows
        w, alpha = v[3:][e], a[3:][e]
        a_t = (a[:3] + _cross(v[3:], v[:3]))[e]
        Jl, Ja = J[:3], J[3:]
        out = np.empty((10,) + J.shape[1:])
        out[0] = (Jl * a_t).sum(axis=0)
        out[1:4] = _cross(Jl, alpha) + _cross(_cross(Jl, w), w) + _cross(a_t, Ja)
        B = _cross(Ja, w)
        for col, (i, k) in enumerate(_INERTIA_UNITS, 4):
            out[col] = alpha[k] * Ja[i] + w[k] * B[i]
            if i != k:
                out[col] += alpha[i] * Ja[k] + w[i] * B[k]
        return out

    def body_efforts(self, kin: Kinematics, joint: int, P: np.ndarray
                     ) -> tuple[tuple[int, ...], np.ndarray]:
        """The efforts of Pinocchio joint ``joint``'s body for the k parameter vectors P
        (10, k) (columns of the identity: plain regressor columns): (the velocity indices of
        the joints on its path, their efforts (k, len(path), m)); the other joints' are 0."""
        E = self._efforts(kin.v[joint], kin.a[joint], kin.J[joint])
        return self.joints[joint].path, _combine(E, P)

    def _at_frame(self, kin: Kinematics, frame_id: int
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Velocity, acceleration (6, m) and LOCAL Jacobian (6, len(path), m) at a frame."""
        frame = self.model.frames[frame_id]
        j, M = int(frame.parentJoint), frame.placement
        m = kin.v[j].shape[1]
        Xf = Placement(np.broadcast_to(M.rotation[:, :, None], (3, 3, m)),
                       np.broadcast_to(M.translation[:, None], (3, m)))
        return Xf.act_inv(kin.v[j]), Xf.act_inv(kin.a[j]), Xf.act_inv(kin.J[j])

    def frame(self, kin: Kinematics, frame_id: int) -> tuple[np.ndarray, np.ndarray]:
        """A frame's body regressor Φ_f (6, 10, m) and its LOCAL Jacobian over the path of its
        joint (6, len(path), m) (Pinocchio's frameBodyRegressor and LOCAL frame Jacobian)."""
        v, a, J = self._at_frame(kin, frame_id)
        return body_regressor(v, a), J

    def frame_efforts(self, kin: Kinematics, frame_id: int, P: np.ndarray
                      ) -> tuple[tuple[int, ...], np.ndarray]:
        """As :meth:`body_efforts` for a body fixed at frame ``frame_id`` (J_fᵀ Φ_f P)."""
        v, a, J = self._at_frame(kin, frame_id)
        path = self.joints[int(self.model.frames[frame_id].parentJoint)].path
        return path, _combine(self._efforts(v, a, J), P)

    def regressor(self, kin: Kinematics) -> np.ndarray:
        """The whole tree regressor (nv, 10 (njoints - 1), m), Pinocchio's column layout."""
        m = kin.v[0].shape[1]
        Y = np.zeros((self.model.nv, 10 * (self.model.njoints - 1), m))
        for j in range(1, self.model.njoints):
            path, E = self.body_efforts(kin, j, np.eye(10))
            Y[list(path), 10 * (j - 1):10 * j] = E.transpose(1, 0, 2)
        return Y
