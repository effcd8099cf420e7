"""Direct-dynamic validation: the identified consistent model, forward-simulated by Pinocchio
under the recorded currents of a validation record, against the measured motion.

The cross-validation (validation.py, the paper's Fig. 5) compares forces along the measured
motion. This runs the other way, as a simulator or a model-based controller would use the
model: from the measured state (q̂, q̂̇ of the derivative filter) at the start of each window of
``horizon_s`` the model is integrated (RK4, SUBSTEPS per tick) under the recorded currents —
τ = g_τ v_τ[k] held over [t_k, t_k+1), the controller's zero-order hold — and its joint
positions are compared with the measured (filtered) ones over the window. Windows follow each
other through every continuous segment, so the whole record is simulated. The reference figure
is the drift of the same windows without dynamics, q̂(t0) + q̂̇(t0) (t − t0): the error relative
to it says how much of the motion over the horizon the model explains (0: all of it).

The model is built from the URDF written for it (model/urdf.py: the inertials that file
carries) with the identified rotor inertias as armature and each joint's friction
fv q̇ + fs sign(q̇) + tauoff as a generalised force; a loaded record's payload is added at its
frame. For the Orthoglide the open tree of that URDF is closed by two 6D welds (body 5 of legs 2
and 3 to the platform, Pinocchio's constraint dynamics, as its plant in orthoglide_sim closes
the loops; the product does not import the simulator). The drive terms the paper's model lacks
(current-loop lag, ripple) are left out. A robot with passive joints other than the
Orthoglide's (a closed chain from a robot YAML) is not simulated: the record's entry says so.
"""
from __future__ import annotations

import math
from typing import Any, Mapping, Sequence

import numpy as np
import pinocchio as pin

from orthoglide_ident.identify.filtering import derivative_filter
from orthoglide_ident.model.robot import Payload, RobotModel

HORIZON_S = 0.2  # s, window of open-loop simulation from the measured state
SUBSTEPS = 1  # RK4 steps per controller tick (the currents are held over it)
PROX = (1e-12, 0.0, 1)  # constraintDynamics: accuracy, mu = 0 (the exact KKT solution), iterations


def _pin_inertia(chi10: np.ndarray) -> pin.Inertia:
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
        self.model.inertias[f.parentJoint] += f.placement.act(_pin_inertia(chi10))
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
        from orthoglide_ident.model.kinematics import tree_state

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


def _rate(stamps_ns: np.ndarray) -> float:
    """A record's sample rate (Hz) from its median step, 1 kHz when it cannot tell."""
    dt = np.diff(np.asarray(stamps_ns, np.int64))
    med = float(np.median(dt)) if dt.size else 0.0
    return 1e9 / med if med > 0 else 1e3


def _windows(fwd, q: np.ndarray, v_tau: np.ndarray, gains: np.ndarray, period_s: float,
             opts, horizon_s: float, max_windows: int) -> tuple[np.ndarray, np.ndarray, int]:
    """Squared position errors and drifts (n_samples, n_j) of the windows of one segment."""
    opts = opts.at_rate(1.0 / period_s)
    qf, qdf, _ = derivative_filter(q, period_s, opts.filter_cutoff_hz, opts.filter_order)
    trim = int(round(opts.edge_trim_s / period_s))
    n_w = max(1, int(round(horizon_s / period_s)))
    starts = np.arange(trim, q.shape[0] - trim - n_w, n_w)
    if starts.size > max_windows:  # spread evenly over the segment
        starts = starts[np.linspace(0, starts.size - 1, max_windows).round().astype(int)]
    if not starts.size:
        return np.zeros((0, q.shape[1])), np.zeros((0, q.shape[1])), 0
    Q0, V0 = fwd.lift(qf[starts], qdf[starts])
    err, drift = [], []
    t = period_s * np.arange(1, n_w + 1)[:, None]
    for k0, Q, V in zip(starts, Q0, V0):
        sim = simulate(fwd, Q, V, gains * v_tau[k0:k0 + n_w], period_s)[1:]
        meas = qf[k0 + 1:k0 + n_w + 1]
        err.append((sim - meas) ** 2)
        drift.append((qf[k0] + qdf[k0] * t - meas) ** 2)
    return np.concatenate(err), np.concatenate(drift), int(starts.size)


def figures(record_name: str, engine: str, errors: list, drifts: list, n_windows: int,
            robot: RobotModel, horizon_s: float) -> dict[str, Any]:
    """The JSON entry of one record: per joint rms error, drift and their ratio."""
    e2, d2 = np.concatenate(errors), np.concatenate(drifts)
    rms, drift = np.sqrt(e2.mean(axis=0)), np.sqrt(d2.mean(axis=0))
    return {"bag": record_name, "engine": engine, "windows": n_windows, "horizon_s": horizon_s,
            "joints": [{"joint": j.name, "unit": j.unit, "rms_error": float(r),
                        "drift_rms": float(d), "relative": float(r / d) if d > 0 else math.inf}
                       for j, r, d in zip(robot.joints, rms, drift)]}


def forward_model(robot: RobotModel, chi_st: np.ndarray, gains: Sequence[float],
                  payload: Payload | None):
    """(forward model, engine name) of the identified model, or (None, reason) when it cannot
    be simulated here (passive joints of a closed chain other than the Orthoglide's)."""
    from orthoglide_ident.model.base import BaseModel
    from orthoglide_ident.model.geometry import G0, GRAVITY
    from orthoglide_ident.model.urdf import PLATFORM_LINK, identified_urdf, joint_labels

    text = identified_urdf(robot, chi_st, gains)
    values = dict(zip(robot.standard_names, (float(x) for x in chi_st)))
    orthoglide = isinstance(robot, BaseModel)
    gravity = GRAVITY if orthoglide else getattr(getattr(robot, "description", None),
                                                 "gravity", (0.0, 0.0, -G0))
    tree = TreeModel(text, values, joint_labels(robot, text), gravity)
    if payload is not None and payload.mass > 0:
        frame = PLATFORM_LINK if orthoglide else (payload.frame or robot.payload_frame)
        tree.add_payload(frame, payload.mass * payload.shape())
    if orthoglide:
        return OrthoglideForward(tree), "Pinocchio constraint dynamics, closed tree of the URDF"
    if tree.model.nv != robot.n_joints or tree.model.nq != tree.model.nv:
        return None, (f"not simulated: the URDF tree has {tree.model.nv} degrees of freedom for "
                      f"{robot.n_joints} actuated joints (a closed chain)")
    return SerialForward(tree, robot.joint_names), "Pinocchio ABA on the URDF"


def validate(record, robot: RobotModel, chi_st: np.ndarray, gains: Sequence[float],
             payload_mass: float, opts, horizon_s: float = HORIZON_S,
             max_windows: int = 100) -> dict[str, Any]:
    """The direct-dynamic validation of ``record`` (pipeline.Record, tagged payload mass in kg)
    for the consistent standard parameters ``chi_st``: see the module docstring."""
    from orthoglide_ident.identify.segments import split_record

    payload = None
    if record.condition == "loaded":
        payload = record.payload or Payload(payload_mass)
        payload = Payload(payload_mass, payload.frame, payload.com, payload.inertia)
    fwd, engine = forward_model(robot, chi_st, gains, payload)
    if fwd is None:
        return {"bag": record.source, "engine": engine, "windows": 0, "joints": []}
    segments, rep = split_record(
        record.stamps_q_ns, record.names_q, record.q, record.stamps_v_ns, record.names_v,
        record.v_tau, min_samples=opts.at_rate(_rate(record.stamps_q_ns)).min_segment_samples(), nonfinite="drop",
        source=record.source, joint_names=robot.joint_names)
    errors, drifts, n = [], [], 0
    g = np.asarray(gains, float)
    for seg in segments:
        e, d, k = _windows(fwd, seg.q, seg.v_tau, g, rep.period_s, opts, horizon_s,
                           max(1, max_windows // len(segments)))
        errors.append(e), drifts.append(d)
        n += k
    if not n:
        return {"bag": record.source, "engine": engine + ": record too short for a window",
                "windows": 0, "joints": []}
    return figures(record.source, engine, errors, drifts, n, robot, horizon_s)
