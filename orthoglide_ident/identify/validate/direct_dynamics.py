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

The model is the robot's own forward model (``RobotModel.forward_model``, model/forward.py):
the URDF written for it (the inertials that file carries) with the identified rotor inertias as
armature and each joint's friction fv q̇ + fs sign(q̇) + tauoff as a generalised force; a loaded
record's payload is added at its frame; a robot with loops closes them its own way (the
Orthoglide: model/orthoglide/forward.py). The drive terms the paper's model lacks
(current-loop lag, ripple) are left out. A robot with passive joints other than the
Orthoglide's (a closed chain from a robot YAML) is not simulated: the record's entry says so.
"""
from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from orthoglide_ident.identify.consistency.report import DirectDynamics, DirectDynamicsJoint
from orthoglide_ident.identify.observe.filtering import derivative_filter
from orthoglide_ident.model.forward import simulate
from orthoglide_ident.model.robot import Payload, RobotModel

HORIZON_S = 0.2  # s, window of open-loop simulation from the measured state


def _rate(stamps_ns: np.ndarray) -> float:
    """A record's sample rate (Hz) from its median step, 1 kHz when it cannot tell."""
    dt = np.diff(np.asarray(stamps_ns, np.int64))
    med = float(np.median(dt)) if dt.size else 0.0
    return 1e9 / med if med > 0 else 1e3


def _windows(fwd, q: np.ndarray, v_tau: np.ndarray, gains: np.ndarray, period_s: float,
             opts, horizon_s: float, max_windows: int) -> tuple[np.ndarray, np.ndarray, int]:
    """Squared position errors and drifts (n_samples, n_j) of the windows of one segment."""
    opts = opts.at_rate(1.0 / period_s)
    qf, qdf, _ = derivative_filter(q, period_s, opts.observe.filter_cutoff_hz,
                                   opts.observe.filter_order)
    trim = int(round(opts.observe.edge_trim_s / period_s))
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
            robot: RobotModel, horizon_s: float) -> DirectDynamics:
    """The figures of one record: per joint rms error, drift and their ratio."""
    e2, d2 = np.concatenate(errors), np.concatenate(drifts)
    rms, drift = np.sqrt(e2.mean(axis=0)), np.sqrt(d2.mean(axis=0))
    return DirectDynamics(record_name, engine, n_windows, tuple(
        DirectDynamicsJoint(j.name, j.unit, float(r), float(d),
                            float(r / d) if d > 0 else math.inf)
        for j, r, d in zip(robot.joints, rms, drift)), horizon_s)


def validate(record, robot: RobotModel, chi_st: np.ndarray, gains: Sequence[float],
             payload_mass: float, opts, horizon_s: float = HORIZON_S,
             max_windows: int = 100) -> DirectDynamics:
    """The direct-dynamic validation of ``record`` (records.Record, tagged payload mass in kg)
    for the consistent standard parameters ``chi_st``: see the module docstring."""
    from orthoglide_ident.identify.records.segments import split_record

    payload = None
    if record.condition == "loaded":
        payload = record.payload or Payload(payload_mass)
        payload = Payload(payload_mass, payload.frame, payload.com, payload.inertia)
    fwd, engine = robot.forward_model(chi_st, gains, payload)
    if fwd is None:
        return DirectDynamics(record.source, engine, 0)
    rate = _rate(record.stamps_q_ns)
    segments, rep = split_record(
        record.stamps_q_ns, record.names_q, record.q, record.stamps_v_ns, record.names_v,
        record.v_tau, min_samples=opts.at_rate(rate).observe.min_segment_samples(1.0 / rate),
        nonfinite="drop", source=record.source, joint_names=robot.joint_names)
    errors, drifts, n = [], [], 0
    g = np.asarray(gains, float)
    for seg in segments:
        e, d, k = _windows(fwd, seg.q, seg.v_tau, g, rep.period_s, opts, horizon_s,
                           max(1, max_windows // len(segments)))
        errors.append(e), drifts.append(d)
        n += k
    if not n:
        return DirectDynamics(record.source, engine + ": record too short for a window", 0)
    return figures(record.source, engine, errors, drifts, n, robot, horizon_s)
