"""Exciting trajectories optimised for the condition number of the base observation matrix
(paper Sect. 3.2, refs [24, 25]; Fig. 4), and the safe workspace box.

Parametrisation: trajectories.FourierTrajectory (K harmonics of w_f per actuator, centred on the
safe box). Constraints are met by construction: every candidate is scaled so that its largest
excursion, speed or acceleration sits exactly on the limit (all three are linear in a common
amplitude factor), so the optimiser works on the shape only. Criterion: cond(W) of the base
observation matrix W (3N, n_b) sampled over one period (``orthoglide_ident.model.base``, or the
the identification model's regressor: trajectories are designed for it).

``python -m orthoglide_sim.excitation`` re-optimises and writes orthoglide_sim/data/exciting*.json.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
from scipy.optimize import minimize

from orthoglide_ident.errors import WorkspaceError
from orthoglide_sim import kinematics as kin
from orthoglide_sim.trajectories import A_MAX, DATA_DIR, Q_CENTER, Q_HALF, V_MAX, FourierTrajectory

POSITION_LIMIT = 0.95 * Q_HALF  # m, excursion from the centre, a little inside the safe box


def _base_regressor():
    from orthoglide_ident.model.base import base_model

    return base_model().regressor


def scaled(traj: FourierTrajectory, n: int = 400) -> FourierTrajectory:
    """traj scaled so that max excursion, speed and acceleration reach exactly one of the limits."""
    t = np.linspace(0.0, traj.period, n, endpoint=False)
    q, qd, qdd = traj.evaluate(t)
    dq = q - traj.q0
    mid = 0.5 * (dq.max(0) + dq.min(0))  # re-centre the excursion on the box centre
    span = 0.5 * (dq.max(0) - dq.min(0))
    s = min(POSITION_LIMIT / span.max(), V_MAX / np.abs(qd).max(), A_MAX / np.abs(qdd).max())
    return FourierTrajectory(Q_CENTER - s * mid, traj.a * s, traj.b * s, traj.w_f)


def criterion(traj: FourierTrajectory, regressor, n: int = 250) -> float:
    t = np.linspace(0.0, traj.period, n, endpoint=False)
    W = regressor(*traj.evaluate(t))
    s = np.linalg.svd(W, compute_uv=False)
    return float(s[0] / s[-1])


def optimise(K: int = 5, period: float = 2.0, seed: int = 0, restarts: int = 12, maxiter: int = 30,
             verbose: bool = True) -> tuple[FourierTrajectory, float]:
    """Best exciting trajectory found: random restarts, then a local search on the best (L-BFGS-B)."""
    regressor = _base_regressor()
    w_f = 2.0 * np.pi / period
    rng = np.random.default_rng(seed)

    def make(x):
        a, b = x.reshape(2, 3, K)
        return scaled(FourierTrajectory(np.full(3, Q_CENTER), a, b, w_f))

    def f(x):
        return np.log(criterion(make(x), regressor))

    best_x, best_f = None, np.inf
    for _ in range(restarts):
        x = rng.normal(size=6 * K)
        fx = f(x)
        if fx < best_f:
            best_x, best_f = x, fx
    if verbose:
        print(f"random restarts: best cond {np.exp(best_f):.1f}")
    res = minimize(f, best_x, method="L-BFGS-B", options={"maxiter": maxiter, "eps": 1e-4})
    traj = make(res.x)
    c = criterion(traj, regressor)
    if verbose:
        print(f"optimised: cond {c:.1f} ({res.nit} iterations)")
    return traj, c


def platform_peaks(traj, duration: float | None = None, n: int = 4000) -> tuple[float, float]:
    """Peak platform speed (m/s) and acceleration (m/s²) along a trajectory: dP/dt = J_p qd in
    closed form, d²P/dt² by central differences of it over the dense time grid."""
    t = np.linspace(0.0, duration or traj.period, n, endpoint=False)
    q, qd, _ = traj.evaluate(t)
    v = kin.platform_velocity(q, qd)
    a = np.gradient(v, t, axis=0)
    return float(np.linalg.norm(v, axis=1).max()), float(np.linalg.norm(a, axis=1).max())


def workspace_report(lo: float = Q_CENTER - Q_HALF, hi: float = Q_CENTER + Q_HALF, n: int = 11) -> dict:
    """Worst singularity margins over a grid of the actuator box [lo, hi]^3."""
    g = np.linspace(lo, hi, n)
    Q = np.array(np.meshgrid(g, g, g)).reshape(3, -1).T
    try:
        serial, parallel, inv_cond = kin.singularity_margins(Q)
    except WorkspaceError:
        return {"box": (lo, hi), "assembled_everywhere": False}
    return {"box": (lo, hi), "assembled_everywhere": True,
            "min_bar_axis_cosine": float(serial.min()), "min_det_u": float(parallel.min()),
            "max_cond_Jp": float(np.max(1.0 / inv_cond))}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m orthoglide_sim.excitation", description=__doc__.splitlines()[0])
    ap.add_argument("--harmonics", type=int, default=5)
    ap.add_argument("--period", type=float, default=2.0, help="s")
    ap.add_argument("--restarts", type=int, default=12)
    ap.add_argument("--maxiter", type=int, default=30)
    ap.add_argument("--out-dir", type=Path, default=DATA_DIR)
    args = ap.parse_args(argv)
    print("workspace:", workspace_report())
    for k, seed in ((1, 0), (2, 1)):
        traj, c = optimise(args.harmonics, args.period, seed, args.restarts, args.maxiter)
        v, a = platform_peaks(traj)
        d = traj.to_dict() | {"condition_number": c, "platform_peak_speed": v, "platform_peak_acceleration": a}
        path = args.out_dir / f"exciting{k}.json"
        path.write_text(json.dumps(d, indent=1))
        print(f"{path}: cond {c:.1f}, platform peak speed {v:.2f} m/s, acceleration {a:.1f} m/s²")
    return 0


if __name__ == "__main__":
    sys.exit(main())
