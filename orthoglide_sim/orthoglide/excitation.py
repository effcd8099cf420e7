"""Exciting trajectories (paper Sect. 3.2, refs [24, 25]; Fig. 4), and the safe workspace box.

Parametrisation: trajectories.FourierTrajectory (K harmonics of w_f per actuator, centred on the
safe box). Constraints are met by construction: every candidate is scaled so that its largest
excursion, speed or acceleration sits exactly on the limit (all three are linear in a common
amplitude factor), so the optimiser works on the shape only.

Criteria, on the base observation matrix W (3N, n_b) of the identification model sampled over
one period (``orthoglide_ident.model.orthoglide.base``: trajectories are designed for it):

- ``gains`` (default): the unloaded and the loaded trajectory are designed together for what
  IDIM-TLS is asked for, the drive gains, on a real drive. :func:`predicted_gain_std` is the σ of
  the gains that the linearised eqs. (35)-(36) give from the two records under white current
  noise; :func:`predicted_delay_bias` the bias a current-loop lag the identification does not know
  (DESIGN_DELAY_S, 0.15 ms) puts on them through the currents' time derivative; the cost is the
  rms of √(σ² + bias²) over the three gains, with cond(W) of each trajectory kept below
  ``COND_SOFT``. The committed pair (exciting1, exciting2) predicts σ 0.113/0.124/0.076 % for
  30 s each at 1 mA and a 0.15 ms lag bias of +0.008/-0.015/-0.002 %; the pair before it
  (designed for the σ alone) 0.105/0.112/0.075 % and -0.25/+0.23/-0.06 %, the pair designed
  for cond(W) alone 0.161/0.213/0.079 % and +0.08/+0.06/-0.15 %. On the simulator
  (bench/identify_accuracy.py, README) the lag's measured share of the bias fell less than
  predicted (q12 +0.28 -> +0.21 % for 0.12 ms, noise-free): under the PID the records track
  within ~1.8 mm rms, and the closed loop's own current transients carry the rest.
- ``cond``: cond(W) of one trajectory, the paper's criterion (each trajectory on its own).

``python -m orthoglide_sim.orthoglide.excitation`` re-optimises and writes
orthoglide_sim/data/exciting*.json.
The gains search (random restarts or ``--start``, then a seeded (1+1) evolution strategy) is
repeatable on one machine: the committed pair is ``--gains 2170,2100,2070 --seed 5 --start
exciting1,exciting2`` run on the pair before it (git show
6f6803d:orthoglide_sim/data/exciting1.json).
Compare a new pair with :func:`predicted_gain_std` and :func:`predicted_delay_bias` before
replacing the committed one.
"""
from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from scipy.optimize import minimize

from orthoglide_ident.errors import OrthoglideError, WorkspaceError
from orthoglide_ident.identify.options import IdentifyOptions
from orthoglide_sim.common.trajectories import (
    A_MAX,
    DATA_DIR,
    Q_CENTER,
    Q_HALF,
    V_MAX,
    FourierTrajectory,
    get_trajectory,
)
from orthoglide_sim.orthoglide import kinematics as kin

POSITION_LIMIT = 0.95 * Q_HALF  # m, excursion from the centre, a little inside the safe box
COND_SOFT = 3.0e4  # cond(W) above which the gains criterion is penalised (warning at 1e5)
DESIGN_PAYLOAD_KG = 1.983  # the weighed payload of the loaded record (Sect. 5.2)
DESIGN_NOISE_A = 1.0e-3  # A, white current noise per 1 kHz sample: sets the scale of the σ
DESIGN_SECONDS = 30.0  # s of each record: sets the scale of the σ
DESIGN_DELAY_S = 1.5e-4  # s, current-loop lag the gains criterion guards against (0.1-0.15 ms)


def _base_regressor():
    from orthoglide_ident.model.orthoglide.base import base_model

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
    """x (6K: a then b, actuator by actuator) -> the trajectory of that shape, scaled to the
    limits."""

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
    def default(cls) -> Design:
        from orthoglide_ident.model.orthoglide.base import base_model
        from orthoglide_ident.model.orthoglide.geometry import G_TAU_MANUFACTURER
        from orthoglide_sim.orthoglide.truth import load_parameters

        model = base_model()
        chi = model.base_values(load_parameters().standard_vector())
        return cls(model.regressor, model.payload_mass_column, chi, np.full(3, G_TAU_MANUFACTURER))


def _currents(design: Design, traj: FourierTrajectory, mass: float, t: np.ndarray) -> np.ndarray:
    """(3, n) A: the currents the a priori model predicts along ``traj`` at instants ``t``."""
    q, qd, qdd = traj.evaluate(t)
    f = design.regressor(q, qd, qdd) @ design.chi + mass * design.payload_column(q, qd, qdd)
    return f.reshape(3, t.shape[0]) / design.g_tau[:, None]


def _tls_rows(design: Design, traj: FourierTrajectory, mass: float, n: int) -> np.ndarray:
    """[W, -V] over one period, V (3N, 3) the currents of joint j in column j (eq. 35's W_tot
    without its right-hand side), each row weighted for the record's samples it stands for."""
    t = np.linspace(0.0, traj.period, n, endpoint=False)
    W = design.regressor(*traj.evaluate(t))
    v = _currents(design, traj, mass, t)
    V = np.zeros((3 * n, 3))
    for j in range(3):
        V[j * n:(j + 1) * n, j] = v[j]
    return np.hstack([W, -V]) * np.sqrt(_samples_per_row(n))


def _samples_per_row(n: int) -> float:
    return DESIGN_SECONDS * 1000.0 / n  # 1 kHz samples of the whole record per row


def _away_from_reversals(traj: FourierTrajectory, t: np.ndarray) -> np.ndarray:
    """(3, n) bool: joint j's samples that reversals.py does not bridge (|q̇_j| above the
    identification's dead band over ± its margin, checked at the samples' spacing)."""
    opts = IdentifyOptions()
    keep = np.ones((3, t.shape[0]), bool)
    m = opts.observe.reversal_margin_s
    for s in np.arange(-m, m + 1e-12, t[1] - t[0]):
        keep &= np.abs(traj.evaluate(t + s)[1].T) >= opts.observe.velocity_deadband_mps
    return keep


def predicted_delay_bias(unloaded: FourierTrajectory, loaded: FourierTrajectory,
                         design: Design | None = None, n: int = 600,
                         delay: float = DESIGN_DELAY_S) -> np.ndarray:
    """Relative bias (%) of the three gains when the recorded currents lead the force by
    ``delay`` s (a current loop's lag, which the IDIM lacks and the identification does not
    know): v_rec ≈ v + delay·v̇ moves eq. (35)'s solution by (AᵀA)⁻¹Aᵀ(delay V̇ g_τ), A the rows of
    :func:`predicted_gain_std` away from the velocity reversals (those are bridged).

    On perfectly tracked records put through the identification this predicts the measured
    effect of a 0.12 ms lead to within ~0.1 % of gain; the simulated closed loop adds its own
    share (bench/identify_accuracy.py, README)."""
    design = design or Design.default()
    blocks, rhs = [], []
    for traj, mass in ((unloaded, 0.0), (loaded, DESIGN_PAYLOAD_KG)):
        t = np.linspace(0.0, traj.period, n, endpoint=False)
        eps = 1e-5  # s, central difference of the currents (no reversal inside: masked)
        v_dot = (
            _currents(design, traj, mass, t + eps) - _currents(design, traj, mass, t - eps)
        ) / (2 * eps)
        keep = _away_from_reversals(traj, t).ravel()
        b = (delay * v_dot * design.g_tau[:, None]).ravel() * np.sqrt(_samples_per_row(n))
        blocks.append(_tls_rows(design, traj, mass, n)[keep])
        rhs.append(b[keep])
    x = np.linalg.lstsq(np.vstack(blocks), np.concatenate(rhs), rcond=None)[0]
    return 100.0 * x[-3:] / design.g_tau


def predicted_gain_std(unloaded: FourierTrajectory, loaded: FourierTrajectory,
                       design: Design | None = None, n: int = 240) -> np.ndarray:
    """Relative σ (%) of the three gains from a DESIGN_SECONDS unloaded and a loaded record.

    Eqs. (35)-(36) linearised: unknowns [χ, g_τ] of W χ - V g_τ = -W_kl m (m known on the loaded
    record), white current noise DESIGN_NOISE_A on every 1 kHz sample; cov = (g σ_i)² (AᵀA)⁻¹.
    """
    design = design or Design.default()
    A = np.vstack(
        [_tls_rows(design, unloaded, 0.0, n), _tls_rows(design, loaded, DESIGN_PAYLOAD_KG, n)]
    )
    cov_g = np.diag(np.linalg.inv(A.T @ A))[-3:]
    return 100.0 * DESIGN_NOISE_A * np.sqrt(cov_g)


def optimise_pair(K: int = 6, period: float = 1.5, seed: int = 0, restarts: int = 20,
                  maxiter: int = 450, verbose: bool = True, design: Design | None = None,
                  n: int = 240, start: tuple[FourierTrajectory, FourierTrajectory] | None = None
                  ) -> tuple[FourierTrajectory, FourierTrajectory, np.ndarray]:
    """Unloaded and loaded trajectories designed together for the gains (criterion ``gains``):
    the rms over the three gains of √(σ² + b²), σ of :func:`predicted_gain_std` (``n`` samples
    per period) and b of :func:`predicted_delay_bias` (a 0.15 ms current-loop lag), cond(W) of
    each kept below COND_SOFT. From ``start`` (a pair of the same K and period), or the best of
    ``restarts`` random shapes; then ``maxiter`` steps of :func:`_local_search`."""
    design = design or Design.default()
    make = _shape_maker(K, 2.0 * np.pi / period)
    rng = np.random.default_rng(seed)

    def f(x):
        tu, tl = make(x[:6 * K]), make(x[6 * K:])
        s = predicted_gain_std(tu, tl, design, n)
        b = predicted_delay_bias(tu, tl, design)
        c = max(criterion(tu, design.regressor), criterion(tl, design.regressor))
        return np.log(np.sqrt(np.mean(s**2 + b**2))) + 0.5 * max(0.0, np.log(c / COND_SOFT))

    if start is not None:
        x0 = np.concatenate([np.concatenate([t.a.ravel(), t.b.ravel()]) for t in start])
    else:
        x0 = min((rng.normal(size=12 * K) for _ in range(restarts)), key=f)
    if verbose:
        print(f"start: rms gain error {np.exp(f(x0)):.3f} %")
    x = _local_search(f, x0, maxiter, rng, verbose)
    tu, tl = make(x[:6 * K]), make(x[6 * K:])
    s = predicted_gain_std(tu, tl, design, n)
    if verbose:
        print(f"optimised: gain σ {np.round(s, 3)} %, delay bias "
              f"{np.round(predicted_delay_bias(tu, tl, design), 3)} % ({maxiter} steps)")
    return tu, tl, s


def _local_search(f: Callable[[np.ndarray], float], x: np.ndarray, steps: int,
                  rng: np.random.Generator, verbose: bool = False) -> np.ndarray:
    """(1+1) evolution strategy: a Gaussian step is kept if it lowers f; the step size grows
    ×1.5 on success and shrinks ×0.9 on failure. Chosen over L-BFGS-B, which stalls on this
    cost's kinks (the scaling to the limits, the cond penalty); repeatable for a given seed."""
    fx, step = f(x), 0.05
    for k in range(steps):
        if verbose and k % 50 == 0:
            print(f"  step {k}/{steps}: rms gain error {np.exp(fx):.4f} %", flush=True)
        y = x + step * np.abs(x).mean() * rng.normal(size=x.size)
        fy = f(y)
        if fy < fx:
            x, fx, step = y, fy, step * 1.5
        else:
            step *= 0.9
    return x


def optimise(K: int = 5, period: float = 2.0, seed: int = 0, restarts: int = 12, maxiter: int = 30,
             verbose: bool = True) -> tuple[FourierTrajectory, float]:
    """Best exciting trajectory found: random restarts, then a local search on the best
    (L-BFGS-B)."""
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


def workspace_report(
    lo: float = Q_CENTER - Q_HALF, hi: float = Q_CENTER + Q_HALF, n: int = 11
) -> dict:
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
    path.write_text(
        json.dumps(
            traj.to_dict() | figures | {"platform_peak_speed": v, "platform_peak_acceleration": a},
            indent=1,
        )
    )
    print(f"{path}: cond {figures['condition_number']:.1f}, platform peak speed {v:.2f} m/s, "
          f"acceleration {a:.1f} m/s²")


def _gains_inputs(args) -> tuple[Design, tuple[FourierTrajectory, FourierTrajectory] | None]:
    """The design (a priori gains from ``--gains``) and the ``--start`` pair, checked."""
    design = Design.default()
    if args.gains:
        g = np.array([float(x) for x in args.gains.split(",")])
        if g.shape != (3,) or not np.all(g > 0):
            raise ValueError(f"--gains needs 3 positive gains in N/A, got {args.gains!r}")
        design = replace(design, g_tau=g)
    if not args.start:
        return design, None
    start = tuple(get_trajectory(name) for name in args.start.split(","))
    w_f = 2.0 * np.pi / args.period
    if len(start) != 2 or any(
        not isinstance(t, FourierTrajectory)
        or t.a.shape != (3, args.harmonics)
        or not np.isclose(t.w_f, w_f)
        for t in start
    ):
        raise ValueError(f"--start needs two Fourier trajectories of {args.harmonics} harmonics "
                         f"and period {args.period} s (see --harmonics, --period)")
    return design, start


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m orthoglide_sim.orthoglide.excitation", description=__doc__.splitlines()[0]
    )
    ap.add_argument("--criterion", choices=["gains", "cond"], default="gains",
                    help="gains: the pair designed together for the gains' σ (default); "
                         "cond: each trajectory for cond(W) alone")
    ap.add_argument("--harmonics", type=int, default=6)
    ap.add_argument("--period", type=float, default=1.5, help="s")
    ap.add_argument("--restarts", type=int, default=20)
    ap.add_argument("--maxiter", type=int, default=None,
                    help="local search steps (gains, default 450) or L-BFGS-B iterations "
                         "(cond, default 30)")
    ap.add_argument("--start", default=None, metavar="U.json,L.json",
                    help="gains criterion: start from this pair instead of random shapes")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--gains", default=None, metavar="G1,G2,G3",
                    help="a priori drive gains N/A for the gains criterion (default: the "
                         "manufacturer's 637π; the committed pair used 2170,2100,2070)")
    ap.add_argument("--samples", type=int, default=240,
                    help="samples per period for the gains' σ (the committed pair: 240)")
    ap.add_argument("--out-dir", type=Path, default=DATA_DIR)
    args = ap.parse_args(argv)
    print("workspace:", workspace_report())
    if args.criterion == "gains":
        try:
            design, start = _gains_inputs(args)
        except (OrthoglideError, ValueError) as exc:
            print(f"error: {exc}", file=sys.stderr)
            return 2
        pair = optimise_pair(args.harmonics, args.period, args.seed, args.restarts,
                             args.maxiter or 450, design=design, n=args.samples, start=start)
        for k, traj in enumerate(pair[:2], 1):
            _write(args.out_dir / f"exciting{k}.json", traj, criterion="gains",
                   condition_number=criterion(traj, design.regressor),
                   predicted_gain_std_pct=pair[2].tolist(),
                   predicted_delay_bias_pct=predicted_delay_bias(*pair[:2], design).tolist())
        return 0
    for k, seed in ((1, args.seed), (2, args.seed + 1)):
        traj, c = optimise(args.harmonics, args.period, seed, args.restarts, args.maxiter or 30)
        _write(args.out_dir / f"exciting{k}.json", traj, criterion="cond", condition_number=c)
    return 0


if __name__ == "__main__":
    sys.exit(main())
