"""The general robot model on Pinocchio: any URDF or MJCF tree, closed chains by loop constraints.

A :class:`PinocchioRobot` is a RobotModel (model/robot.py) built from a robot YAML
(docs/guide/robot_files.md) or a bare URDF:

- bodies: the link of every movable joint (Pinocchio merges the links fixed to it), and the
  links named in ``fixed_bodies`` (kept apart: the Orthoglide's platform), each with the 10
  inertial parameters of INERTIAL_KINDS at its own frame; every actuated joint adds ia, fv,
  fs, tauoff, every passive joint of a closed chain fv, fs, tauoff (``passive_friction``).
  Standard names are ``<kind>_<label>`` with the body's label (1, 2, ... from the base, in
  Pinocchio's joint order, fixed bodies last; ``body_labels`` renames them), e.g. ``m_3``,
  ``fv_2`` (the joint that moves body 2), as the paper names a serial robot's;
- rows: tree_regressor.py (Pinocchio's regressors per sample, projected by Gᵀ through the loops
  of closure.py for a closed chain);
- base parameters: base_parameters.py on random regular states, columns in ``column_order``
  (eq. 23) or from the base outwards.

The model is not re-entrant (Pinocchio ``Data``, the closure's warm start): calls are
serialised by a lock shared with the models ``with_payload`` returns.
"""
from __future__ import annotations

import copy
import math
import threading
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from orthoglide_ident.errors import ConfigError, ModelError, OrthoglideError, WorkspaceError
from orthoglide_ident.model.base_parameters import BaseSet, NamedByParameters, base_parameters
from orthoglide_ident.model.closure import Closure, TreeStates
from orthoglide_ident.model.locked_joints import (
    LockedJoint,
    lock_text,
    locked_joints,
    reduced_model,
)
from orthoglide_ident.model.loop_constraints import LoopConstraints
from orthoglide_ident.model.robot import INERTIAL_KINDS, ActuatedJoint, Body, Payload, RobotModel
from orthoglide_ident.model.robot_file import RobotDescription, read_description
from orthoglide_ident.model.tree import (
    TreeJoint,
    fixed_link,
    load_tree,
    movable_joints,
    urdf_mimics,
)
from orthoglide_ident.model.tree_regressor import (
    Column,
    TreeRegressor,
    kinds_parameters,
    pin_parameters,
)

ACTUATED_TERMS = ("ia", "fv", "fs", "tauoff")
PASSIVE_TERMS = ("fv", "fs", "tauoff")
ROWS_PER_PARAMETER = 8  # random-state rows per standard parameter for the QR (closed form: ~8.7)
RATE_SD, ACC_SD = 1.0, 10.0  # random q̇, q̈ (m/s or rad/s, per s²), as the closed form's states
UNBOUNDED_RANGE = {"prismatic": 0.1, "revolute": math.pi}  # random q of joints without limits
MAX_RATE_GROWTH = 10.0  # random closed-chain states: |G| at most this times the reference's


@dataclass(frozen=True)
class _Body:
    """A body of the standard parameter set: label, link, what moves it, its parameter kinds."""

    label: str
    link: str
    kinds: tuple[str, ...]
    joint: TreeJoint | None = None  # None: a fixed body on frame slot ``slot``
    slot: int = -1

    def column(self, kind: str) -> Column:
        if kind not in INERTIAL_KINDS:
            return Column("drive", self.joint.iv, kind)
        if self.joint is None:
            return Column("frame", self.slot, kind)
        return Column("joint", self.joint.id, kind)


def _nearest_first(points: np.ndarray, start: np.ndarray, scale: np.ndarray) -> list[np.ndarray]:
    """``points`` (k, n) in greedy nearest-neighbour order from ``start`` (distances per
    ``scale``): a short path through them."""
    left = list(range(len(points)))
    here, order = start, []
    while left:
        d = np.max(np.abs(points[left] - here) / scale, axis=1)
        here = points[left.pop(int(np.argmin(d)))]
        order.append(here)
    return order


def _moved(placement: pin.SE3, chi: np.ndarray) -> np.ndarray:
    """Ten inertial parameters (INERTIAL_KINDS) at a frame -> Pinocchio's, in the frame of the
    joint it sits on (``placement``: the frame in that joint). The move is linear in the
    parameters, so a unit parameter with no mass is moved as the difference of two bodies."""
    unit = pin.Inertia.FromDynamicParameters(pin_parameters(np.r_[np.zeros(9), 1.0]))
    body = pin.Inertia.FromDynamicParameters(pin_parameters(np.r_[np.zeros(9), 1.0] + chi))
    return (placement.act(body).toDynamicParameters()
            - placement.act(unit).toDynamicParameters())


def _fmt(values: Sequence[float]) -> str:
    return "[" + ", ".join(f"{x:.6g}" for x in values) + "]"


class PinocchioRobot(NamedByParameters, RobotModel):
    """A robot described by a URDF/MJCF (and loops): see the module docstring."""

    @classmethod
    def from_description(cls, data: dict[str, Any], base_dir: Path, where: str | None = None,
                         package_dirs: Sequence[str | Path] = ()) -> PinocchioRobot:
        """The model a robot YAML's mapping describes (``description`` relative to base_dir);
        ``where`` names the file in its errors (default: the robot's name or description);
        ``package_dirs``: where a xacro description's packages are found."""
        where = where or f"robot {data.get('name') or data.get('description')}"
        desc = read_description(data, Path(base_dir), where, package_dirs)
        return cls(desc, where=where)

    def __init__(self, desc: RobotDescription, seed: int = 0, where: str | None = None):
        self.description = desc
        self.name = desc.name
        model, anchors = load_tree(desc.path)
        model.gravity = pin.Motion(np.array(desc.gravity, dtype=float), np.zeros(3))
        mimics = urdf_mimics(desc.path)
        self.locked_joints = self._locked(model, mimics, desc, anchors, where)
        self.model = model = reduced_model(model, movable_joints(model), self.locked_joints)
        self.tree_joints = movable_joints(model)
        locked = {lj.name for lj in self.locked_joints}
        # joints that follow a leader (URDF <mimic>), those locked with it left out
        self.mimics = {n: m for n, m in mimics.items() if n not in locked}
        self.actuated = self._actuated(desc)
        self.joints = self._joints(desc)
        self.closure = self._closure(desc, anchors)
        self._bodies = self._make_bodies(desc)
        self.standard_names = tuple(f"{k}_{b.label}" for b in self._bodies for k in b.kinds)
        self._columns = [b.column(k) for b in self._bodies for k in b.kinds]
        self.bodies = self._body_table()
        self._fixed_frames = [model.getFrameId(b.link, pin.FrameType.BODY)
                              for b in self._bodies if b.joint is None]
        self._lock = threading.Lock()
        self.payload_frame = desc.payload_frame or self.tree_joints[-1].link
        self._bind_payload(Payload(1.0, self.payload_frame))
        self._base = self._base_set(seed)
        self.K = self._base.K
        self.parameters = list(self._base.parameters)
        self._base_columns = [self._columns[c] for c in self._base.columns]

    # --- construction ---------------------------------------------------------------------
    def _locked(self, model: pin.Model, mimics: dict, desc: RobotDescription, anchors: list,
                where: str | None) -> tuple[LockedJoint, ...]:
        """The joints fixed before anything else (model/locked_joints.py)."""
        where = where or f"robot {self.name}"
        if anchors and desc.locked_joints:
            raise ConfigError(f"{where}: locked_joints with the loops of an MJCF's <equality> "
                              "is not supported (give the loops in the robot file)")
        return locked_joints(movable_joints(model), mimics, desc,
                             not desc.loops and not anchors, where)

    def _actuated(self, desc: RobotDescription) -> tuple[TreeJoint, ...]:
        by_name = {j.name: j for j in self.tree_joints}
        names = desc.actuated_joints or tuple(n for n in by_name if n not in self.mimics)
        for n in names:
            if n in self.mimics:
                raise ConfigError(f"robot {self.name}: actuated joint {n!r} is a mimic joint of "
                                  f"{desc.path.name} (it follows {self.mimics[n].leader!r}): "
                                  "actuate its leader")
            if n not in by_name:
                raise ConfigError(f"robot {self.name}: actuated joint {n!r} is not a movable joint "
                                  f"of {desc.path.name} (movable: {', '.join(by_name)})")
            if not by_name[n].one_dof:
                raise ConfigError(f"robot {self.name}: actuated joint {n!r} is a "
                                  f"{by_name[n].kind}; only 1-DOF joints can be actuated")
        if len(set(names)) != len(names):
            raise ConfigError(f"robot {self.name}: actuated_joints lists a joint twice: "
                              f"{list(names)}")
        actuated = tuple(by_name[n] for n in names)
        self._mimic_rows = self._followers(desc, by_name, actuated)
        return actuated

    @property
    def mimic_rows(self) -> tuple[tuple[TreeJoint, int, float, float], ...]:
        """(mimic joint, its leader's actuated index, multiplier, offset) of each URDF mimic."""
        return self._mimic_rows

    def _followers(
        self, desc: RobotDescription, by_name: dict[str, TreeJoint], actuated: tuple[TreeJoint, ...]
    ) -> tuple[tuple[TreeJoint, int, float, float], ...]:
        """(mimic joint, its leader's actuated index, multiplier, offset) of each mimic joint:
        only a 1-DOF mimic of an actuated leader, in an open tree, is supported (said)."""
        out = []
        index = {j.name: a for a, j in enumerate(actuated)}
        for m in self.mimics.values():
            if m.joint not in by_name:
                continue  # a fixed joint Pinocchio dropped
            if desc.loops or m.leader not in index or not by_name[m.joint].one_dof:
                raise ConfigError(
                    f"robot {self.name}: mimic joint {m.joint!r} of {desc.path.name} follows "
                    f"{m.leader!r}: only a 1-DOF mimic of an actuated joint in an open tree is "
                    "supported (its position r·q_leader + offset, its torque added r times to "
                    "the leader's)")
            out.append((by_name[m.joint], index[m.leader], m.multiplier, m.offset))
        return tuple(out)

    def _joints(self, desc: RobotDescription) -> tuple[ActuatedJoint, ...]:
        self.nominal_gains_given = desc.nominal_gains is not None
        gains = 1.0 if desc.nominal_gains is None else desc.nominal_gains
        if isinstance(gains, float):
            gains = (gains,) * len(self.actuated)
        if len(gains) != len(self.actuated):
            raise ConfigError(f"robot {self.name}: {len(gains)} nominal_gains for "
                              f"{len(self.actuated)} actuated joints")
        return tuple(ActuatedJoint(j.name, j.unit_kind, g, j.lower, j.upper, j.velocity)
                     for j, g in zip(self.actuated, gains))

    def _reference(self, desc: RobotDescription) -> np.ndarray:
        q = pin.neutral(self.model)
        by_name = {j.name: j for j in self.tree_joints}
        locked = {lj.name for lj in self.locked_joints}
        for name, value in desc.reference_configuration.items():
            if name in locked:
                continue  # fixed at its locked value already
            if name not in by_name or not by_name[name].one_dof:
                raise ConfigError(f"robot {self.name}: reference_configuration names {name!r}, "
                                  "not a 1-DOF movable joint of the description")
            j = by_name[name]
            q[j.iq:j.iq + (2 if j.kind == "continuous" else 1)] = \
                (math.cos(value), math.sin(value)) if j.kind == "continuous" else (value,)
        return q

    def _closure(self, desc: RobotDescription, anchors: list) -> Closure | None:
        if not desc.loops and not anchors:
            free = [j.name for j in self.tree_joints
                    if j not in self.actuated and j.name not in self.mimics]
            if free:
                raise ConfigError(f"robot {self.name}: joints {free} move but are neither "
                                  "actuated nor closed by a loop: list them in actuated_joints, "
                                  "lock them (locked_joints: {joint: value}), or add the loops")
            return None
        loops = LoopConstraints(self.model, desc.loops, anchors)
        try:
            return Closure(self.model, loops, self.actuated, self._reference(desc))
        except OrthoglideError as exc:
            if isinstance(exc, ConfigError):
                raise
            raise ConfigError(f"robot {self.name}: {exc}; check the loops' frames and "
                              "reference_configuration") from None

    def _make_bodies(self, desc: RobotDescription) -> list[_Body]:
        closed = self.closure is not None
        friction = closed if desc.passive_friction is None else desc.passive_friction
        labels = dict(desc.body_labels)
        links = [j.link for j in self.tree_joints] + list(desc.fixed_bodies)
        bad = sorted(set(labels) - set(links))
        if bad:
            raise ConfigError(f"robot {self.name}: body_labels names {bad}, not bodies "
                              f"(bodies: {', '.join(links)})")
        label = {link: labels.get(link, str(k)) for k, link in enumerate(links, 1)}
        if len(set(label.values())) != len(label):
            raise ConfigError(f"robot {self.name}: two bodies share a label: {label}")
        out = []
        for j in self.tree_joints:  # a mimic's friction is in its leader's columns (r², |r|)
            terms = ACTUATED_TERMS if j in self.actuated else \
                (PASSIVE_TERMS if friction and j.one_dof and j.name not in self.mimics else ())
            out.append(_Body(label[j.link], j.link, INERTIAL_KINDS + terms, j))
        for slot, link in enumerate(desc.fixed_bodies):
            fixed_link(self.model, link)  # ConfigError unless a massive link on a moving body
            out.append(_Body(label[link], link, INERTIAL_KINDS, None, slot))
        return out

    def _body_table(self) -> tuple[Body, ...]:
        index = {n: k for k, n in enumerate(self.standard_names)}
        return tuple(Body(b.link, tuple(index[f"{k}_{b.label}"] for k in INERTIAL_KINDS), b.link)
                     for b in self._bodies)

    def column_order(self) -> list[int]:
        """Standard columns in the QR order: ``column_order`` groups (each group's parameters
        kind by kind, its bodies side by side: eq. 23), then the other bodies from the base."""
        by_label = {b.label: b for b in self._bodies}
        index = {n: k for k, n in enumerate(self.standard_names)}
        order: list[int] = []
        seen: set[str] = set()
        for group in self.description.column_order:
            for lab in group:
                if lab not in by_label or lab in seen:
                    raise ConfigError(f"robot {self.name}: column_order: {lab!r} is "
                                      f"{'listed twice' if lab in seen else 'not a body label'} "
                                      f"(labels: {', '.join(by_label)})")
                seen.add(lab)
            kinds = {by_label[lab].kinds for lab in group}
            if len(kinds) != 1:
                raise ConfigError(f"robot {self.name}: column_order group {list(group)} mixes "
                                  "bodies with different parameters (actuated and passive joints?)")
            order += [index[f"{k}_{lab}"] for k in kinds.pop() for lab in group]
        rest = [b for b in self._bodies if b.label not in seen]
        return order + [index[f"{k}_{b.label}"] for b in rest for k in b.kinds]

    def _base_set(self, seed: int) -> BaseSet:
        n = max(100, math.ceil(ROWS_PER_PARAMETER * len(self.standard_names) / self.n_joints))
        W = self.standard_regressor(*self.random_states(n, seed))
        return base_parameters(W, self.standard_names, self.column_order())

    def _payload_frame(self, frame: str) -> pin.Frame:
        """The frame a payload is fixed to; ConfigError when the robot has no such movable frame."""
        if not self.model.existFrame(frame):
            raise ConfigError(f"robot {self.name}: the payload frame {frame!r} is not a frame of "
                              f"{self.description.path.name}")
        frame_ = self.model.frames[self.model.getFrameId(frame)]
        if frame_.parentJoint == 0:
            raise ConfigError(f"robot {self.name}: the payload frame {frame!r} is fixed to the "
                              "world")
        return frame_

    def payload_standard_block(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray,
                               frame: str) -> np.ndarray:
        """(10, n, m): efforts of each payload parameter (INERTIAL_KINDS) at ``frame``: the
        columns of the frame's joint body for the parameters moved into that joint's frame
        (the move is linear in the ten parameters: one column per unit parameter)."""
        joint, chi = self._unit_payloads(frame)
        q, qd, qdd = self._samples(q, qd, qdd)
        out = np.zeros((10, self.n_joints, q.shape[0]))
        with self._lock:
            return self._rows.block(q, qd, qdd, [], (joint, chi), out)

    def observation_and_payload_block(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray,
                                      frame: str) -> np.ndarray:
        """[W | W_payload | the ten payload columns at ``frame``] (n_b + 11, n, m) in one pass
        of Pinocchio's regressor: both payloads' columns from the same joint-body columns."""
        joint, chi = self._unit_payloads(frame)
        if joint != self._payload[0]:  # on other bodies: two passes
            return super().observation_and_payload_block(q, qd, qdd, frame)
        q, qd, qdd = self._samples(q, qd, qdd)
        out = np.zeros((self.n_b + 11, self.n_joints, q.shape[0]))
        both = np.column_stack([self._payload[1], chi])
        with self._lock:
            return self._rows.block(q, qd, qdd, self._base_columns, (joint, both), out)

    def _unit_payloads(self, frame: str) -> tuple[int, np.ndarray]:
        """The joint a frame is on and its (10, 10) unit payload parameters moved there."""
        frame_ = self._payload_frame(frame or self.payload_frame)
        return int(frame_.parentJoint), np.column_stack(
            [_moved(frame_.placement, e) for e in np.eye(10)])

    def _bind_payload(self, payload: Payload) -> None:
        frame = payload.frame or self.payload_frame
        if not self.model.existFrame(frame):
            raise ConfigError(f"robot {self.name}: the payload frame {frame!r} is not a frame of "
                              f"{self.description.path.name}")
        fid = self.model.getFrameId(frame)
        if self.model.frames[fid].parentJoint == 0:
            raise ConfigError(f"robot {self.name}: the payload frame {frame!r} is fixed to the "
                              "world")
        self.payload = payload
        # the payload is rigidly fixed to its frame's joint body: per kg, its inertia moved into
        # that joint's frame, whose regressor columns then give its forces (no per-sample frame
        # regressor or Jacobian)
        frame_ = self.model.frames[fid]
        shape = pin.Inertia.FromDynamicParameters(pin_parameters(payload.shape()))
        self._payload = (int(frame_.parentJoint),
                         frame_.placement.act(shape).toDynamicParameters())
        if getattr(self, "_rows", None) is None:
            self._rows = TreeRegressor(self.model, self.actuated, self._fixed_frames,
                                       self.closure, self._mimic_rows)

    # --- RobotModel (names, expressions: NamedByParameters) -------------------------------
    def _samples(self, *arrays: np.ndarray) -> list[np.ndarray]:
        out = []
        for x, name in zip(arrays, ("q", "qd", "qdd")):
            x = np.asarray(x, dtype=float)
            x = x[None, :] if x.ndim == 1 else x
            if x.ndim != 2 or x.shape[1] != self.n_joints:
                raise ModelError(f"{name} must have shape (N, {self.n_joints}) for robot "
                                 f"{self.name}, got {x.shape}")
            if not np.all(np.isfinite(x)):
                k = int(np.flatnonzero(~np.all(np.isfinite(x), axis=1))[0])
                raise ModelError(f"{name} has a non-finite value at sample {k}: {_fmt(x[k])}")
            out.append(x)
        if len({x.shape[0] for x in out}) != 1:
            raise ModelError("q, qd, qdd have different numbers of samples: "
                             f"{[x.shape for x in out]}")
        if self.closure is not None:
            self._check_limits(out[0])
        return out

    def _check_limits(self, q: np.ndarray) -> None:
        """WorkspaceError for a closed chain's sample beyond an actuated joint's limits: closing
        the loops there may give another assembly mode than the robot's."""
        for a, j in enumerate(self.joints):
            out = (q[:, a] < j.lower) | (q[:, a] > j.upper)
            if out.any():
                k = int(np.argmax(out))
                raise WorkspaceError(f"{j.name} = {q[k, a]:.6g} {j.unit} at sample {k} is outside "
                                     f"its limits [{j.lower:g}, {j.upper:g}] {j.unit}: the loops "
                                     "could close in another assembly mode there (widen the "
                                     "description's limits if the robot goes there)")

    def observation_block(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray,
                          out: np.ndarray | None = None) -> np.ndarray:
        """[W | W_payload] as (n_b + 1, n, m): base columns, then the efforts per kg of the
        bound payload (eqs. 18, 20, 33); written into ``out`` when given."""
        q, qd, qdd = self._samples(q, qd, qdd)
        if out is None:
            out = np.zeros((self.n_b + 1, self.n_joints, q.shape[0]))
        with self._lock:
            return self._rows.block(q, qd, qdd, self._base_columns, self._payload, out)

    @property
    def rough_columns(self) -> tuple[int, ...] | None:
        """Columns of [W | W_payload] that are not smooth functions of the filtered states:
        the Coulomb friction ones, sign(q̇). The stream (identify/stream.py) decimates them at
        the sample rate and builds the others at the decimated rows only. None for a closed
        chain: its friction columns need the loops closed at every sample anyway (Gᵀ sign(q̇_t)),
        so nothing is saved, and the five-bar's mx_2R moved by 0.11 σ."""
        if self.closure is not None:
            return None
        return tuple(k for k, c in enumerate(self._base_columns)
                     if c.source == "drive" and c.kind == "fs")

    def rough_block(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray,
                    out: np.ndarray | None = None) -> np.ndarray:
        """The :attr:`rough_columns` of states (m, n) as (len(rough_columns), n, m)."""
        q, qd, qdd = self._samples(q, qd, qdd)
        cols = [self._base_columns[k] for k in self.rough_columns]
        if out is None:
            out = np.zeros((len(cols), self.n_joints, q.shape[0]))
        with self._lock:
            return self._rows.block(q, qd, qdd, cols, None, out)

    def standard_block(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray,
                       columns: Sequence[int], payload: bool = False) -> np.ndarray:
        """(len(columns) [+ 1], n, m): the standard ``columns`` (indices into standard_names),
        then the bound payload's column when ``payload`` (a transmission's wrapper,
        model/actuator_space.py, takes its base columns from here)."""
        q, qd, qdd = self._samples(q, qd, qdd)
        out = np.zeros((len(columns) + int(payload), self.n_joints, q.shape[0]))
        with self._lock:
            return self._rows.block(q, qd, qdd, [self._columns[c] for c in columns],
                                    self._payload if payload else None, out)

    def actuated_drive_columns(self) -> list[int]:
        """Indices in standard_names of the actuated joints' drive terms (ia, fv, fs, tauoff)."""
        return [k for k, c in enumerate(self._columns) if c.source == "drive"
                and any(j.iv == c.index for j in self.actuated)]

    def drive_columns(self, joint: int) -> dict[str, int]:
        """Kind (ia, fv, fs, tauoff) -> index in standard_names of actuated joint ``joint``'s
        drive terms."""
        iv = self.actuated[joint].iv
        return {c.kind: k for k, c in enumerate(self._columns)
                if c.source == "drive" and c.index == iv}

    def standard_regressor(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        """W_st (n m, n_st), rows joint by joint (eq. 20), columns in ``standard_names`` order."""
        q, qd, qdd = self._samples(q, qd, qdd)
        out = np.zeros((len(self._columns), self.n_joints, q.shape[0]))
        with self._lock:
            self._rows.block(q, qd, qdd, self._columns, None, out)
        return out.reshape(out.shape[0], -1).T

    @property
    def gravity(self) -> tuple[float, float, float]:
        """m/s², the description's (z up unless the robot file says otherwise)."""
        return self.description.gravity

    def with_payload(self, payload: Payload) -> PinocchioRobot:
        """The same robot whose payload column is ``payload``'s (its frame, or payload_frame)."""
        other = copy.copy(self)  # shares the tree, closure, base parameters and the lock
        other._bind_payload(payload)
        return other

    def random_states(self, n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """n regular states inside the joint limits: q uniform (closed chains: assembled in the
        reference's working mode, passive joints within their limits, |G| at most
        MAX_RATE_GROWTH times the reference's, in nearest-neighbour order), q̇ ~ N(0, 1),
        q̈ ~ N(0, 10) (m or rad per s, per s²)."""
        rng = np.random.default_rng(seed)
        lo = np.array([j.lower if math.isfinite(j.lower) else -UNBOUNDED_RANGE[j.unit_kind]
                       for j in self.actuated])
        hi = np.array([j.upper if math.isfinite(j.upper) else UNBOUNDED_RANGE[j.unit_kind]
                       for j in self.actuated])
        shape = (n, self.n_joints)
        if self.closure is None:
            q = rng.uniform(lo, hi, shape)
        else:
            with self._lock:
                q = self._closed_states(n, rng, lo, hi)
        return q, rng.normal(0.0, RATE_SD, shape), rng.normal(0.0, ACC_SD, shape)

    def _closed_states(self, n: int, rng: np.random.Generator, lo: np.ndarray,
                       hi: np.ndarray) -> np.ndarray:
        """Uniform candidates, visited nearest first and each closed by continuation from the
        last one kept (short hops: a few Newton steps each, on the reference's branch)."""
        c = self.closure
        model, zero = self.model, np.zeros((1, self.n_joints))

        def rates(q_a: np.ndarray, q_t: np.ndarray) -> float:  # max |G| at a closed state
            st = TreeStates.empty(1, model.nq, model.nv, self.n_joints)
            return float(np.max(np.abs(c.states(q_a[None], zero, zero, st, q_t[None]).G)))

        limit = MAX_RATE_GROWTH * rates(c.actuated_values(c.reference), c.reference)
        passive = [j for j in self.tree_joints if j not in self.actuated and j.one_dof
                   and j.kind != "continuous"]
        out: list[np.ndarray] = []
        last = c.reference
        for _ in range(20):
            candidates = rng.uniform(lo, hi, (2 * (n - len(out)) + 10, self.n_joints))
            for q_a in _nearest_first(candidates, c.actuated_values(last), hi - lo):
                try:
                    q_t = c.close(q_a, last)
                    ok = all(j.lower <= q_t[j.iq] <= j.upper for j in passive) and \
                        rates(q_a, q_t) <= limit
                except OrthoglideError:
                    continue
                if ok:
                    out.append(q_a)
                    last = q_t
                    if len(out) == n:
                        return np.array(out)
        raise ModelError(f"robot {self.name}: found only {len(out)} of {n} regular assembled "
                         "states within the joint limits: check the limits and the reference")

    # --- nominal values from the description ---------------------------------------------
    def effort_limits(self) -> dict[str, float]:
        """The URDF's ``<limit effort>`` (N·m or N) of each actuated joint that gives one."""
        out = {}
        for j in self.joints:
            if not self.model.existJointName(j.name):
                continue
            iv = self.model.joints[self.model.getJointId(j.name)].idx_v
            lim = float(self.model.effortLimit[iv])
            if math.isfinite(lim) and lim > 0:
                out[j.name] = lim
        return out

    def standard_values(self) -> np.ndarray:
        """χ_st of the description itself (``standard_names`` order): inertials of the links,
        ia = armature, fv = damping, fs = friction of each joint, tauoff = 0."""
        out = []
        fixed = {b.link: fixed_link(self.model, b.link) for b in self._bodies if b.joint is None}
        for b in self._bodies:
            if b.joint is None:
                inertia = fixed[b.link][2]
            else:
                inertia = self.model.inertias[b.joint.id].copy()
                for jid, placement, I_f in fixed.values():
                    if jid == b.joint.id:
                        inertia = inertia - placement.act(I_f)
            pi = inertia.toDynamicParameters()
            terms = {"ia": float(self.model.armature[b.joint.iv]) if b.joint else 0.0,
                     "fv": b.joint.damping if b.joint else 0.0,
                     "fs": b.joint.friction if b.joint else 0.0, "tauoff": 0.0}
            chi = dict(zip(INERTIAL_KINDS, kinds_parameters(pi)))
            out += [chi[k] if k in INERTIAL_KINDS else terms[k] for k in b.kinds]
        return np.array(out)

    # --- for people -----------------------------------------------------------------------
    def table(self) -> str:
        w = max(len(n) for n in self.names)
        lines = [f"{self.n_b} base parameters of robot {self.name} (of {len(self.standard_names)} "
                 f"standard; {self._order_text()})", "Bodies:"]
        for b in self._bodies:
            how = (f"joint {b.joint.name} ({b.joint.kind}, "
                   f"{'actuated' if b.joint in self.actuated else 'passive'})") if b.joint else \
                f"fixed to {self.model.names[fixed_link(self.model, b.link)[0]]}'s body"
            lines.append(f"  {b.label:>4}  {b.link:<20} {how}")
        lines.append(f"{'#':>3}  {'name':<{w}}  expression")
        for k, p in enumerate(self.parameters, 1):
            lines.append(f"{k:>3}  {p.name:<{w}}  {p.expression}")
        gains = ", ".join(f"{j.name} {j.nominal_gain:g} {j.gain_unit}" for j in self.joints)
        lines.append(f"Actuated joints (nominal gains): {gains}. "
                     f"Payload frame: {self.payload_frame}.")
        if self.locked_joints:
            lines.append(lock_text(self.locked_joints))
        return "\n".join(lines)

    def _order_text(self) -> str:
        groups = self.description.column_order
        order = "column order " + " ".join("(" + " ".join(g) + ")" for g in groups) \
            if groups else "columns from the base outwards"
        return f"{order}, QR rank gap {self._base.rank_gap:.2g}"

    def to_json(self) -> dict:
        return {
            "robot": self.name,
            "n_standard": len(self.standard_names),
            "n_base": self.n_b,
            "column_order": [list(g) for g in self.description.column_order] or "from the base",
            "joints": [{"name": j.name, "kind": j.kind, "nominal_gain": j.nominal_gain,
                        "unit": j.gain_unit} for j in self.joints],
            "locked_joints": [lj.to_json() for lj in self.locked_joints],
            "bodies": [{"label": b.label, "link": b.link,
                        "joint": b.joint.name if b.joint else None} for b in self._bodies],
            "parameters": [{"name": p.name, "standard": p.standard, "expression": p.expression,
                            "terms": [{"name": n, "coefficient": c} for n, c in p.terms]}
                           for p in self.parameters],
        }

