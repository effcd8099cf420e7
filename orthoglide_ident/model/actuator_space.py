"""A robot with a transmission, identified in actuator space: its "joints" are its motors.

With q̇_m = N q̇_j and τ_j = Nᵀ τ_m (model/transmission.py), motor a's torque balance is

    g_a v_a = (N⁻ᵀ W(q_j, q̇_j, q̈_j))_a χ + ia_a q̈_m,a + fv_a q̇_m,a + fs_a sign(q̇_m,a) + off_a

with q_j = N⁻¹ (q_m − offset), q̇_j = N⁻¹ q̇_m, q̈_j = N⁻¹ q̈_m: the rigid-body IDIM rows of the
joint model (eqs. 15, 18, 20) premultiplied by N⁻ᵀ, sample by sample, and the paper's drive
terms (ia, fv, fs, tauoff) moved to each motor's own velocity (a coupled motor's friction stays
on that motor). Row a is motor a's equation, so the per-motor drive gains g_a come out of
IDIM-TLS (eqs. 33–36) and WLS unchanged, one row block per motor: the gain reported is the
motor's (current → motor torque), and the whole pipeline runs on this model as on any other.

A closed chain works the same way: the joint model's rows are already the actuated joints'
(the loop solved and projected, model/closure.py), and N maps the actuated joints to the motors
(tests/identify/test_on_five_bar.py).

Base parameters are regrouped again numerically (eqs. 21–23 by QR on random states of this
mixed regressor: a motor's ia can regroup with a link's inertia), rigid columns from the base
outwards, the motors' terms after them.
"""
from __future__ import annotations

import copy
import math

import numpy as np

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.model.base_parameters import BaseSet, NamedByParameters, base_parameters
from orthoglide_ident.model.pinocchio_model import ROWS_PER_PARAMETER, PinocchioRobot
from orthoglide_ident.model.robot import DRIVE_KINDS, ActuatedJoint, Body, Payload, RobotModel
from orthoglide_ident.model.transmission import Transmission


def _motor_joints(jm: PinocchioRobot, t: Transmission) -> tuple[ActuatedJoint, ...]:
    """The motors as actuated joints: kind of the joint they drive most, nominal gains of the
    robot file (per motor), limits the box q_m spans over the joints' limits."""
    out = []
    lo = np.array([j.lower for j in jm.joints])
    hi = np.array([j.upper for j in jm.joints])
    vmax = np.array([j.velocity_limit for j in jm.joints])
    for a, name in enumerate(t.actuators):
        row = t.N[a]
        used = row != 0
        ends = np.where(row > 0, 1.0, -1.0)[used]  # interval arithmetic on N's row
        low = np.sum(np.where(ends > 0, row[used] * lo[used], row[used] * hi[used])) + t.offset[a]
        up = np.sum(np.where(ends > 0, row[used] * hi[used], row[used] * lo[used])) + t.offset[a]
        kind = jm.joints[int(np.argmax(np.abs(row)))].kind
        out.append(ActuatedJoint(name, kind, jm.joints[a].nominal_gain,
                                 low if math.isfinite(low) else -math.inf,
                                 up if math.isfinite(up) else math.inf,
                                 float(np.abs(row[used]) @ vmax[used])))
    return tuple(out)


class ActuatorSpaceRobot(NamedByParameters, RobotModel):
    """A :class:`PinocchioRobot` behind a transmission: samples, rows and gains per motor."""

    def __init__(self, joint_model: PinocchioRobot, transmission: Transmission, seed: int = 0):
        jm, t = joint_model, transmission
        if tuple(t.joints) != jm.joint_names:
            raise ConfigError(f"{t.where}: transmission joints {list(t.joints)} are not the "
                              f"actuated joints {list(jm.joint_names)}")
        self.joint_model, self.transmission = jm, t
        self.name = jm.name
        self.joints = _motor_joints(jm, t)
        self.nominal_gains_given = jm.nominal_gains_given
        self.payload_frame = jm.payload_frame
        self.locked_joints = jm.locked_joints
        drive = set(jm.actuated_drive_columns())
        self._rigid = [k for k in range(len(jm.standard_names)) if k not in drive]
        self.standard_names = tuple(jm.standard_names[k] for k in self._rigid) + tuple(
            f"{kind}_{a}" for a in t.actuators for kind in DRIVE_KINDS)
        index = {n: k for k, n in enumerate(self.standard_names)}
        self.bodies = tuple(Body(b.name, tuple(index[jm.standard_names[k]] for k in b.inertial),
                                 b.frame) for b in jm.bodies)
        self._base = self._base_set(seed)
        self.K = self._base.K
        self.parameters = list(self._base.parameters)

    def _base_set(self, seed: int) -> BaseSet:
        n = max(100, math.ceil(ROWS_PER_PARAMETER * len(self.standard_names) / self.n_joints))
        W = self.standard_regressor(*self.random_states(n, seed))
        rigid = {k: r for r, k in enumerate(self._rigid)}
        order = [rigid[k] for k in self.joint_model.column_order() if k in rigid]
        drive = list(range(len(self._rigid), len(self.standard_names)))
        # the links' columns scale with N⁻ᵀ, each motor's own with N: round-off is told within
        # the links' columns only (a motor's column is never structurally zero)
        return base_parameters(W, self.standard_names, order + drive,
                               [range(len(self._rigid))] + [[c] for c in drive])

    @property
    def rigid_columns(self) -> tuple[int, ...]:
        """The joint model's standard indices of this model's first (rigid-body) columns."""
        return tuple(self._rigid)

    @property
    def gravity(self) -> tuple[float, float, float]:  # type: ignore[override]
        return self.joint_model.gravity

    @property
    def payload(self) -> Payload:
        return self.joint_model.payload

    # --- rows -------------------------------------------------------------------------------
    def _joint_side(self, q, qd, qdd) -> tuple[np.ndarray, ...]:
        t = self.transmission
        q_m, qd_m, qdd_m = (np.atleast_2d(np.asarray(x, float)) for x in (q, qd, qdd))
        return (q_m, qd_m, qdd_m, t.to_joint_position(q_m), t.to_joint_rate(qd_m),
                t.to_joint_rate(qdd_m))

    def _to_motors(self, X: np.ndarray) -> np.ndarray:
        """(k, n_j, m) joint-side efforts -> (k, n_a, m) motor-side: τ_m = N⁻ᵀ τ_j per sample."""
        return np.einsum("ja,kjm->kam", self.transmission.N_inv, X)

    def _motor_terms(self, qd_m: np.ndarray, qdd_m: np.ndarray, cols: list[int],
                     out: np.ndarray) -> None:
        """The motors' drive columns (standard indices ``cols``) into ``out`` (len(cols), n, m):
        ia q̈_m, fv q̇_m, fs sign(q̇_m), tauoff, each in its own motor's row only."""
        first = len(self._rigid)
        out[...] = 0.0
        for r, c in enumerate(cols):
            a, kind = divmod(c - first, len(DRIVE_KINDS))
            kind = DRIVE_KINDS[kind]
            out[r, a] = {"ia": qdd_m[:, a], "fv": qd_m[:, a], "fs": np.sign(qd_m[:, a]),
                         "tauoff": 1.0}[kind]

    def _block(self, q, qd, qdd, columns: list[int], payload: bool) -> np.ndarray:
        """(len(columns) [+ 1], n_a, m) for standard ``columns`` (this model's indices)."""
        q_m, qd_m, qdd_m, q_j, qd_j, qdd_j = self._joint_side(q, qd, qdd)
        first = len(self._rigid)
        rigid = [(r, self._rigid[c]) for r, c in enumerate(columns) if c < first]
        motor = [(r, c) for r, c in enumerate(columns) if c >= first]
        out = np.empty((len(columns) + int(payload), self.n_joints, q_m.shape[0]))
        X = self.joint_model.standard_block(q_j, qd_j, qdd_j, [c for _, c in rigid], payload)
        X = self._to_motors(X)
        out[[r for r, _ in rigid]] = X[:len(rigid)]
        if payload:
            out[-1] = X[-1]
        if motor:
            tmp = np.empty((len(motor), self.n_joints, q_m.shape[0]))
            self._motor_terms(qd_m, qdd_m, [c for _, c in motor], tmp)
            out[[r for r, _ in motor]] = tmp
        return out

    def observation_block(self, q, qd, qdd, out=None) -> np.ndarray:
        """[W | W_payload] (n_b + 1, n_a, m) in motor rows (eqs. 18, 20, 33 through N⁻ᵀ)."""
        X = self._block(q, qd, qdd, list(self._base.columns), True)
        if out is None:
            return X
        out[...] = X
        return out

    @property
    def rough_columns(self) -> tuple[int, ...]:
        """Columns of [W | W_payload] that are not smooth functions of the filtered states:
        the motors' Coulomb friction, sign(q̇_m) (PinocchioRobot.rough_columns)."""
        first = len(self._rigid)
        return tuple(r for r, c in enumerate(self._base.columns) if c >= first and
                     DRIVE_KINDS[(c - first) % len(DRIVE_KINDS)] == "fs")

    def rough_block(self, q, qd, qdd, out=None) -> np.ndarray:
        """The :attr:`rough_columns` of states (m, n_a) as (len(rough_columns), n_a, m)."""
        cols = [self._base.columns[r] for r in self.rough_columns]
        X = self._block(q, qd, qdd, cols, False)
        if out is None:
            return X
        out[...] = X
        return out

    def standard_regressor(self, q, qd, qdd) -> np.ndarray:
        X = self._block(q, qd, qdd, list(range(len(self.standard_names))), False)
        return X.reshape(X.shape[0], -1).T

    def payload_standard_block(self, q, qd, qdd, frame: str) -> np.ndarray:
        _, _, _, q_j, qd_j, qdd_j = self._joint_side(q, qd, qdd)
        return self._to_motors(self.joint_model.payload_standard_block(q_j, qd_j, qdd_j, frame))

    def with_payload(self, payload: Payload) -> ActuatorSpaceRobot:
        other = copy.copy(self)
        other.joint_model = self.joint_model.with_payload(payload)
        return other

    def random_states(self, n: int, seed: int = 0):
        """The joint model's random states, seen from the motors."""
        t = self.transmission
        q, qd, qdd = self.joint_model.random_states(n, seed)
        return t.to_actuator_position(q), t.to_actuator_rate(qd), t.to_actuator_rate(qdd)

    def standard_values(self) -> np.ndarray:
        """The description's rigid-body values; the motors' drive terms 0 (the URDF's armature,
        damping and friction are joint-side)."""
        jm = self.joint_model.standard_values()
        return np.r_[jm[self._rigid], np.zeros(len(self.standard_names) - len(self._rigid))]

    def identified_urdf(self, chi_st, gains) -> str:
        """The joint model's identified URDF plus the motors' ``<ros2_control>`` transmissions
        (model/urdf_transmission.py)."""
        from orthoglide_ident.model.urdf_transmission import identified_urdf

        return identified_urdf(self, chi_st, gains)

    # --- out of scope for now: said, not silently wrong --------------------------------------

    def forward_model(self, chi_st, gains, payload):
        return None, "a robot with a transmission is not simulated here yet (issue 33)"

    # --- for people -------------------------------------------------------------------------
    def table(self) -> str:
        w = max(len(n) for n in self.names)
        lines = [f"{self.n_b} base parameters of robot {self.name} in actuator space (of "
                 f"{len(self.standard_names)} standard; QR rank gap {self._base.rank_gap:.2g})",
                 self.transmission.describe(), f"{'#':>3}  {'name':<{w}}  expression"]
        lines += [f"{k:>3}  {p.name:<{w}}  {p.expression}"
                  for k, p in enumerate(self.parameters, 1)]
        gains = ", ".join(f"{j.name} {j.nominal_gain:g} {j.gain_unit}" for j in self.joints)
        lines.append(f"Motors (nominal gains, current -> motor torque): {gains}. "
                     f"Payload frame: {self.payload_frame}.")
        return "\n".join(lines)

    def to_json(self) -> dict:
        t = self.transmission
        return {
            "robot": self.name, "n_standard": len(self.standard_names), "n_base": self.n_b,
            "transmission": {"joints": list(t.joints), "actuators": list(t.actuators),
                             "reduction": t.N.tolist(), "offset": t.offset.tolist(),
                             "position_side": t.position_side, "effort_side": t.effort_side},
            "joints": [{"name": j.name, "kind": j.kind, "nominal_gain": j.nominal_gain,
                        "unit": j.gain_unit} for j in self.joints],
            "parameters": [{"name": p.name, "standard": p.standard, "expression": p.expression,
                            "terms": [{"name": n, "coefficient": c} for n, c in p.terms]}
                           for p in self.parameters],
        }
