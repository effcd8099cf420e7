"""Forward dynamics of the Orthoglide's identified model: the open tree of its URDF (urdf.py)
closed by two 6D welds (body 5 of legs 2 and 3 to the platform, Pinocchio's constraint dynamics,
as its plant in orthoglide_sim closes the loops; the product does not import the simulator).
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pinocchio as pin

from orthoglide_ident.model.forward import TreeModel, identified_tree
from orthoglide_ident.model.orthoglide.kinematics import tree_state
from orthoglide_ident.model.orthoglide.urdf import PLATFORM_LINK
from orthoglide_ident.model.robot import Payload, RobotModel

__all__ = ["OrthoglideForward", "orthoglide_forward"]


PROX = (1e-12, 0.0, 1)  # constraintDynamics: accuracy, mu = 0 (the exact KKT solution), iterations


class OrthoglideForward:
    """Forward dynamics of the Orthoglide's closed tree: the URDF's open tree, body 5 of legs 2
    and 3 welded to the platform (6D constraints, Pinocchio's constraint dynamics)."""

    def __init__(self, tree: TreeModel):
        self.tree = tree
        m = tree.model
        self.iq = np.array([[m.joints[m.getJointId(f"q{j}{i}")].idx_q for j in range(1, 6)]
                            for i in (1, 2, 3)])  # (3 legs, 5)
        self.iv = self.iq[:, 0]
        platform = m.frames[m.getFrameId("platform")]
        welds = []
        for leg in (2, 3):
            f = m.frames[m.getFrameId(f"platform_on_leg{leg}")]
            welds.append(pin.RigidConstraintModel(pin.ContactType.CONTACT_6D, m, f.parentJoint,
                                                  f.placement, platform.parentJoint,
                                                  platform.placement, pin.ReferenceFrame.LOCAL))
        self.constraints = pin.StdVec_RigidConstraintModel(welds)
        self.cdata = pin.StdVec_RigidConstraintData([c.createData() for c in welds])
        pin.initConstraintDynamics(m, tree.data, self.constraints, self.cdata)
        self.prox = pin.ProximalSettings(*PROX)

    def lift(self, q: np.ndarray, qd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Tree states exactly on the closed loop (kinematics.tree_state) of actuator states."""
        s = tree_state(q, qd, np.zeros_like(q))
        Q, V = np.zeros((q.shape[0], 15)), np.zeros((q.shape[0], 15))
        Q[:, self.iq], V[:, self.iq] = s.qt, s.qdt
        return Q, V

    def acceleration(self, Q: np.ndarray, V: np.ndarray, tau: np.ndarray) -> np.ndarray:
        t = self.tree
        u = -t.friction(V)
        u[self.iv] += tau
        return pin.constraintDynamics(t.model, t.data, Q, V, u, self.constraints, self.cdata,
                                      self.prox).copy()


def orthoglide_forward(robot: RobotModel, chi_st: np.ndarray, gains: Sequence[float],
                       payload: Payload | None):
    """(OrthoglideForward, engine): the payload on the platform, which only translates."""
    tree = identified_tree(robot, chi_st, gains, payload, PLATFORM_LINK)
    return OrthoglideForward(tree), "Pinocchio constraint dynamics, closed tree of the URDF"
