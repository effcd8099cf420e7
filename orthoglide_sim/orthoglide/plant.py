"""Closed-loop Orthoglide dynamics on Pinocchio: three P + 4R legs closed on the platform.

Independent of the identification model (orthoglide_ident.model: Newton-Euler on the virtual tree,
loop closure by J_t = J_k^-1 J_tk J_p, regressor): here Pinocchio's spatial-algebra algorithms
solve the constrained forward dynamics of the real topology.

- The tree: per leg i, a prismatic joint q1i (body 1, the foot) and four revolute pivots q2i..q5i
  (bodies 2..5), placed with the MDH transforms of Tables 1-2 (docs/design/conventions.md). The
  platform
  (body 6) and payload (body 7) are fixed to body 5 of leg 1 at P; the rotor inertia ia is each
  actuator's armature. Gravity g = +9.80665 m/s² along y0.
- The loops: body 5 of legs 2 and 3 is welded to the platform by two 6D Pinocchio constraint
  models (RigidConstraintModel CONTACT_6D), 15 - 12 = 3 degrees of freedom. ``constraintDynamics``
  returns the tree accelerations under the actuator forces and joint friction.
- Friction of every tree joint j (actuated and passive) is a generalised force against q_tj:
  fv qd_tj + fs s(qd_tj) + tauoff, with s = tanh(qd / v_s) (real drives' Coulomb friction turns
  smoothly through zero velocity) or sign() (the identification model's, for the agreement test).

Layouts: Pinocchio's configuration and velocity vectors are leg by leg, (q11..q51, q12..q52,
q13..q53); the public functions take the actuator coordinates q, qd, qdd, tau as (3,) or (N, 3).
"""
from __future__ import annotations

import numpy as np
import pinocchio as pin

from orthoglide_sim.orthoglide import kinematics as kin
from orthoglide_sim.orthoglide.truth import INERTIAL, TrueParameters

N_TREE = 15  # tree joints: 3 legs x (1 prismatic + 4 pivots)
ACTUATED = np.array([0, 5, 10])  # velocity indices of q11, q12, q13 in the tree
_HP = 0.5 * np.pi


def _mdh(
    gamma: float, b: float, alpha: float, d: float, theta: float = 0.0, r: float = 0.0
) -> pin.SE3:
    """Constant part of an MDH transform: Rot(z, gamma) Trans(z, b) Rot(x, alpha) Trans(x, d)
    Trans(z, r) Rot(z, theta); the joint variable then moves along / about the new z axis."""
    def rot(axis: str, t: float) -> np.ndarray:
        c, s = np.cos(t), np.sin(t)
        if axis == "x":
            return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])
        return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])

    T = pin.SE3(rot("z", gamma), np.array([0.0, 0.0, b])) * pin.SE3(
        rot("x", alpha), np.array([d, 0.0, 0.0])
    )
    return T * pin.SE3(rot("z", theta), np.array([0.0, 0.0, r]))


# Table 1 (feet, r of 1_3 = q13 - a) and Table 2 (pivots 2..5 of every leg).
FOOT_PLACEMENTS = (_mdh(0.0, 0.0, 0.0, 0.0), _mdh(_HP, kin.A, _HP, 0.0, 0.0, -kin.A),
                   _mdh(0.0, kin.A, -_HP, 0.0, -_HP, -kin.A))
PIVOT_PLACEMENTS = (
    _mdh(0.0, 0.0, -_HP, 0.0),
    _mdh(0.0, 0.0, -_HP, 0.0),
    _mdh(0.0, 0.0, 0.0, kin.D4),
    _mdh(0.0, 0.0, _HP, 0.0),
)


def platform_in_body5(leg: int) -> pin.SE3:
    """Pose of the platform frame (parallel to the base, origin P) in body 5 of leg ``leg`` (0..2).

    On the closed loop body 5 has the orientation R_1i Rot(x, -pi/2) and its origin is C_i =
    P - d6 e_i, so P is at d6 e_i, i.e. (0, -d6, 0) in body-5 coordinates.
    """
    R5 = kin.R_FOOT[leg] @ np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])
    return pin.SE3(R5.T, R5.T @ (kin.D6 * kin.E_AXIS[leg]))


def _inertia(v: np.ndarray) -> pin.Inertia:
    """Pinocchio inertia from the 10 standard parameters xx, xy, xz, yy, yz, zz, mx, my, mz, m
    (inertia at the frame origin, first moments in the frame)."""
    xx, xy, xz, yy, yz, zz, mx, my, mz, m = v
    return pin.Inertia.FromDynamicParameters(np.array([m, mx, my, mz, xx, xy, yy, xz, yz, zz]))


class Plant:
    """The true robot carrying a payload: forward dynamics, energy, tree state, per-step calls.

    One Pinocchio ``Model``/``Data`` per instance (not thread-safe: one plant per thread).
    ``coulomb``: "smooth" (tanh, the plant) or "sign" (the identification model's friction).
    """

    def __init__(
        self, params: TrueParameters, payload: str | float | None = "none", coulomb: str = "smooth"
    ):
        if coulomb not in ("smooth", "sign"):
            raise ValueError(f"coulomb must be 'smooth' or 'sign', got {coulomb!r}")
        self.params = params
        self.coulomb = coulomb
        self.payload_vector = params.payload_vector(payload)
        self.model, self._joint5 = self._build_tree(params, self.payload_vector)
        self.data = self.model.createData()
        self.constraints = pin.StdVec_RigidConstraintModel([
            pin.RigidConstraintModel(pin.ContactType.CONTACT_6D, self.model, self._joint5[leg],
                                     platform_in_body5(leg), self._joint5[0], platform_in_body5(0),
                                     pin.ReferenceFrame.LOCAL)
            for leg in (1, 2)])
        self.constraint_data = pin.StdVec_RigidConstraintData(
            [c.createData() for c in self.constraints]
        )
        pin.initConstraintDynamics(self.model, self.data, self.constraints, self.constraint_data)
        self.prox = pin.ProximalSettings(1e-12, 0.0, 1)  # mu = 0: the exact KKT solution
        table = [[[params.values[f"{kind}_{j}{i}"] for j in range(1, 6)] for i in (1, 2, 3)]
                 for kind in ("fv", "fs", "tauoff")]
        self.fv, self.fs, self.tauoff = (np.ravel(t) for t in table)
        self.v_s = np.tile(
            [params.coulomb_velocity["prismatic"]] + 4 * [params.coulomb_velocity["revolute"]], 3
        )

    @staticmethod
    def _build_tree(params: TrueParameters, chi_l: np.ndarray) -> tuple[pin.Model, list[int]]:
        model = pin.Model()
        model.gravity = pin.Motion(kin.GRAVITY, np.zeros(3))
        joint5 = []
        for i in (1, 2, 3):
            parent = 0
            for j in range(1, 6):
                joint = pin.JointModelPZ() if j == 1 else pin.JointModelRZ()
                placement = FOOT_PLACEMENTS[i - 1] if j == 1 else PIVOT_PLACEMENTS[j - 2]
                parent = model.addJoint(parent, joint, placement, f"q{j}{i}")
                body = np.array([params.values[f"{kind}_{j}{i}"] for kind in INERTIAL])
                model.appendBodyToJoint(parent, _inertia(body), pin.SE3.Identity())
            joint5.append(parent)
        # bodies 6 + 7 at P
        platform = np.array([params.values[f"{kind}_6"] for kind in INERTIAL]) + chi_l
        model.appendBodyToJoint(joint5[0], _inertia(platform), platform_in_body5(0))
        armature = np.zeros(N_TREE)
        armature[ACTUATED] = [params.values[f"ia_1{i}"] for i in (1, 2, 3)]
        model.armature = armature
        return model, joint5

    # ---- per-step calls (one state, tree coordinates) -------------------------------------------
    def lift(self, q: np.ndarray, qd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Tree state (Q, V) (15,) each, exactly on the closed loop, from actuator q, qd (3,)."""
        qt, qtd = kin.tree_state(q, qd)
        return qt.reshape(N_TREE), qtd.reshape(N_TREE)

    def friction(self, V: np.ndarray) -> np.ndarray:
        """Generalised friction force of the 15 tree joints (15,), acting against V."""
        s = np.tanh(V / self.v_s) if self.coulomb == "smooth" else np.sign(V)
        return self.fv * V + self.fs * s + self.tauoff

    def tree_acceleration(self, Q: np.ndarray, V: np.ndarray, force: np.ndarray) -> np.ndarray:
        """Tree accelerations (15,) under actuator forces ``force`` (3,) N and joint friction."""
        tau = -self.friction(V)
        tau[ACTUATED] += force
        return pin.constraintDynamics(self.model, self.data, Q, V, tau, self.constraints,
                                      self.constraint_data, self.prox).copy()

    # ---- batch helpers (loops over samples; for set-up and tests) -------------------------------
    def forward_dynamics(self, q, qd, tau) -> np.ndarray:
        """Actuator accelerations qdd (N, 3) m/s² under actuator forces tau (N, 3) N ((3,) ->
        (3,))."""
        q, qd, tau = (np.asarray(a, dtype=float) for a in (q, qd, tau))
        out = np.empty(np.broadcast_shapes(q.shape, qd.shape, tau.shape))
        for k in np.ndindex(out.shape[:-1]):
            Q, V = self.lift(q[k], qd[k])
            out[k] = self.tree_acceleration(Q, V, tau[k])[ACTUATED]
        return out

    def inverse_dynamics(self, q, qd, qdd) -> np.ndarray:
        """Actuator forces tau (N, 3) N giving accelerations qdd: qdd = a0 + M^-1 tau is affine in
        tau, so M^-1 and a0 come from four forward solutions."""
        q, qd, qdd = (np.asarray(a, dtype=float) for a in (q, qd, qdd))
        out = np.empty(np.broadcast_shapes(q.shape, qd.shape, qdd.shape))
        for k in np.ndindex(out.shape[:-1]):
            Q, V = self.lift(q[k], qd[k])
            a0 = self.tree_acceleration(Q, V, np.zeros(3))[ACTUATED]
            Minv = np.column_stack(
                [self.tree_acceleration(Q, V, e)[ACTUATED] - a0 for e in np.eye(3)]
            )
            out[k] = np.linalg.solve(Minv, qdd[k] - a0)
        return out

    def energy(self, q: np.ndarray, qd: np.ndarray) -> float:
        """T + V (J) at one state (kinetic energy includes the rotor inertias)."""
        Q, V = self.lift(q, qd)
        return float(pin.computeKineticEnergy(self.model, self.data, Q, V)
                     + pin.computePotentialEnergy(self.model, self.data, Q))
