"""A 7-axis arm's records from an independent model: the example-robot-data Panda, fingers fixed.

Issue 43's shape for small distal gains under current noise: the Panda's URDF
(tests/fixtures/panda_erd, its inertials as published by example-robot-data), 7 revolute joints,
each with a rotor inertia ia, viscous fv and Coulomb fs friction (turning smoothly through zero
velocity within FS_SMOOTH_RADPS) and an offset; drive gains a few N·m/A, the distal ones (5-7)
small. The torque is Pinocchio's own RNEA (not the product's regressor) plus those drive terms;
the controller holds each current over its 1 ms tick, so the recorded current is the torque at
the middle of the tick divided by the gain (the mean over the tick to ~1e-6). White current noise
of ``noise`` times each joint's rms current (0.005-0.05: "0.5-5 % current noise"). The loaded
record carries a 1 kg payload whose CoM is off the flange axis, tagged with its mass only.

    un, lo = records(seconds=40, noise=0.01, seed=0)      # Record, Record (unloaded, loaded)
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from orthoglide_ident.identify import Record

URDF = Path(__file__).parent / "fixtures" / "panda_erd" / "panda_fingers_fixed.urdf"
JOINTS = tuple(f"panda_joint{i}" for i in range(1, 8))
GAINS = np.array([9.2, 8.7, 9.5, 8.1, 1.9, 2.2, 1.6])  # N·m/A, the distal three small
IA = np.array([0.30, 0.28, 0.25, 0.22, 0.08, 0.07, 0.05])  # kg·m², rotor inertia at the joint
FV = np.array([0.9, 0.8, 0.7, 0.6, 0.25, 0.2, 0.15])  # N·m·s/rad
FS = np.array([0.6, 0.9, 0.6, 0.8, 0.35, 0.3, 0.25])  # N·m
OFFSET = np.array([0.05, -0.2, 0.1, -0.15, 0.04, -0.03, 0.02])  # N·m
FS_SMOOTH_RADPS = 0.002  # Coulomb friction's tanh width
PAYLOAD_KG = 1.0
PAYLOAD_COM = np.array([0.03, -0.02, 0.08])  # m in panda_link7 (unknown to the identification)
PAYLOAD_RADIUS = 0.04  # m: a solid sphere's inertia about its CoM
RATE_HZ = 1000.0
CENTRE = np.array([0.0, 0.0, 0.0, -1.6, 0.0, 1.8, 0.0])  # rad, mid-range of the joint limits
AMPLITUDE = np.array([1.4, 0.8, 1.4, 0.9, 1.6, 1.0, 1.6])  # rad, kept inside the limits
G0 = 9.80665  # m/s², the product's standard gravity (Pinocchio's default is 9.81)
T0_NS = 1_700_000_000_000_000_000


def pin_model(payload: bool):
    """Pinocchio's model of the URDF (fingers fixed), with the payload in panda_link7."""
    import pinocchio as pin

    model = pin.buildModelFromUrdf(str(URDF))
    model.gravity.linear[:] = [0.0, 0.0, -G0]
    if payload:
        inertia = pin.Inertia(PAYLOAD_KG, PAYLOAD_COM,
                              np.eye(3) * 0.4 * PAYLOAD_KG * PAYLOAD_RADIUS ** 2)
        jid = model.getJointId("panda_joint7")
        frame = model.frames[model.getFrameId("panda_link7")]
        model.appendBodyToJoint(jid, inertia, frame.placement)
    return model


def trajectory(t: np.ndarray, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """q, q̇, q̈ (N, 7): per joint a sum of 5 sines, 0.04-0.25 Hz, within AMPLITUDE of CENTRE."""
    rng = np.random.default_rng(seed)
    t = np.asarray(t, float)[:, None]
    q, qd, qdd = (np.tile(CENTRE, (t.shape[0], 1)), np.zeros((t.shape[0], 7)),
                  np.zeros((t.shape[0], 7)))
    for _ in range(5):
        w = 2 * np.pi * rng.uniform(0.04, 0.25, 7)
        a = rng.uniform(0.5, 1.0, 7) * AMPLITUDE / 5
        ph = rng.uniform(0, 2 * np.pi, 7)
        q = q + a * np.sin(w * t + ph)
        qd = qd + a * w * np.cos(w * t + ph)
        qdd = qdd - a * w * w * np.sin(w * t + ph)
    return q, qd, qdd


def torques(q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, payload: bool) -> np.ndarray:
    """Joint torques (N, 7), N·m: Pinocchio's RNEA plus the drive terms above."""
    import pinocchio as pin

    model = pin_model(payload)
    data = model.createData()
    tau = np.array([pin.rnea(model, data, a, b, c).copy() for a, b, c in zip(q, qd, qdd)])
    return tau + IA * qdd + FV * qd + FS * np.tanh(qd / FS_SMOOTH_RADPS) + OFFSET


def record(seconds: float, payload: bool, noise: float, seed: int) -> Record:
    """One record at RATE_HZ: positions at the ticks, currents held over each tick, noisy."""
    n = int(round(seconds * RATE_HZ))
    t = np.arange(n) / RATE_HZ
    q_mid, qd_mid, qdd_mid = trajectory(t + 0.5 / RATE_HZ, seed)  # mid-tick: the hold's mean
    v = torques(q_mid, qd_mid, qdd_mid, payload) / GAINS
    rng = np.random.default_rng(1000 + seed)
    v = v + noise * np.sqrt(np.mean(v ** 2, axis=0)) * rng.standard_normal(v.shape)
    q = trajectory(t, seed)[0]
    stamps = T0_NS + np.arange(n, dtype=np.int64) * int(round(1e9 / RATE_HZ))
    cond = "loaded" if payload else "unloaded"
    return Record.from_arrays(f"panda-{cond}-{seed}", stamps, q, v, cond,
                              PAYLOAD_KG if payload else 0.0, JOINTS)


def records(seconds: float = 40.0, noise: float = 0.01, seed: int = 0) -> list[Record]:
    """An unloaded and a loaded record (different trajectories), ``seconds`` each."""
    return [record(seconds, False, noise, 2 * seed), record(seconds, True, noise, 2 * seed + 1)]
