"""Loop closures of a closed chain: the one place that touches Pinocchio's constraint API.

A loop holds two frames of the open tree together: their origins (``point``, a 3D ball joint:
Pinocchio's ``PointAnchorConstraintModel``) or their whole placements (``frame``, 6D, a weld:
``FrameAnchorConstraintModel``). The constraint API is still changing upstream (pin 4.1 has
these beside the older ``RigidConstraintModel``), so the rest of the product sees only
:class:`LoopConstraints`: the stacked residual e(q_t), its Jacobian J_c = ∂e/∂q_t
(n_c × nv) and the drift J̇_c q̇_t, all in the same (Pinocchio's) coordinates, which is all
that closing the loops needs (closure.py: J_c q̇_t = 0, J_c q̈_t + J̇_c q̇_t = 0).

Measured here on pin 4.1.0: ``constraint_position_error`` after ``calc`` is e, ``jacobian`` is
∂e/∂q (central differences agree to 1e-9), and ``constraint_acceleration_error`` after
``forwardKinematics(q, v, 0)`` is J̇_c v (the same to 1e-9). A planar loop's point constraint has
a row that stays zero: callers use the null space of J_c, not its inverse.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin

from orthoglide_ident.errors import ConfigError

LOOP_KINDS = ("point", "frame")


@dataclass(frozen=True)
class Loop:
    """Two frames of the tree held together: origins (``point``) or placements (``frame``)."""

    frame_a: str
    frame_b: str
    kind: str = "point"

    def __post_init__(self) -> None:
        if self.kind not in LOOP_KINDS:
            raise ConfigError(f"loop {self.frame_a}-{self.frame_b}: type {self.kind!r} is not "
                              f"{' or '.join(LOOP_KINDS)}")


def _frame(model: pin.Model, name: str, loop: Loop) -> pin.Frame:
    if not model.existFrame(name):
        raise ConfigError(f"loop {loop.frame_a}-{loop.frame_b}: the description has no frame "
                          f"(link, joint or site) named {name!r}")
    return model.frames[model.getFrameId(name)]


def _anchor(model: pin.Model, loop: Loop):
    a, b = _frame(model, loop.frame_a, loop), _frame(model, loop.frame_b, loop)
    if a.parentJoint == b.parentJoint:
        raise ConfigError(f"loop {loop.frame_a}-{loop.frame_b}: both frames are on the same body; "
                          "a loop joins two different branches of the tree")
    cls = pin.PointAnchorConstraintModel if loop.kind == "point" else pin.FrameAnchorConstraintModel
    return cls(model, a.parentJoint, a.placement, b.parentJoint, b.placement)


def load_mjcf(path: Path) -> tuple[pin.Model, list]:
    """An MJCF tree and its ``<equality connect/weld>`` loops as constraint models.

    Pinocchio places the second body's anchor where the first's is at q = 0 (MuJoCo's qpos0 when
    no joint has a ``ref``): describe the MJCF assembled at q = 0, or give the loops in the
    robot YAML between two sites instead."""
    model, points, frames = pin.buildModelAndConstraintsFromMJCF(str(path))
    return model, list(points) + list(frames)


class LoopConstraints:
    """The stacked loop constraints of one tree: residual, Jacobian and drift at a state.

    ``loops`` name frame pairs; ``anchors`` are constraint models already built (an MJCF's).
    Not thread-safe (one Pinocchio ``Data``, preallocated outputs): one per model, under the
    caller's lock.
    """

    def __init__(self, model: pin.Model, loops: Sequence[Loop] = (), anchors: Sequence = ()):
        self.model = model
        self.loops = tuple(loops)
        self._models = [_anchor(model, loop) for loop in loops] + list(anchors)
        self._datas = [c.createData() for c in self._models]
        sizes = [c.residualSize() for c in self._models]
        self._rows = np.cumsum([0] + sizes)
        self.n_rows = int(self._rows[-1])
        self.e = np.zeros(self.n_rows)
        self.J = np.zeros((self.n_rows, model.nv))
        self.b = np.zeros(self.n_rows)
        self._a0 = np.zeros(model.nv)

    def __len__(self) -> int:
        return len(self._models)

    def evaluate(self, data: pin.Data, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(e, J_c) at configuration q: residual (n_c,) m or rad, Jacobian (n_c, nv). The arrays
        are reused by the next call: copy what must outlive it."""
        pin.computeJointJacobians(self.model, data, q)  # placements and joint Jacobians
        for k, (c, cd) in enumerate(zip(self._models, self._datas)):
            c.calc(self.model, data, cd)
            s = slice(self._rows[k], self._rows[k + 1])
            self.e[s] = cd.constraint_position_error
            self.J[s] = c.jacobian(self.model, data, cd)
        return self.e, self.J

    def drift(self, data: pin.Data, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """J̇_c v (n_c,) at (q, v): the constraints' acceleration with q̈ = 0 (reused array)."""
        pin.forwardKinematics(self.model, data, q, v, self._a0)
        for k, (c, cd) in enumerate(zip(self._models, self._datas)):
            c.calc(self.model, data, cd)
            self.b[self._rows[k]:self._rows[k + 1]] = cd.constraint_acceleration_error
        return self.b
