"""The closed chain's tree state from its actuated joints (the paper's eqs. 5-8, numerically).

The open tree has nv joint velocities; the loops (loop_constraints.py) hold e(q_t) = 0 with
Jacobian J_c (n_c × nv). For actuated values (q_a, q̇_a, q̈_a):

- q_t: Newton on e(q_t) = 0 over the passive joints, the actuated ones fixed at q_a
  (least squares: a planar loop's point constraint has a row that stays zero), warm-started
  from the previous sample; a step longer than a few % of a joint's range is cut into
  substeps (continuation), so that the solution stays on the assembly mode of
  ``reference`` (the robot's working mode) instead of jumping to another one;
- q̇_t = G q̇_a with G = N (S_a N)⁻¹, N an orthonormal basis of the null space of J_c (SVD),
  S_a the rows of the actuated joints (so S_a G = I): the tree velocities of unit actuator
  rates, what J_t = J_k⁻¹ J_tk J_p is for the Orthoglide (eq. 15);
- q̈_t from J_c q̈_t = -J̇_c q̇_t with S_a q̈_t = q̈_a: q̈_t = G q̈_a + (I - G S_a) x_0,
  x_0 = -J_c⁺ J̇_c q̇_t.

The actuated forces are then τ_a = Gᵀ τ_t (virtual power), which is eq. (15) in general form.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from orthoglide_ident.errors import ConfigError, SingularityError, WorkspaceError
from orthoglide_ident.model.loop_constraints import LoopConstraints
from orthoglide_ident.model.tree import TreeJoint, get_joint

CLOSURE_TOL = 1e-12  # m or rad: loop residual accepted as closed (round-off is ~1e-16)
MAX_NEWTON = 12  # iterations per (sub)step; warm-started samples need 2-3
RANK_TOL = 1e-9  # singular values of J_c below this (relative) are dependent rows
SINGULAR_RATE = 1e8  # |G| above this (rad/m, m/rad or 1): a parallel singularity
STEP_FRACTION = 0.05  # continuation step: this fraction of a joint's range
DEFAULT_STEP = {"prismatic": 0.01, "revolute": 0.1}  # m, rad: for joints without limits


@dataclass
class TreeStates:
    """Samples on the closed loop: q_t (m, nq), q̇_t, q̈_t (m, nv), G (m, nv, n_a)."""

    q: np.ndarray
    v: np.ndarray
    a: np.ndarray
    G: np.ndarray

    @classmethod
    def empty(cls, m: int, nq: int, nv: int, n_a: int) -> TreeStates:
        return cls(np.zeros((m, nq)), np.zeros((m, nv)), np.zeros((m, nv)), np.zeros((m, nv, n_a)))


def _fmt(values: np.ndarray) -> str:
    return "[" + ", ".join(f"{x:.6g}" for x in values) + "]"


class Closure:
    """Tree states of one closed chain; keeps the last solution as the next warm start.

    Not thread-safe (one Pinocchio ``Data``, the warm start): the owner serialises calls.
    """

    def __init__(self, model: pin.Model, loops: LoopConstraints, actuated: Sequence[TreeJoint],
                 reference: np.ndarray):
        self.model, self.data, self.loops = model, model.createData(), loops
        self.actuated = tuple(actuated)
        self.S_a = np.array([j.iv for j in actuated])
        self.passive = np.setdiff1d(np.arange(model.nv), self.S_a)
        self.n_a = len(actuated)
        self.steps = np.array([self._step(j) for j in actuated])
        self._dv = np.zeros(model.nv)
        # Every joint a vector space (no quaternion, no unbounded revolute): integrate is +.
        self._flat = model.nq == model.nv
        self._iq = np.array([j.iq for j in actuated])
        self._plain = all(j.kind != "continuous" for j in actuated)
        self._check_mobility(reference)  # near a closed configuration the rank is the same
        self.reference = self.close(self.actuated_values(reference), reference, "the reference "
                                    "configuration")
        self._last = self.reference.copy()
        self._last_a = self.actuated_values(self.reference)
        self._last_step: tuple[np.ndarray, np.ndarray] | None = None  # (Δq_a, Δq_t) of the last

    @staticmethod
    def _step(j: TreeJoint) -> float:
        span = j.upper - j.lower
        return STEP_FRACTION * span if math.isfinite(span) else DEFAULT_STEP[j.unit_kind]

    def actuated_values(self, q: np.ndarray) -> np.ndarray:
        if self._plain:
            return q[self._iq]
        return np.array([get_joint(q, j) for j in self.actuated])

    def _set_actuated(self, q: np.ndarray, q_a: np.ndarray) -> None:
        if self._plain:
            q[self._iq] = q_a
            return
        for j, x in zip(self.actuated, q_a):
            if j.kind == "continuous":
                q[j.iq], q[j.iq + 1] = math.cos(x), math.sin(x)
            else:
                q[j.iq] = x

    def _check_mobility(self, q: np.ndarray) -> None:
        _, J = self.loops.evaluate(self.data, q)
        s = np.linalg.svd(J, compute_uv=False)
        rank = int(np.sum(s > RANK_TOL * s[0])) if s.size else 0
        dof = self.model.nv - rank
        if dof != self.n_a:
            raise ConfigError(f"the loops leave {dof} degrees of freedom at the reference "
                              f"configuration but {self.n_a} joints are actuated "
                              f"({', '.join(j.name for j in self.actuated)})")

    # --- positions (sample by sample: Newton, warm-started) --------------------------------
    def _newton(self, q: np.ndarray) -> tuple[bool, float]:
        """Close the loops over the passive joints in place; (converged, final residual). On
        success ``loops.J`` holds J_c at the closed q."""
        from scipy.linalg import lapack  # on demand: a serial robot's model never needs it

        res = math.inf
        P = self.passive
        for _ in range(MAX_NEWTON):
            e, J = self.loops.evaluate(self.data, q)
            res = float(abs(e).max())
            if res < CLOSURE_TOL:
                return True, res
            # least squares (LAPACK gels): J_p has full column rank off parallel singularities
            _, x, info = lapack.dgels(J[:, P], e)
            if info != 0:
                return False, res
            if self._flat:
                q[P] -= x[:P.size]
            else:
                self._dv[P] = -x[:P.size]
                q[:] = pin.integrate(self.model, q, self._dv)
        return False, res

    def close(self, q_a: np.ndarray, start: np.ndarray, what: str = "") -> np.ndarray:
        """q_t closing the loops at actuated values q_a, by continuation from ``start``
        (a closed configuration); WorkspaceError when no assembly is found."""
        q = start.copy()
        q_a0 = self.actuated_values(start)
        n = max(1, int(math.ceil(float(np.max(np.abs(q_a - q_a0) / self.steps)))))
        for k in range(1, n + 1):
            self._set_actuated(q, q_a0 + (q_a - q_a0) * (k / n))
            ok, res = self._newton(q)
            if not ok:
                where = what or f"q = {_fmt(q_a)}"
                raise WorkspaceError(f"the loops do not close at {where} (residual {res:.2g} "
                                     f"after {MAX_NEWTON} Newton steps): outside the workspace "
                                     "or past a singularity")
        return q

    def track(self, q_a: np.ndarray) -> np.ndarray:
        """q_t at q_a from the last solution (a trajectory's previous sample), else from the
        reference configuration. The start is the last solution moved on by the last step,
        scaled to this one (second-order error on a smooth trajectory: one Newton step less)."""
        start = self._last
        step = q_a - self._last_a
        if self._last_step is not None:
            prev_a, prev_t = self._last_step
            den = float(prev_a @ prev_a)
            if den > 0.0:
                dq = prev_t * (float(step @ prev_a) / den)
                start = self._last + dq if self._flat else pin.integrate(self.model, self._last, dq)
        try:
            q = self.close(q_a, start)
        except WorkspaceError:
            q = self.close(q_a, self.reference)
        self._last_step = (step, q - self._last if self._flat else
                           pin.difference(self.model, self._last, q))
        self._last, self._last_a = q, q_a.copy()
        return q

    # --- velocities and accelerations (a chunk at once: batched linear algebra) ----------
    def states(self, q_a: np.ndarray, qd_a: np.ndarray, qdd_a: np.ndarray,
               out: TreeStates, q: np.ndarray | None = None) -> TreeStates:
        """Tree states of actuated samples (m, n_a) into ``out``; at the closed configurations
        ``q`` (m, nq) when given, else tracked sample after sample. SingularityError at a
        singular sample."""
        m = q_a.shape[0]
        J = np.empty((m, self.loops.n_rows, self.model.nv))
        for k in range(m):
            if q is None:
                out.q[k] = self.track(q_a[k])
            else:
                out.q[k] = q[k]
                self.loops.evaluate(self.data, out.q[k])
            J[k] = self.loops.J
        U, s, Vt = np.linalg.svd(J)
        rank = self._rank(s, q_a)
        N = Vt[:, rank:, :].transpose(0, 2, 1)  # (m, nv, n_a): null space of J_c
        try:
            out.G[:] = np.linalg.solve(N[:, self.S_a, :].transpose(0, 2, 1),
                                       N.transpose(0, 2, 1)).transpose(0, 2, 1)  # N (S_a N)⁻¹
        except np.linalg.LinAlgError:
            out.G[:] = np.inf
        big = ~(np.abs(out.G).max(axis=(1, 2)) < SINGULAR_RATE)
        if big.any():
            raise SingularityError(f"at q = {_fmt(q_a[np.argmax(big)])} the actuated joints do "
                                   "not fix the passive ones (parallel singularity)")
        out.v[:] = np.einsum("kvn,kn->kv", out.G, qd_a)
        b = np.empty((m, self.loops.n_rows))
        for k in range(m):
            b[k] = self.loops.drift(self.data, out.q[k], out.v[k])
        Ub = np.einsum("kcr,kc->kr", U[:, :, :rank], b) / s[:, :rank]
        x0 = -np.einsum("krv,kr->kv", Vt[:, :rank, :], Ub)  # -J_c⁺ J̇_c q̇_t
        out.a[:] = np.einsum("kvn,kn->kv", out.G, qdd_a - x0[:, self.S_a]) + x0
        return out

    def _rank(self, s: np.ndarray, q_a: np.ndarray) -> int:
        """The rank of J_c, the same at every sample (nv - n_a); SingularityError otherwise."""
        ranks = np.sum(s > RANK_TOL * s[:, :1], axis=1)
        bad = ranks != self.model.nv - self.n_a
        if bad.any():
            k = int(np.argmax(bad))
            raise SingularityError(f"at q = {_fmt(q_a[k])} the loops leave "
                                   f"{self.model.nv - ranks[k]} degrees of freedom, not "
                                   f"{self.n_a}: a leg is at a serial singularity")
        return int(ranks[0])
