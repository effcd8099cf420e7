"""Trajectories stay inside the safe box, within limits, and away from singularities; the
simulator's Fourier series are the product's one type."""
from __future__ import annotations

import dataclasses
import importlib
import inspect
import pkgutil

import numpy as np
import pytest

import orthoglide_sim
from orthoglide_ident.excite import FourierSeries
from orthoglide_sim.common.trajectories import Q_CENTER, Q_HALF, TEST_TRAJECTORIES, get_trajectory
from orthoglide_sim.orthoglide import kinematics as kin

NAMES = ["exciting1", "exciting2", "test1", "test2"]


@pytest.mark.parametrize("name", NAMES)
def test_inside_workspace_and_away_from_singularities(name):
    traj = get_trajectory(name)
    t = np.linspace(0.0, traj.period, 2001)
    q, qd, qdd = traj.evaluate(t)
    assert np.all(q >= Q_CENTER - Q_HALF - 1e-12) and np.all(q <= Q_CENTER + Q_HALF + 1e-12)
    assert np.abs(qd).max() <= 1.5 and np.abs(qdd).max() <= 25.0
    serial, parallel, inv_cond = kin.singularity_margins(q[::10])
    assert serial.min() > 0.8 and parallel.min() > 0.5 and (1 / inv_cond).max() < 3.0


def test_exciting_trajectory_is_strongly_exciting():
    traj = get_trajectory("exciting")
    from orthoglide_sim.orthoglide.excitation import platform_peaks

    v, a = platform_peaks(traj, n=1000)
    assert v > 0.7 and a > 8.0


def test_test_trajectories_are_smooth_and_periodic():
    for traj in TEST_TRAJECTORIES.values():
        q0, qd0, _ = traj.evaluate(0.0)
        q1, qd1, _ = traj.evaluate(traj.period - 1e-9)
        assert np.allclose(q0, q1, atol=1e-9) and np.allclose(qd0, 0) and np.abs(qd1).max() < 1e-6


def test_the_simulators_fourier_series_are_the_products_one_type():
    """Every stored trajectory loads as orthoglide_ident.excite.FourierSeries, and no class of
    the simulator is a second Fourier series (a dataclass of q0, a, b, w_f)."""
    from orthoglide_sim.arms.description import load_arm
    from orthoglide_sim.arms.excitation import designed_trajectory

    assert type(get_trajectory("exciting1")) is FourierSeries
    assert type(designed_trajectory(load_arm("ur5"), "exciting2")) is FourierSeries
    fourier_fields = {"q0", "a", "b", "w_f"}
    others = []
    for info in pkgutil.walk_packages(orthoglide_sim.__path__, "orthoglide_sim."):
        module = importlib.import_module(info.name)
        for _, cls in inspect.getmembers(module, inspect.isclass):
            if cls.__module__ == info.name and dataclasses.is_dataclass(cls) and \
                    fourier_fields <= {f.name for f in dataclasses.fields(cls)}:
                others.append(f"{info.name}.{cls.__name__}")
    assert not others, others
