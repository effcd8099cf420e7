"""Forward dynamics of an identified model: its URDF on Pinocchio, with the drive terms.

``RobotModel.forward_model(chi_st, gains, payload)`` gives (forward model, engine name), or
(None, reason) when the robot cannot be simulated here. A forward model has ``iv`` (the actuated
velocity indices), ``lift(q, qd) -> (Q, V)`` (tree states of actuator states) and
``acceleration(Q, V, tau)``; :func:`simulate` integrates one (identify/direct_dynamics.py).
Every robot described by a URDF whose joints are all actuated is a tree solved by ABA
(:func:`tree_forward`); a robot with loops brings its own (the Orthoglide's closed tree,
model/orthoglide/forward.py).
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import pinocchio as pin

RobotModel = Payload = Any  # model/robot.py's, whose methods call this module: not imported

__all__ = ["SerialForward", "TreeModel", "identified_tree", "pin_inertia", "simulate",
           "tree_forward"]


SUBSTEPS = 1  # RK4 steps per controller tick (the currents are held over it)


def pin_inertia(chi10: np.ndarray) -> pin.Inertia:
    """Pinocchio inertia of the 10 parameters (INERTIAL_KINDS order, at the frame origin)."""
    xx, xy, xz, yy, yz, zz, mx, my, mz, m = chi10
    return pin.Inertia.FromDynamicParameters(np.array([m, mx, my, mz, xx, xy, yy, xz, yz, zz]))


class TreeModel:
    """Pinocchio model of an identified URDF, with the drive terms of its joints.

    ``values``: the standard parameters by name; ``labels``: URDF joint name -> the suffix of
    its drive terms (``fv_<label>``...); ``gravity`` m/s² (the acceleration vector)."""

    def __init__(self, urdf_text: str, values: Mapping[str, float], labels: Mapping[str, str],
                 gravity: Sequence[float]):
        self.model = pin.buildModelFromXML(urdf_text)
        self.model.gravity = pin.Motion(np.asarray(gravity, float), np.zeros(3))
        nv = self.model.nv
        self.fv, self.fs, self.off = np.zeros(nv), np.zeros(nv), np.zeros(nv)
        armature = np.zeros(nv)
        for name, label in labels.items():
            if not self.model.existJointName(name):
                continue
            iv = self.model.joints[self.model.getJointId(name)].idx_v
            armature[iv] = values.get(f"ia_{label}", 0.0)
            self.fv[iv] = values.get(f"fv_{label}", 0.0)
            self.fs[iv] = values.get(f"fs_{label}", 0.0)
            self.off[iv] = values.get(f"tauoff_{label}", 0.0)
        self.model.armature = armature
        self.data = self.model.createData()

    def add_payload(self, frame: str, chi10: np.ndarray) -> None:
        """Fix a payload (10 parameters at ``frame``'s origin) to the body carrying ``frame``."""
        f = self.model.frames[self.model.getFrameId(frame)]
        self.model.inertias[f.parentJoint] += f.placement.act(pin_inertia(chi10))
        self.data = self.model.createData()

    def friction(self, V: np.ndarray) -> np.ndarray:
        return self.fv * V + self.fs * np.sign(V) + self.off

    def v_index(self, names: Sequence[str]) -> np.ndarray:
        return np.array([self.model.joints[self.model.getJointId(n)].idx_v for n in names])


class SerialForward:
    """Forward dynamics of a tree whose every joint is actuated (ABA)."""

    def __init__(self, tree: TreeModel, joint_names: Sequence[str]):
        self.tree = tree
        self.iv = tree.v_index(joint_names)

    def lift(self, q: np.ndarray, qd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Tree states (m, nq), (m, nv) of actuated states (m, n_j)."""
        m = self.tree.model
        Q, V = np.zeros((q.shape[0], m.nq)), np.zeros((q.shape[0], m.nv))
        Q[:, self.iv], V[:, self.iv] = q, qd
        return Q, V

    def acceleration(self, Q: np.ndarray, V: np.ndarray, tau: np.ndarray) -> np.ndarray:
        t = self.tree
        u = -t.friction(V)
        u[self.iv] += tau
        return pin.aba(t.model, t.data, Q, V, u).copy()


def simulate(fwd, Q0: np.ndarray, V0: np.ndarray, tau: np.ndarray, period_s: float) -> np.ndarray:
    """Actuated positions (n + 1, n_j) from the tree state (Q0, V0) under the efforts
    ``tau: (n, n_j)`` each held over one tick (RK4, SUBSTEPS per tick)."""
    h = period_s / SUBSTEPS
    Q, V = Q0.copy(), V0.copy()
    out = [Q[fwd.iv].copy()]
    for u in tau:
        for _ in range(SUBSTEPS):
            k1v, k1a = V, fwd.acceleration(Q, V, u)
            k2v = V + 0.5 * h * k1a
            k2a = fwd.acceleration(Q + 0.5 * h * k1v, k2v, u)
            k3v = V + 0.5 * h * k2a
            k3a = fwd.acceleration(Q + 0.5 * h * k2v, k3v, u)
            k4v = V + h * k3a
            k4a = fwd.acceleration(Q + h * k3v, k4v, u)
            Q = Q + h / 6.0 * (k1v + 2 * k2v + 2 * k3v + k4v)
            V = V + h / 6.0 * (k1a + 2 * k2a + 2 * k3a + k4a)
        out.append(Q[fwd.iv].copy())
    return np.array(out)


def identified_tree(robot: RobotModel, chi_st: np.ndarray, gains: Sequence[float],
                    payload: Payload | None, payload_frame: str) -> TreeModel:
    """The tree of ``robot.identified_urdf`` with the drive terms of ``chi_st``, under the robot's
    gravity, a loaded record's payload fixed at ``payload_frame``."""
    text = robot.identified_urdf(chi_st, gains)
    values = dict(zip(robot.standard_names, (float(x) for x in chi_st)))
    tree = TreeModel(text, values, robot.joint_labels(text), robot.gravity)
    if payload is not None and payload.mass > 0:
        tree.add_payload(payload_frame, payload.mass * payload.shape())
    return tree


def tree_forward(robot: RobotModel, chi_st: np.ndarray, gains: Sequence[float],
                 payload: Payload | None):
    """(SerialForward, engine) of a robot whose URDF tree is all actuated joints, or (None,
    reason) for a closed chain (its passive joints are not simulated here)."""
    frame = (payload.frame or robot.payload_frame) if payload is not None else ""
    tree = identified_tree(robot, chi_st, gains, payload, frame)
    if tree.model.nv != robot.n_joints or tree.model.nq != tree.model.nv:
        return None, (f"not simulated: the URDF tree has {tree.model.nv} degrees of freedom for "
                      f"{robot.n_joints} actuated joints (a closed chain)")
    return SerialForward(tree, robot.joint_names), "Pinocchio ABA on the URDF"
