"""A serial arm's or closed chain's exciting trajectories in the simulator (paper Sect. 3.2,
refs [24, 25]): the stored designs (data/<robot>_exciting{1,2}.json, finite Fourier series per
joint, ``orthoglide_ident.excite.FourierSeries``), the random Fourier series they are compared
with, and cond(W) that compares them.

The stored UR5 and five-bar designs (period 5 s, 5 harmonics, 12 periods in a 60 s record: the
identification's current-loop-lag instrument needs at least 4) were optimised for cond(W) by an
optimiser of the simulator's own, since replaced by the product's designer: the design command
(arm_or_chain/excitation.py) runs ``orthoglide_ident.excite.design`` inside the arm's box
(arms/limits.py); the committed files stay as the records' data.

A random series (``random_trajectory``: the baseline a design must beat, and the big arm's
data-set motions, big_arm.py) has each joint re-centred on the box and scaled so that its
largest excursion, speed or acceleration sits exactly on that joint's limit (all three are
linear in the joint's amplitude).
"""
from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.excite import FourierSeries
from orthoglide_sim.arms.description import ArmDescription
from orthoglide_sim.arms.limits import MotionLimits
from orthoglide_sim.common.trajectories import DATA_DIR, load_fourier

Regressor = Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]
PERIOD = 5.0  # s
HARMONICS = 5
SAMPLES = 200  # per period, for cond(W)


def scaled(traj: FourierSeries, limits: MotionLimits, n: int = 2000) -> FourierSeries:
    """``traj`` with each joint re-centred on the box and scaled until its excursion, speed or
    acceleration reaches that joint's limit (checked on ``n`` samples per period)."""
    t = np.linspace(0.0, traj.period, n, endpoint=False)
    q, qd, qdd = traj.evaluate(t)
    dq = q - traj.q0
    mid, span = 0.5 * (dq.max(0) + dq.min(0)), 0.5 * (dq.max(0) - dq.min(0))
    s = np.min([limits.half / span, limits.velocity / np.abs(qd).max(0),
                limits.acceleration / np.abs(qdd).max(0)], axis=0)
    return FourierSeries(
        limits.centre - s * mid, traj.a * s[:, None], traj.b * s[:, None], traj.w_f
    )


def condition_number(traj: FourierSeries, regressor: Regressor, n: int = SAMPLES) -> float:
    """cond(W) of ``regressor`` sampled at n instants over one period (the paper's criterion)."""
    t = np.linspace(0.0, traj.period, n, endpoint=False)
    s = np.linalg.svd(regressor(*traj.evaluate(t)), compute_uv=False)
    return float(s[0] / s[-1]) if s[-1] > 0 else float("inf")


def random_trajectory(limits: MotionLimits, seed: int, K: int = HARMONICS,
                      period: float = PERIOD) -> FourierSeries:
    """A random Fourier shape (a then b, joint by joint, standard normal) scaled to the limits."""
    n = len(limits.centre)
    a, b = np.random.default_rng(seed).normal(size=2 * n * K).reshape(2, n, K)
    return scaled(FourierSeries(limits.centre.copy(), a, b, 2.0 * np.pi / period), limits)


def design_path(robot: str, k: int, data_dir: Path = DATA_DIR) -> Path:
    return data_dir / f"{robot}_exciting{k}.json"


def designed_trajectory(arm: ArmDescription, name: str) -> FourierSeries:
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
