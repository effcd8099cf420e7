"""Reference trajectories of the actuators: exciting finite Fourier series and smooth test motions.

Exciting trajectories (paper Sect. 3.2, refs [24, 25], Fig. 4): per actuator a finite Fourier series

    q_i(t) = q0_i + sum_{k=1..K} a_ik / (k w_f) sin(k w_f t) - b_ik / (k w_f) cos(k w_f t)

the product's one type, ``orthoglide_ident.excite.FourierSeries``; the stored ones (data/*.json,
``kind: fourier``) were designed inside the workspace box, velocity and acceleration limits and
a margin from singularities (``orthoglide_sim.orthoglide.excitation``). Test trajectories
(Fig. 6): smooth point-to-point motions (quintic blends, zero velocity and acceleration at every
via point).

All trajectories are evaluated by ``evaluate(t) -> (q, qd, qdd)``, each (N, 3) in m, m/s, m/s².
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.excite import FourierSeries

# Safe actuator box (m): Q_CENTER - Q_HALF <= q1i <= Q_CENTER + Q_HALF, i.e. [-0.04, 0.12] m on each
# actuator (see excitation.workspace_report()). Everywhere in it the bars stay within ~28 deg of
# their actuator axis (u_i.e_i >= 0.88: far from the serial singularities, where J_k loses rank),
# the parallel-singularity margin |det(u_1, u_2, u_3)| >= 0.56 (0 when the bars are coplanar, A_p
# singular) and cond(J_p) <= 2.5. The box is not centred on q = 0: moving all feet back from the
# isotropic configuration soon leaves the workspace (no assembly beyond q = -0.08 (1, 1, 1)).
Q_CENTER = 0.04
Q_HALF = 0.08
V_MAX = 0.8  # m/s, actuator speed limit for exciting trajectories
A_MAX = 14.0  # m/s², actuator acceleration limit for exciting trajectories

DATA_DIR = Path(__file__).resolve().parents[1] / "data"


def _quintic(s):
    return (
        s**3 * (10 - 15 * s + 6 * s**2),
        s**2 * (30 - 60 * s + 30 * s**2),
        s * (60 - 180 * s + 120 * s**2),
    )


@dataclass(frozen=True)
class ViaPointTrajectory:
    """Rest-to-rest quintic moves through via points (3,) with given durations, repeated."""

    points: np.ndarray  # (P, 3) m, the first is repeated at the end to close the cycle
    durations: np.ndarray  # (P,) s, duration of the move from point k to point k+1

    @property
    def period(self) -> float:
        return float(np.sum(self.durations))

    def evaluate(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        t = np.mod(np.atleast_1d(np.asarray(t, dtype=float)), self.period)
        starts = np.concatenate([[0.0], np.cumsum(self.durations)[:-1]])
        seg = np.clip(np.searchsorted(starts, t, side="right") - 1, 0, len(self.durations) - 1)
        T = self.durations[seg]
        s = np.clip((t - starts[seg]) / T, 0.0, 1.0)
        p0 = self.points[seg]
        p1 = self.points[(seg + 1) % len(self.points)]
        f, fd, fdd = _quintic(s)
        dp = p1 - p0
        return p0 + f[:, None] * dp, (fd / T)[:, None] * dp, (fdd / T**2)[:, None] * dp


# Test trajectories in the manner of Fig. 6: trajectory 1 moves mainly the horizontal actuators
# 1 and 2 (actuator 3 little), trajectory 2 moves all three.
TEST_TRAJECTORIES = {
    "test1": ViaPointTrajectory(
        Q_CENTER + np.array([[0.0, 0.0, 0.0], [0.07, -0.06, 0.005], [-0.065, 0.06, -0.005],
                             [0.06, 0.07, 0.0], [-0.07, -0.06, 0.005]]),
        np.array([0.35, 0.45, 0.4, 0.45, 0.35])),
    "test2": ViaPointTrajectory(
        Q_CENTER + np.array([[0.0, 0.0, 0.0], [0.07, 0.06, -0.06], [-0.06, 0.05, 0.07],
                             [0.06, -0.07, 0.05], [-0.05, -0.06, -0.07]]),
        np.array([0.4, 0.45, 0.45, 0.45, 0.4])),
}


def load_fourier(path: str | Path) -> FourierSeries:
    try:
        return FourierSeries.from_dict(json.loads(Path(path).read_text()))
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise ConfigError(f"cannot load Fourier trajectory {path}: {exc}") from None


def exciting_names() -> list[str]:
    return sorted(p.stem for p in DATA_DIR.glob("exciting*.json"))


def get_trajectory(name: str):
    """A trajectory by name: "exciting" (= exciting1), "exciting2", "test1", "test2", or a .json
    path."""
    if name in TEST_TRAJECTORIES:
        return TEST_TRAJECTORIES[name]
    if name == "exciting":
        name = "exciting1"
    path = DATA_DIR / f"{name}.json"
    if path.exists():
        return load_fourier(path)
    if name.endswith(".json"):
        return load_fourier(name)
    known = sorted(TEST_TRAJECTORIES) + ["exciting"] + exciting_names()
    raise ConfigError(f"unknown trajectory {name!r}; known: {', '.join(known)} or a .json file")
