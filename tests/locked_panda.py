"""The example-robot-data Panda as it comes (fingers, one a mimic joint), its fingers locked: a
test and bench fixture (issue 43).

``robot_file`` writes a robot YAML naming the 7 arm joints (fingers locked at ``FINGER`` m, or
left out: locked at 0); ``records`` simulates an unloaded and a loaded record with a generator
that is not the identification model: Pinocchio's RNEA on the **full** URDF (both fingers as
joints of their own, held at their locked values, the mimic's r·q + o by hand), its own
inertials, plus rotor inertia, viscous and Coulomb friction and a point-mass payload at the
payload frame; the currents v = τ / g_τ held over each 1 ms step (zero-order hold, the mean of
τ over the step by 4-point Gauss-Legendre) with white current noise.
"""
from __future__ import annotations

import importlib.metadata
from pathlib import Path

import numpy as np
import pinocchio as pin
from example_robots import urdf

from orthoglide_ident.identify import Record
from orthoglide_ident.model.robot import Payload

ARM = tuple(f"panda_joint{i}" for i in range(1, 8))
FINGERS = ("panda_finger_joint1", "panda_finger_joint2")  # the second mimics the first
FINGER = 0.03  # m, the fingers' locked opening
PAYLOAD_FRAME = "panda_hand_tcp"
PAYLOAD_KG = 2.0
PAYLOAD_COM = (0.08, -0.03, 0.05)  # m in PAYLOAD_FRAME: off joint 7's axis, so that it loads it
PAYLOAD_INERTIA = (0.004, 0.0002, 0.0, 0.005, 0.0, 0.003)  # kg·m² about the CoM: xx xy xz yy yz zz
NOMINAL_GAIN = 5.0  # N·m/A
TRUE_GAINS = NOMINAL_GAIN * np.array([1.04, 0.97, 1.02, 0.95, 1.06, 0.98, 1.03])
ARMATURE = np.array([0.3, 0.3, 0.3, 0.3, 0.1, 0.1, 0.1])  # kg·m², reflected rotor inertia
FV = np.array([0.6, 0.5, 0.5, 0.4, 0.2, 0.2, 0.15])  # N·m·s/rad
FS = np.array([0.8, 0.9, 0.7, 0.8, 0.4, 0.35, 0.3])  # N·m
ACCELERATION = (15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0)  # rad/s², Franka's datasheet
G = np.array([0.0, 0.0, -9.80665])  # m/s², the product's default


def share_dir() -> Path:
    """The folder holding example-robot-data (its package:// meshes: ``--package-dir``)."""
    return urdf_path().parents[4]


def urdf_path() -> Path:
    """panda.urdf of the example-robot-data wheel (its cmeel prefix), as it comes."""
    return urdf("panda_description/urdf/panda.urdf")


def installed() -> bool:
    try:
        return urdf_path().is_file()
    except importlib.metadata.PackageNotFoundError:
        return False


def robot_file(folder: Path, locked: bool = True, finger: float = FINGER) -> Path:
    """A robot YAML for the Panda: the 7 arm joints, the fingers locked at ``finger`` (or left
    out), the acceleration limits of Franka's datasheet for exciting trajectories."""
    lines = [f"name: panda_locked\ndescription: {urdf_path()}",
             f"actuated_joints: [{', '.join(ARM)}]", f"nominal_gains: {NOMINAL_GAIN}",
             f"payload_frame: {PAYLOAD_FRAME}",
             f"excitation: {{acceleration_limits: [{', '.join(map(str, ACCELERATION))}]}}"]
    if locked:
        lines.append(f"locked_joints: {{{FINGERS[0]}: {finger}}}")
    path = folder / (f"panda_locked_{finger:g}.yaml" if locked else "panda_unlisted.yaml")
    path.write_text("\n".join(lines) + "\n")
    return path


def full_model(payload_kg: float, finger: float) -> tuple[pin.Model, np.ndarray]:
    """The full URDF model with the payload's rigid body added to its frame's joint body, and
    the configuration tail of the fingers (finger, 1·finger + 0: the URDF's mimic)."""
    model = pin.buildModelFromUrdf(str(urdf_path()))
    model.gravity = pin.Motion(G, np.zeros(3))
    if not payload_kg:
        return model, np.array([finger, finger])
    frame = model.frames[model.getFrameId(PAYLOAD_FRAME)]
    xx, xy, xz, yy, yz, zz = PAYLOAD_INERTIA
    body = pin.Inertia(payload_kg, np.array(PAYLOAD_COM),
                       np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]]))
    model.inertias[frame.parentJoint] = model.inertias[frame.parentJoint] + \
        frame.placement.act(body)
    return model, np.array([finger, finger])


def trajectory(t: np.ndarray, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Sums of 5 sines per joint around the middle of its range, within 70 % of it."""
    model = pin.buildModelFromUrdf(str(urdf_path()))
    lo, hi = model.lowerPositionLimit[:7], model.upperPositionLimit[:7]
    mid, half = (lo + hi) / 2, 0.7 * np.minimum((hi - lo) / 2, 1.2)
    rng = np.random.default_rng(seed)
    t = np.asarray(t, float)[:, None]
    q, qd, qdd = np.zeros((len(t), 7)) + mid, np.zeros((len(t), 7)), np.zeros((len(t), 7))
    for _ in range(5):
        f, ph = rng.uniform(0.1, 0.8, 7), rng.uniform(0, 2 * np.pi, 7)
        a, w = rng.uniform(0.3, 1.0, 7) * half / 5, 2 * np.pi * f
        q += a * np.sin(w * t + ph)
        qd += a * w * np.cos(w * t + ph)
        qdd -= a * w * w * np.sin(w * t + ph)
    return q, qd, qdd


def torques(model: pin.Model, tail: np.ndarray, t: np.ndarray, seed: int) -> np.ndarray:
    """τ (N, 7) of the full model along the trajectory at times t: RNEA with the fingers at
    rest at their locked opening, + ia q̈ + fv q̇ + fs sign(q̇)."""
    q, qd, qdd = trajectory(t, seed)
    data = model.createData()
    zero = np.zeros(2)
    tau = np.array([pin.rnea(model, data, np.r_[q[k], tail], np.r_[qd[k], zero],
                             np.r_[qdd[k], zero])[:7] for k in range(len(t))])
    return tau + ARMATURE * qdd + FV * qd + FS * np.sign(qd)


def record(duration_s: float, payload_kg: float, seed: int, current_noise_a: float,
           finger: float = FINGER, rate_hz: float = 1000.0, noise_seed: int = 0) -> Record:
    """A record of the 7 arm joints (module docstring); ``seed`` draws the trajectory,
    ``noise_seed`` the current noise."""
    model, tail = full_model(payload_kg, finger)
    T = 1.0 / rate_hz
    n = int(round(duration_s * rate_hz))
    t = np.arange(n) * T
    xg, wg = np.polynomial.legendre.leggauss(4)
    tau = sum(0.5 * w * torques(model, tail, t + (0.5 + 0.5 * x) * T, seed)
              for x, w in zip(xg, wg))
    q = trajectory(t, seed)[0]
    rng = np.random.default_rng([1000 + seed, noise_seed])
    v = tau / TRUE_GAINS + current_noise_a * rng.standard_normal(tau.shape)
    stamps = 1_700_000_000_000_000_000 + (np.arange(n) * round(T * 1e9)).astype(np.int64)
    cond = "loaded" if payload_kg else "unloaded"
    payload = Payload(payload_kg, PAYLOAD_FRAME, PAYLOAD_COM, PAYLOAD_INERTIA) if payload_kg \
        else None
    return Record.from_arrays(f"panda-{cond}-{seed}", stamps, q, v, cond, payload_kg, ARM,
                              payload)


def records(duration_s: float = 20.0, current_noise_a: float = 0.002,
            finger: float = FINGER, noise_seed: int = 0) -> list[Record]:
    """An unloaded and a loaded record (different trajectories)."""
    return [record(duration_s, 0.0, 1, current_noise_a, finger, noise_seed=noise_seed),
            record(duration_s, PAYLOAD_KG, 2, current_noise_a, finger, noise_seed=noise_seed)]
