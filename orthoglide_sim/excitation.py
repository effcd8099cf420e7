"""Exciting trajectories (paper Sect. 3.2, refs [24, 25]; Fig. 4), and the safe workspace box.

Parametrisation: trajectories.FourierTrajectory (K harmonics of w_f per actuator, centred on the
safe box). Constraints are met by construction: every candidate is scaled so that its largest
excursion, speed or acceleration sits exactly on the limit (all three are linear in a common
amplitude factor), so the optimiser works on the shape only.

Criteria, on the base observation matrix W (3N, n_b) of the identification model sampled over
one period (``orthoglide_ident.model.base``: trajectories are designed for it):

- ``gains`` (default): the unloaded and the loaded trajectory are designed together for what
  IDIM-TLS is asked for, the drive gains. :func:`predicted_gain_std` is the σ of the gains that
  the linearised eqs. (35)-(36) give from the two records under white current noise; the
  condition number of each W is only kept below ``COND_SOFT``. The pair designed this way
  (exciting1, exciting2 since 2026-12) predicts 0.10/0.11/0.07 % for 30 s each at 1 mA, against
  0.16/0.21/0.08 % for the former pair designed for cond(W) alone; on the simulator the worst
  gain error over 5 seeds fell from 0.30 to 0.19 % (nominal, 60 s) and from 0.70 to 0.40 %
  (realistic, 30 s), see bench/identify_accuracy.py.
- ``cond``: cond(W) of one trajectory, the paper's criterion (each trajectory on its own).

``python -m orthoglide_sim.excitation`` re-optimises and writes orthoglide_sim/data/exciting*.json.
The search (random restarts, then L-BFGS-B on a non-smooth cost: the scaling to the limits and the
cond(W) penalty have kinks) is not repeatable across machines or settings: a run with
``--gains 2170,2100,2070 --samples 500`` on 2026-12-02 stopped after 10 iterations at
0.135/0.161/0.084 % (cond 6.4·10⁴). Compare a new pair with :func:`predicted_gain_std` before
replacing the committed one.
"""
from __future__ import annotations

import argparse
import json
import sys
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Callable

import numpy as np
from scipy.optimize import minimize

from orthoglide_ident.errors import WorkspaceError
from orthoglide_sim import kinematics as kin
from orthoglide_sim.trajectories import A_MAX, DATA_DIR, Q_CENTER, Q_HALF, V_MAX, FourierTrajectory

POSITION_LIMIT = 0.95 * Q_HALF  # m, excursion from the centre, a little inside the safe box
COND_SOFT = 3.0e4  # cond(W) above which the gains criterion is penalised (warning at 1e5)
DESIGN_PAYLOAD_KG = 1.983  # the weighed payload of the loaded record (Sect. 5.2)
DESIGN_NOISE_A = 1.0e-3  # A, white current noise per 1 kHz sample: sets the scale of the σ
DESIGN_SECONDS = 30.0  # s of each record: sets the scale of the σ


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


def _shape_maker(K: int, w_f: float) -> Callable[[np.ndarray], FourierTrajectory]:
    """x (6K: a then b, actuator by actuator) -> the trajectory of that shape, scaled to the limits."""
    def make(x: np.ndarray) -> FourierTrajectory:
        a, b = x.reshape(2, 3, K)
        return scaled(FourierTrajectory(np.full(3, Q_CENTER), a, b, w_f))
    return make


def criterion(traj: FourierTrajectory, regressor, n: int = 250) -> float:
    t = np.linspace(0.0, traj.period, n, endpoint=False)
    W = regressor(*traj.evaluate(t))
    s = np.linalg.svd(W, compute_uv=False)
    return float(s[0] / s[-1])


@dataclass(frozen=True)
class Design:
    """What the gains criterion needs of the model: its regressor and payload column, and a
    priori values (a CAD model's: here the simulator's table, which enters only through the
    size of the currents) of the base parameters and the gains."""

    regressor: Callable
    payload_column: Callable
    chi: np.ndarray  # (n_b,) a priori base parameters
    g_tau: np.ndarray  # (3,) N/A a priori gains

    @classmethod
    def default(cls) -> "Design":
        from orthoglide_ident.model.base import base_model
        from orthoglide_ident.model.geometry import G_TAU_MANUFACTURER
        from orthoglide_sim.true_parameters import load_parameters

        model = base_model()
        chi = model.base_values(load_parameters().standard_vector())
        return cls(model.regressor, model.payload_mass_column, chi, np.full(3, G_TAU_MANUFACTURER))


def _tls_rows(design: Design, traj: FourierTrajectory, mass: float, n: int) -> np.ndarray:
    """[W, -V] over one period, V (3N, 3) the currents of joint j in column j (eq. 35's W_tot
    without its right-hand side), each row weighted for the record's samples it stands for."""
    t = np.linspace(0.0, traj.period, n, endpoint=False)
    q, qd, qdd = traj.evaluate(t)
    W = design.regressor(q, qd, qdd)
    v = (W @ design.chi + mass * design.payload_column(q, qd, qdd)).reshape(3, n) / design.g_tau[:, None]
    V = np.zeros((3 * n, 3))
    for j in range(3):
        V[j * n:(j + 1) * n, j] = v[j]
    samples_per_row = DESIGN_SECONDS * 1000.0 / n  # 1 kHz samples of the whole record per row
    return np.hstack([W, -V]) * np.sqrt(samples_per_row)


def predicted_gain_std(unloaded: FourierTrajectory, loaded: FourierTrajectory,
                       design: Design | None = None, n: int = 240) -> np.ndarray:
    """Relative σ (%) of the three gains from a DESIGN_SECONDS unloaded and a loaded record.

    Eqs. (35)-(36) linearised: unknowns [χ, g_τ] of W χ - V g_τ = -W_kl m (m known on the loaded
    record), white current noise DESIGN_NOISE_A on every 1 kHz sample; cov = (g σ_i)² (AᵀA)⁻¹.
    """
    design = design or Design.default()
    A = np.vstack([_tls_rows(design, unloaded, 0.0, n), _tls_rows(design, loaded, DESIGN_PAYLOAD_KG, n)])
    cov_g = np.diag(np.linalg.inv(A.T @ A))[-3:]
    return 100.0 * DESIGN_NOISE_A * np.sqrt(cov_g)


def optimise_pair(K: int = 6, period: float = 1.5, seed: int = 0, restarts: int = 20,
                  maxiter: int = 60, verbose: bool = True, design: Design | None = None,
                  n: int = 240) -> tuple[FourierTrajectory, FourierTrajectory, np.ndarray]:
    """Unloaded and loaded trajectories designed together for the gains' σ (criterion ``gains``):
    rms of :func:`predicted_gain_std` (``n`` samples per period), cond(W) of each kept below
    COND_SOFT."""
    design = design or Design.default()
    w_f = 2.0 * np.pi / period
    rng = np.random.default_rng(seed)
    make = _shape_maker(K, w_f)

    def f(x):
        tu, tl = make(x[:6 * K]), make(x[6 * K:])
        s = predicted_gain_std(tu, tl, design, n)
        c = max(criterion(tu, design.regressor), criterion(tl, design.regressor))
        return np.log(np.sqrt(np.mean(s**2))) + 0.5 * max(0.0, np.log(c / COND_SOFT))

    best_x = min((rng.normal(size=12 * K) for _ in range(restarts)), key=f)
    if verbose:
        print(f"random restarts: best rms gain σ {np.exp(f(best_x)):.3f} %")
    res = minimize(f, best_x, method="L-BFGS-B", options={"maxiter": maxiter, "eps": 1e-4})
    tu, tl = make(res.x[:6 * K]), make(res.x[6 * K:])
    s = predicted_gain_std(tu, tl, design, n)
    if verbose:
        print(f"optimised: gain σ {np.round(s, 3)} % ({res.nit} iterations)")
    return tu, tl, s


def optimise(K: int = 5, period: float = 2.0, seed: int = 0, restarts: int = 12, maxiter: int = 30,
             verbose: bool = True) -> tuple[FourierTrajectory, float]:
    """Best exciting trajectory found: random restarts, then a local search on the best (L-BFGS-B)."""
    regressor = _base_regressor()
    w_f = 2.0 * np.pi / period
    rng = np.random.default_rng(seed)
    make = _shape_maker(K, w_f)

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


def _write(path: Path, traj: FourierTrajectory, **figures) -> None:
    v, a = platform_peaks(traj)
    path.write_text(json.dumps(traj.to_dict() | figures | {"platform_peak_speed": v,
                                                          "platform_peak_acceleration": a}, indent=1))
    print(f"{path}: cond {figures['condition_number']:.1f}, platform peak speed {v:.2f} m/s, "
          f"acceleration {a:.1f} m/s²")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m orthoglide_sim.excitation", description=__doc__.splitlines()[0])
    ap.add_argument("--criterion", choices=["gains", "cond"], default="gains",
                    help="gains: the pair designed together for the gains' σ (default); "
                         "cond: each trajectory for cond(W) alone")
    ap.add_argument("--harmonics", type=int, default=6)
    ap.add_argument("--period", type=float, default=1.5, help="s")
    ap.add_argument("--restarts", type=int, default=20)
    ap.add_argument("--maxiter", type=int, default=60)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--gains", default=None, metavar="G1,G2,G3",
                    help="a priori drive gains N/A for the gains criterion (default: the "
                         "manufacturer's 637π; the committed pair used 2170,2100,2070)")
    ap.add_argument("--samples", type=int, default=240,
                    help="samples per period for the gains criterion (the committed pair: 500)")
    ap.add_argument("--out-dir", type=Path, default=DATA_DIR)
    args = ap.parse_args(argv)
    print("workspace:", workspace_report())
    if args.criterion == "gains":
        design = Design.default()
        if args.gains:
            design = replace(design, g_tau=np.array([float(g) for g in args.gains.split(",")]))
        pair = optimise_pair(args.harmonics, args.period, args.seed, args.restarts, args.maxiter,
                             design=design, n=args.samples)
        for k, traj in enumerate(pair[:2], 1):
            _write(args.out_dir / f"exciting{k}.json", traj, criterion="gains",
                   condition_number=criterion(traj, design.regressor),
                   predicted_gain_std_pct=pair[2].tolist())
        return 0
    for k, seed in ((1, args.seed), (2, args.seed + 1)):
        traj, c = optimise(args.harmonics, args.period, seed, args.restarts, args.maxiter)
        _write(args.out_dir / f"exciting{k}.json", traj, criterion="cond", condition_number=c)
    return 0


if __name__ == "__main__":
    sys.exit(main())
