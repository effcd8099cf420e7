"""IDIM rows of the actuated joints from Pinocchio's tree regressors (eqs. 15, 18, 20, in general).

The open tree's joint-torque regressor Y (nv × 10 per joint body) and, for a body fixed to a
frame (a link kept as a body of its own), the frame's body regressor Φ_f with the frame's
Jacobian J_f (LOCAL), whose product J_fᵀ Φ_f is that body's contribution to the tree's joint
forces, come from Pinocchio's C++ sample by sample (``computeJointTorqueRegressor``,
``frameBodyRegressor``, ``computeFrameJacobian``; a numpy recursion over whole chunks was no
faster where the rows are used: bench/regressor_paths.py). The payload, rigidly fixed to one
joint's body, needs neither: its column is that body's columns of Y times its parameters in the
joint's frame. Everything else is numpy over a chunk of samples:
picking the columns asked for, the drive columns (ia q̈ of an actuated joint — the regressor
omits armature — and fv q̇, fs sign(q̇), tauoff of each joint with friction), and the
projection onto the actuated joints, τ_a = Gᵀ τ_t (closure.py; a serial robot's G selects its
rows; a URDF's mimic joint follows its leader, q_m = r q_l + o, so G is constant: its column of
the leader holds r at the mimic's row, and the mimic's torque is added, times r, to the
leader's).

Pinocchio orders a body's parameters [m, mx, my, mz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz] (inertia
at the body frame origin, ``Inertia.toDynamicParameters``); ``PIN_INDEX`` maps the product's
INERTIAL_KINDS onto it. Output layout: (column, joint, sample), as RobotModel.observation_block.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from orthoglide_ident.model.closure import Closure, TreeStates
from orthoglide_ident.model.robot import INERTIAL_KINDS
from orthoglide_ident.model.tree import TreeJoint, set_joint

_PIN_ORDER = ("m", "mx", "my", "mz", "xx", "xy", "yy", "xz", "yz", "zz")
PIN_INDEX = tuple(_PIN_ORDER.index(k) for k in INERTIAL_KINDS)  # INERTIAL_KINDS -> Pinocchio
CHUNK = 512  # samples per pass: the (chunk, nv, 10 n_bodies) regressor buffer stays small


@dataclass(frozen=True)
class Column:
    """Where one standard parameter's column comes from.

    ``source``: "joint" (the body of Pinocchio joint ``index``), "frame" (the body fixed to
    frame slot ``index``) with ``kind`` an inertial kind; or "drive" with ``kind`` ia, fv, fs
    or tauoff of the tree joint whose velocity index is ``index``.
    """

    source: str
    index: int
    kind: str

    @property
    def pin_column(self) -> int:
        """Column in the body's 10 Pinocchio parameters (inertial sources)."""
        return PIN_INDEX[INERTIAL_KINDS.index(self.kind)]


def pin_parameters(chi: Sequence[float]) -> np.ndarray:
    """10 inertial parameters in INERTIAL_KINDS order -> Pinocchio's order."""
    out = np.empty(10)
    out[list(PIN_INDEX)] = chi
    return out


def kinds_parameters(pi: Sequence[float]) -> np.ndarray:
    """Pinocchio's 10 dynamic parameters -> INERTIAL_KINDS order."""
    return np.asarray(pi, dtype=float)[list(PIN_INDEX)]


class _Chunk:
    """Per-sample outputs of one chunk of m samples, preallocated once per call."""

    def __init__(self, m: int, nq: int, nv: int, n_y: int, n_slots: int, n_a: int, closed: bool):
        self.Q, self.V, self.A = np.zeros((m, nq)), np.zeros((m, nv)), np.zeros((m, nv))
        self.Y = np.zeros((m, nv, n_y)) if n_y else None
        self.J = np.zeros((n_slots, m, 6, nv))
        self.R = np.zeros((n_slots, m, 6, 10))
        self.G = np.zeros((m, nv, n_a)) if closed else None


def _payload_matrix(payload: tuple[int, np.ndarray]) -> tuple[int, np.ndarray]:
    """(joint, (10, k)): a payload's parameter vectors as columns (one vector: k = 1)."""
    joint, chi = payload
    chi = np.asarray(chi, float)
    return joint, chi[:, None] if chi.ndim == 1 else chi


class TreeRegressor:
    """Rows of the actuated joints for samples of (q_a, q̇_a, q̈_a) and asked-for columns.

    ``frames``: Pinocchio frame ids of the bodies fixed to frames (slot k = frames[k]);
    ``closure``: the loops' tree states, None for a serial/tree robot whose movable joints are
    all actuated. Not thread-safe (one ``Data``): the owner serialises calls.
    """

    def __init__(self, model: pin.Model, actuated: Sequence[TreeJoint], frames: Sequence[int],
                 closure: Closure | None,
                 mimics: Sequence[tuple[TreeJoint, int, float, float]] = ()):
        self.model, self.data = model, model.createData()
        self.actuated, self.frames, self.closure = tuple(actuated), tuple(frames), closure
        self.S_a = np.array([j.iv for j in actuated])
        self._row = {j.iv: a for a, j in enumerate(actuated)}  # actuated index of a v index
        # mimic joints (joint, its leader's actuated index, multiplier, offset): constant G
        self.mimics = tuple(mimics)
        self._G0 = None
        if self.mimics:
            self._G0 = np.zeros((model.nv, len(self.actuated)))
            self._G0[self.S_a, np.arange(len(self.actuated))] = 1.0
            for j, a, r, _ in self.mimics:
                self._G0[j.iv, a] = r
        # a serial robot whose velocity vector is its actuated joints in order: no selection
        self._identity = closure is None and not self.mimics and \
            np.array_equal(self.S_a, np.arange(model.nv))

    # --- per sample (Pinocchio) -----------------------------------------------------------
    def _states(self, c: _Chunk, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> None:
        if self.closure is None:
            for a, j in enumerate(self.actuated):
                set_joint(c.Q, j, q[:, a])
            c.V[:, self.S_a], c.A[:, self.S_a] = qd, qdd
            for j, a, r, o in self.mimics:  # q_m = r q_l + o, and its derivatives
                set_joint(c.Q, j, r * q[:, a] + o)
                c.V[:, j.iv], c.A[:, j.iv] = r * qd[:, a], r * qdd[:, a]
            return
        self.closure.states(q, qd, qdd, TreeStates(c.Q, c.V, c.A, c.G))

    def _regressors(self, c: _Chunk, slots: Sequence[int], want_y: bool) -> None:
        model, data = self.model, self.data
        regressor, body, jacobian = (pin.computeJointTorqueRegressor, pin.frameBodyRegressor,
                                     pin.computeFrameJacobian)
        frames = [(s, self.frames[s]) for s in slots]
        for k in range(c.Q.shape[0]):
            Y = regressor(model, data, c.Q[k], c.V[k], c.A[k])  # forward pass for the frames too
            if want_y:
                c.Y[k] = Y
            for s, f in frames:
                c.R[s, k] = body(model, data, f)
            for s, f in frames:
                c.J[s, k] = jacobian(model, data, c.Q[k], f, pin.LOCAL)

    # --- per chunk (numpy) ----------------------------------------------------------------
    def _project(self, c: _Chunk, T: np.ndarray) -> np.ndarray:
        """Tree forces (m, nv, n) -> actuated forces (m, n_a, n): Gᵀ T."""
        if c.G is None:
            if self._G0 is not None:  # mimic joints: τ_l + r τ_m
                return np.einsum("va,mvn->man", self._G0, T)
            return T if self._identity else T[:, self.S_a]
        return np.matmul(c.G.transpose(0, 2, 1), T)

    def _drive(self, c: _Chunk, col: Column, qdd: np.ndarray, out: np.ndarray) -> None:
        """The drive term of tree joint ``col.index`` into ``out`` (n_a, m): its own row for
        a serial robot, Gᵀ of it for a closed chain."""
        t = col.index
        if col.kind == "ia":
            x = qdd[:, self._row[t]]
        elif col.kind == "fv":
            x = c.V[:, t]
        elif col.kind == "fs":
            x = np.sign(c.V[:, t])
        else:
            x = np.ones(c.V.shape[0])
        if c.G is None:
            out[:] = 0.0
            out[self._row[t]] = x
        else:
            out[:] = (c.G[:, t, :] * x[:, None]).T

    def block(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, columns: Sequence[Column],
              payload: tuple[int, np.ndarray] | None, out: np.ndarray) -> np.ndarray:
        """Columns (and the payload column last when ``payload`` = (the Pinocchio joint it is
        fixed to, its 10 Pinocchio parameters per kg in that joint's frame) is given; k payload
        columns last for a (10, k) matrix of parameter vectors) into ``out`` (n, n_a, m);
        q, qd, qdd: (m, n_a)."""
        inertial = [n for n, c in enumerate(columns) if c.source != "drive"]
        drive = [(n, c) for n, c in enumerate(columns) if c.source == "drive"]
        want_y = any(c.source == "joint" for c in columns) or payload is not None
        slots = sorted({c.index for c in columns if c.source == "frame"})
        n_y = 10 * (self.model.njoints - 1) if want_y else 0
        buf = None
        for s in range(0, q.shape[0], CHUNK):
            e = min(q.shape[0], s + CHUNK)
            if buf is None or buf.Q.shape[0] != e - s:
                buf = _Chunk(e - s, self.model.nq, self.model.nv, n_y, len(self.frames),
                             len(self.actuated), self.closure is not None)
            self._states(buf, q[s:e], qd[s:e], qdd[s:e])
            if inertial or payload is not None:  # drive columns only (identify/stream.py's
                # rough ones) need no regressor
                self._per_sample(buf, columns, inertial, payload, slots, want_y, out[:, :, s:e])
            for n, c in drive:
                self._drive(buf, c, qdd[s:e], out[n, :, s:e])
        return out

    def _per_sample(self, buf: _Chunk, columns: Sequence[Column], inertial: list[int],
                    payload: tuple[int, np.ndarray] | None, slots: Sequence[int], want_y: bool,
                    out: np.ndarray) -> None:
        """Inertial and payload columns of a chunk from Pinocchio's per-sample regressors."""
        self._regressors(buf, slots, want_y)
        if inertial:
            T = self._inertial(buf, [columns[n] for n in inertial])
            where = inertial if len(inertial) != inertial[-1] - inertial[0] + 1 else \
                slice(inertial[0], inertial[-1] + 1)  # a slice writes 2-3x faster
            out[where] = self._project(buf, T).transpose(2, 1, 0)
        if payload is not None:
            joint, chi = _payload_matrix(payload)
            f = buf.Y[:, :, 10 * (joint - 1):10 * joint] @ chi  # (m, nv, k): Y_j χ_l
            out[len(columns):len(columns) + chi.shape[1]] = \
                self._project(buf, f).transpose(2, 1, 0)

    def _inertial(self, c: _Chunk, columns: Sequence[Column]) -> np.ndarray:
        """Tree forces (m, nv, n) of inertial columns, from Y and the frames' J_fᵀ Φ_f."""
        parts = []
        for col in columns:  # runs of one source kept together: one gather each
            if col.source == "joint":
                key = ("joint", -1, 10 * (col.index - 1) + col.pin_column)
            else:
                key = ("frame", col.index, col.pin_column)
            if parts and parts[-1][0][:2] == key[:2]:
                parts[-1][1].append(key[2])
            else:
                parts.append((key[:2], [key[2]]))
        blocks = []
        for (source, slot), cols in parts:
            if source == "joint":
                blocks.append(c.Y[:, :, cols])
            else:
                blocks.append(np.matmul(c.J[slot].transpose(0, 2, 1), c.R[slot][:, :, cols]))
        return blocks[0] if len(blocks) == 1 else np.concatenate(blocks, axis=2)
