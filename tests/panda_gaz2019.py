"""A real robot's record against its published model: the Franka Emika Panda of Gaz et al. 2019.

The fixture (tests/fixtures/panda_gaz2019, README.md there: source, licence, how it was cut) is
the published exciting-trajectory log, every 10th sample, split into an identification part
(traj1_a, 0-14 s) and a held-out part (traj1_b, 14-21 s). ``run`` imports both with
``orthoglide-ident import`` and identifies the first with ``orthoglide-ident identify --method
wls`` (gains 1: the effort is the torque sensors' N·m); ``held_out_rms`` then predicts the
held-out torques with the identified base parameters and with the published model (its feasible
parameters in panda_gaz2019.urdf through Pinocchio's RNEA, plus its sigmoid friction), both from
the same states, and gives each one's residual rms per joint.

    python bench/panda_gaz2019.py      # prints the figures of the README section
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

FIXTURE = Path(__file__).parent / "fixtures" / "panda_gaz2019"
URDF = FIXTURE / "panda_gaz2019.urdf"
JOINTS = tuple(f"panda_joint{i}" for i in range(1, 8))
G0 = 9.80665  # m/s², get_GravityVector.m's g0
# get_FrictionTorque.m: tau_f = A / (1 + exp(-alpha (qd + s))) - A / (1 + exp(-alpha s))
FRICTION_A = np.array([0.54615, 0.87224, 0.64068, 1.2794, 0.83904, 0.30301, 0.56489])
FRICTION_S = np.array([0.039533, 0.025882, -0.04607, 0.036194, 0.026226, -0.021047, 0.0035526])
FRICTION_ALPHA = np.array([5.1181, 9.0657, 10.136, 5.5903, 8.3469, 17.133, 10.336])
EVAL_CUTOFF_HZ = 5.0  # low-pass of the evaluation states and torques (dynamics below 0.4 Hz)
EDGE = 50  # samples left out at both ends of the held-out part (the filter's transients)


def published_friction(qd: np.ndarray) -> np.ndarray:
    """Gaz et al.'s friction torque (N·m) at joint velocities ``qd`` (N, 7)."""
    a, s, al = FRICTION_A, FRICTION_S, FRICTION_ALPHA
    return a / (1 + np.exp(-al * (qd + s))) - a / (1 + np.exp(-al * s))


def published_standard(robot) -> np.ndarray:
    """The published model as this product's standard parameters: the URDF's inertials, no
    rotor inertia or viscous friction, and the sigmoid's limit away from zero velocity
    (Coulomb A/2, offset A (1/2 - 1/(1 + exp(-alpha s))))."""
    chi = robot.standard_values()
    offset = FRICTION_A * (0.5 - 1 / (1 + np.exp(-FRICTION_ALPHA * FRICTION_S)))
    for k, name in enumerate(robot.standard_names):
        kind, _, body = name.partition("_")
        if kind in ("fs", "tauoff", "fv", "ia"):
            j = int(body) - 1
            chi[k] = {"fs": FRICTION_A[j] / 2, "tauoff": offset[j], "fv": 0.0, "ia": 0.0}[kind]
    return chi


@dataclass
class States:
    """Held-out states, low-passed alike: q, q̇ (the recorded velocity), q̈ (its derivative) and
    the measured torque, (N, 7) each."""

    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    tau: np.ndarray


def states(csv: Path) -> States:
    """The CSV's samples, low-passed at EVAL_CUTOFF_HZ (zero phase); q̈ by central differences
    at the median step: the time column is the logging PC's clock (steps 0.7-8.8 ms around the
    robot's 1 ms), and derivatives over those stamps were 5-10x worse for both models."""
    from scipy.signal import butter, filtfilt

    d = np.loadtxt(csv, delimiter=",", skiprows=1)
    t, q, qd, tau = d[:, 0], d[:, 1:8], d[:, 8:15], d[:, 15:22]
    step = float(np.median(np.diff(t)))
    b, a = butter(4, EVAL_CUTOFF_HZ * 2 * step)
    lp = lambda x: filtfilt(b, a, x, axis=0)  # noqa: E731
    return States(lp(q), lp(qd), np.gradient(lp(qd), step, axis=0), lp(tau))


def published_torque(s: States) -> np.ndarray:
    import pinocchio as pin

    model = pin.buildModelFromUrdf(str(URDF))
    model.gravity.linear[:] = [0.0, 0.0, -G0]
    data = model.createData()
    rnea = np.array([pin.rnea(model, data, *x) for x in zip(s.q, s.qd, s.qdd)])
    return rnea + published_friction(s.qd)


def identified_torque(robot, chi: np.ndarray, s: States) -> np.ndarray:
    return (robot.regressor(s.q, s.qd, s.qdd) @ chi).reshape(robot.n_joints, -1).T


def held_out_rms(robot, chi: np.ndarray) -> dict[str, np.ndarray]:
    """Residual rms per joint (N·m) on the held-out part: measured (the torque itself),
    published, identified."""
    s = states(FIXTURE / "traj1_b.csv.gz")
    keep = slice(EDGE, -EDGE)
    rms = lambda e: np.sqrt(np.mean(e[keep] ** 2, axis=0))  # noqa: E731
    return {"measured": rms(s.tau), "published": rms(s.tau - published_torque(s)),
            "identified": rms(s.tau - identified_torque(robot, chi, s))}


def run(work: Path, main) -> dict:
    """Import both parts and identify the first (``main``: the CLI's entry point); returns the
    ``identify --json`` document. AssertionError with the CLI's message if a step fails."""
    a, b, out = work / "traj1_a", work / "traj1_b", work / "result.json"
    for part, bag in (("traj1_a", a), ("traj1_b", b)):
        code = main(["import", str(FIXTURE / f"{part}.csv.gz"), "--map",
                     str(FIXTURE / "map.yaml"), "--out", str(bag)])
        assert code == 0, f"import {part} exited {code}"
    code = main(["identify", "--robot", str(URDF), "--method", "wls", str(a),  # default options
                 "--validate", str(b), "--json",
                 str(out), "-q"])
    assert code == 0, f"identify exited {code}"
    return json.loads(out.read_text())
