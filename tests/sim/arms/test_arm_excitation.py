"""The serial arm's stored exciting trajectories: periodic, inside the UR5's safe box, better
conditioned than random Fourier series; the regressor cond(W) is measured on equals the truth's
inverse dynamics. (Their design: the product's designer, tests/sim/arm_or_chain.)"""
from __future__ import annotations

import json

import numpy as np
import pinocchio as pin
import pytest

from orthoglide_ident.errors import ConfigError
from orthoglide_sim.arms import excitation as ax
from orthoglide_sim.arms.description import load_arm
from orthoglide_sim.arms.limits import motion_limits
from orthoglide_sim.arms.pinocchio_truth import ArmRegressor, TruthDynamics, urdf_model
from orthoglide_sim.arms.truth import GRAVITY, default_truth

NAMES = ("exciting1", "exciting2")


@pytest.fixture(scope="module")
def arm():
    return load_arm("ur5")


@pytest.fixture(scope="module")
def regressor(arm):
    return ArmRegressor(arm)


@pytest.mark.parametrize("name", NAMES)
def test_designed_trajectory_is_periodic_and_inside_the_limits(arm, name):
    traj = ax.designed_trajectory(arm, name)
    lim = motion_limits(arm)
    t = np.linspace(0.0, traj.period, 40_000, endpoint=False)
    q, qd, qdd = traj.evaluate(t)
    tol = 1 + 1e-3  # the scaling checks 2000 samples per period; this grid is 20x denser
    assert np.all(np.abs(q - lim.centre) <= lim.half * tol)
    assert np.all(np.abs(qd).max(0) <= lim.velocity * tol)
    assert np.all(np.abs(qdd).max(0) <= lim.acceleration * tol)
    # each joint is on one of its limits (the scaling)
    ratio = np.max([np.abs(q - lim.centre).max(0) / lim.half, np.abs(qd).max(0) / lim.velocity,
                    np.abs(qdd).max(0) / lim.acceleration], axis=0)
    assert np.all(ratio > 0.999)
    later = traj.evaluate(t[:500] + 3 * traj.period)
    for a, b in zip(traj.evaluate(t[:500]), later):
        assert np.allclose(a, b, atol=1e-9)
    assert 60.0 / traj.period >= 4  # the lag instrument: >= 4 periods in a 60 s record


@pytest.mark.parametrize("name", NAMES)
def test_designed_trajectory_beats_random_fourier_series(arm, regressor, name):
    traj = ax.designed_trajectory(arm, name)
    cond = ax.condition_number(traj, regressor.base)
    stored = json.loads((ax.design_path(arm.name, NAMES.index(name) + 1)).read_text())
    assert cond == pytest.approx(stored["condition_number"], rel=1e-6)
    lim = motion_limits(arm)
    random = [
        ax.condition_number(ax.random_trajectory(lim, seed), regressor.base) for seed in range(8)
    ]
    print(f"{name}: cond {cond:.0f}, random {np.round(random)}")
    assert cond < 0.8 * min(random)


def test_safe_box_keeps_the_arm_above_its_mounting_plane(arm):
    """Random corners of the UR5's box: forearm to tool0 at least 0.2 m above the base plane."""
    model, idx = urdf_model(arm, GRAVITY)
    data = model.createData()
    lim = motion_limits(arm)
    frames = [model.getFrameId(f) for f in ("forearm_link", "wrist_1_link", "wrist_2_link",
                                            "wrist_3_link", "tool0")]
    rng = np.random.default_rng(0)
    lowest = np.inf
    for _ in range(1500):
        u = rng.uniform(-1, 1, 6)
        u[:3] = np.sign(u[:3])  # the arm joints at their box edges
        q = np.empty(6)
        q[idx] = lim.centre + lim.half * u
        pin.framesForwardKinematics(model, data, q)
        lowest = min(lowest, min(data.oMf[f].translation[2] for f in frames))
    assert lowest > 0.2


def test_regressor_times_standard_parameters_is_the_truths_dynamics(arm, regressor):
    truth = default_truth(arm)
    rng = np.random.default_rng(5)
    q, qd, qdd = (
        rng.uniform(-3, 3, (100, 6)),
        rng.normal(0, 2, (100, 6)),
        rng.normal(0, 10, (100, 6)),
    )
    for payload in (None, truth.payload("2.0")):
        tau = TruthDynamics(truth, payload).torques(q, qd, qdd, friction=True)
        W = regressor.standard(q, qd, qdd)
        assert W.shape == (600, 84) and len(regressor.names) == 84
        assert (
            np.abs(W @ regressor.standard_vector(truth, payload) - tau.T.ravel()).max()
            < 1e-9 * np.abs(tau).max()
        )
    B = regressor.base(q, qd, qdd)
    assert np.linalg.matrix_rank(B) == B.shape[1] == np.linalg.matrix_rank(W)


def test_missing_trajectory_says_how_to_design_it(arm):
    how = "python -m orthoglide_sim.arm_or_chain.excitation --robot ur5"
    with pytest.raises(ConfigError, match=how):
        ax.designed_trajectory(arm, "exciting9")


def test_the_box_as_a_ros2_control_joint_limits_file(tmp_path):
    """The box written as a joint_limits YAML (make demo-excite's cell limits) is what the
    product's excite design reads, inside the simulated arm's protective stop."""
    import yaml

    from orthoglide_ident.excite.limits import read_limits
    from orthoglide_ident.model.registry import load_robot
    from orthoglide_sim.arms.limits import ros2_joint_limits

    arm = load_arm("ur5")
    lim = motion_limits(arm)
    f = tmp_path / "cell.yaml"
    f.write_text(yaml.safe_dump(ros2_joint_limits(lim, arm.joint_names)))
    read = read_limits(load_robot("ur5"), f)
    np.testing.assert_allclose(read.lower, lim.centre - lim.half)
    np.testing.assert_allclose(read.upper, lim.centre + lim.half)
    assert np.all(read.lower > lim.stop_lower) and np.all(read.upper < lim.stop_upper)
    np.testing.assert_allclose(read.velocity, [3.15, 3.15, 3.15, 3.2, 3.2, 3.2])  # the URDF's
