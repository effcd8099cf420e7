"""Exciting trajectories for a serial arm (paper Sect. 3.2, refs [24, 25]): a finite Fourier
series per joint (trajectories.FourierTrajectory, any number of joints), periodic, optimised for
the condition number of the observation matrix W over one period.

Constraints are met by construction: each joint's series is scaled so that its largest
excursion from the box centre, speed or acceleration sits exactly on that joint's limit
(arm_limits.MotionLimits; all three are linear in the joint's amplitude), so the optimiser
works on the shapes only. The period (PERIOD = 5 s) repeats 12 times in a 60 s record: the
identification's current-loop-lag instrument needs a trajectory repeating at least 4 times.

The optimiser takes any regressor ``regressor(q, qd, qdd) -> W (n m, p)`` (rows joint by joint,
independent columns): for a serial arm ``pinocchio_arm.ArmRegressor.base`` (the URDF's
joint-torque regressor with drive columns), for a closed chain the product's general model
(``load_robot(name).regressor``: its base columns, the rows of the actuated joints through the
loops), whose box (arm_limits) keeps the loops closed away from singularities.

The design command, for a serial arm or a closed chain (arm_or_chain/excitation.py):

    python -m orthoglide_sim.arm_or_chain.excitation --robot ur5   # data/ur5_exciting{1,2}.json

The search (best of ``--restarts`` random shapes, then a seeded (1+1) evolution strategy on
log cond(W)) is repeatable on one machine for a given ``--seed``.
"""
from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

from orthoglide_ident.errors import ConfigError
from orthoglide_sim.arms.description import ArmDescription
from orthoglide_sim.arms.limits import MotionLimits
from orthoglide_sim.common.trajectories import DATA_DIR, FourierTrajectory, load_fourier

Regressor = Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]
PERIOD = 5.0  # s
HARMONICS = 5
SAMPLES = 200  # per period, for cond(W)


def scaled(traj: FourierTrajectory, limits: MotionLimits, n: int = 2000) -> FourierTrajectory:
    """``traj`` with each joint re-centred on the box and scaled until its excursion, speed or
    acceleration reaches that joint's limit (checked on ``n`` samples per period)."""
    t = np.linspace(0.0, traj.period, n, endpoint=False)
    q, qd, qdd = traj.evaluate(t)
    dq = q - traj.q0
    mid, span = 0.5 * (dq.max(0) + dq.min(0)), 0.5 * (dq.max(0) - dq.min(0))
    s = np.min([limits.half / span, limits.velocity / np.abs(qd).max(0),
                limits.acceleration / np.abs(qdd).max(0)], axis=0)
    return FourierTrajectory(
        limits.centre - s * mid, traj.a * s[:, None], traj.b * s[:, None], traj.w_f
    )


def shape_maker(
    limits: MotionLimits, K: int, period: float
) -> Callable[[np.ndarray], FourierTrajectory]:
    """x (2 n K: a then b, joint by joint) -> that shape scaled to the limits."""
    n, w_f = len(limits.centre), 2.0 * np.pi / period

    def make(x: np.ndarray) -> FourierTrajectory:
        a, b = np.asarray(x, float).reshape(2, n, K)
        return scaled(FourierTrajectory(limits.centre.copy(), a, b, w_f), limits)
    return make


def condition_number(traj: FourierTrajectory, regressor: Regressor, n: int = SAMPLES) -> float:
    """cond(W) of ``regressor`` sampled at n instants over one period (the paper's criterion)."""
    t = np.linspace(0.0, traj.period, n, endpoint=False)
    s = np.linalg.svd(regressor(*traj.evaluate(t)), compute_uv=False)
    return float(s[0] / s[-1]) if s[-1] > 0 else float("inf")


def random_trajectory(limits: MotionLimits, seed: int, K: int = HARMONICS,
                      period: float = PERIOD) -> FourierTrajectory:
    """A random Fourier shape scaled to the limits: what the optimiser starts from."""
    n = len(limits.centre)
    return shape_maker(limits, K, period)(np.random.default_rng(seed).normal(size=2 * n * K))


def optimise(regressor: Regressor, limits: MotionLimits, K: int = HARMONICS, period: float = PERIOD,
             seed: int = 0, restarts: int = 20, steps: int = 600,
             verbose: bool = False) -> tuple[FourierTrajectory, float]:
    """The trajectory of least cond(W) found: the best of ``restarts`` random shapes, then
    ``steps`` of a (1+1) evolution strategy (a Gaussian step kept if it lowers log cond; step
    size ×1.5 on success, ×0.9 on failure), which copes with the kinks of the scaling."""
    make = shape_maker(limits, K, period)
    rng = np.random.default_rng(seed)
    n = len(limits.centre)

    def f(x: np.ndarray) -> float:
        return float(np.log(condition_number(make(x), regressor)))

    x = min((rng.normal(size=2 * n * K) for _ in range(restarts)), key=f)
    fx, step = f(x), 0.05
    if verbose:
        print(f"best of {restarts} random shapes: cond {np.exp(fx):.1f}", flush=True)
    for k in range(steps):
        y = x + step * np.abs(x).mean() * rng.normal(size=x.size)
        fy = f(y)
        x, fx, step = (y, fy, step * 1.5) if fy < fx else (x, fx, step * 0.9)
        if verbose and (k + 1) % 100 == 0:
            print(f"  step {k + 1}/{steps}: cond {np.exp(fx):.1f}", flush=True)
    return make(x), float(np.exp(fx))


def design_path(robot: str, k: int, data_dir: Path = DATA_DIR) -> Path:
    return data_dir / f"{robot}_exciting{k}.json"


def designed_trajectory(arm: ArmDescription, name: str) -> FourierTrajectory:
    """``exciting1``/``exciting2`` (data/<robot>_exciting<k>.json) or a .json path, checked to
    have one series per joint of ``arm``."""
    path = Path(name) if name.endswith(".json") else DATA_DIR / f"{arm.name}_{name}.json"
    if not path.exists():
        raise ConfigError(
            f"no trajectory {name!r} for robot {arm.name} ({path} missing): design one with "
            f"python -m orthoglide_sim.arm_or_chain.excitation --robot {arm.name}"
        )
    traj = load_fourier(path)
    if traj.a.shape[0] != arm.n:
        raise ConfigError(
            f"trajectory {path} has {traj.a.shape[0]} joints, robot {arm.name} has {arm.n}"
        )
    return traj
