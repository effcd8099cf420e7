"""The vectorised recursive Newton–Euler regressor (model/rnea_regressor.py) against Pinocchio's
per-sample one: the tree regressor, frame body regressors and LOCAL frame Jacobians on random
states, and the IDIM rows it builds (tree_regressor.py) — base columns, the payload column and
the standard columns with fixed bodies — for a serial arm and two closed chains."""
from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from orthoglide_ident.model.rnea_regressor import RneaRegressor, supported
from orthoglide_ident.model.robot import Payload
from orthoglide_ident.model.robots import load_robot
from orthoglide_ident.model.tree_regressor import TreeRegressor

ROBOTS = ("ur5", "five_bar", "orthoglide_general")
REL = 1e-12  # relative to each column's largest value: round-off is ~1e-15


def _close(a: np.ndarray, b: np.ndarray, axis: tuple[int, ...]) -> None:
    """|a - b| <= REL × the largest |b| over ``axis`` (a column's scale), everywhere; a column
    that is zero but for round-off (a planar robot's out-of-plane terms) is scaled by
    1e-3 × the largest column instead."""
    scale = np.maximum(np.abs(b).max(axis=axis, keepdims=True), 1e-3 * np.abs(b).max())
    assert np.all(np.abs(a - b) <= REL * scale), float(np.max(np.abs(a - b) / scale))


def _tree_states(model: pin.Model, m: int, seed: int):
    rng = np.random.default_rng(seed)
    lo, hi = -np.full(model.nq, 3.0), np.full(model.nq, 3.0)
    Q = np.array([pin.randomConfiguration(model, lo, hi) for _ in range(m)])
    return Q, rng.normal(0, 1, (m, model.nv)), rng.normal(0, 10, (m, model.nv))


@pytest.mark.parametrize("name", ROBOTS)
def test_tree_regressor_frames_and_jacobians_match_pinocchio(name):
    robot = load_robot(name)
    model, data = robot.model, robot.model.createData()
    Q, V, A = _tree_states(model, 40, seed=3)
    rnea = RneaRegressor(model)
    kin = rnea.kinematics(Q, V, A)
    Y = rnea.regressor(kin)  # (nv, 10 nb, m)
    frames = [f for f in range(model.nframes) if model.frames[f].parentJoint > 0]
    frames = frames[::max(1, len(frames) // 6)]  # a few frames on different bodies
    Yp = np.stack([pin.computeJointTorqueRegressor(model, data, Q[k], V[k], A[k]).copy()
                   for k in range(len(Q))], axis=-1)
    _close(Y, Yp, axis=(0, 2))
    for f in frames:
        path = list(rnea.joints[model.frames[f].parentJoint].path)
        Phi, J = rnea.frame(kin, f)
        Pp, Jp = [], []
        for k in range(len(Q)):
            pin.computeJointTorqueRegressor(model, data, Q[k], V[k], A[k])  # forward pass
            Pp.append(pin.frameBodyRegressor(model, data, f).copy())
            Jp.append(pin.computeFrameJacobian(model, data, Q[k], f, pin.LOCAL).copy())
        _close(Phi, np.stack(Pp, axis=-1), axis=(0, 2))
        Jp = np.stack(Jp, axis=-1)
        _close(J, Jp[:, path], axis=(0, 2))
        assert not np.any(np.delete(Jp, path, axis=1))  # no other joint moves the frame


@pytest.mark.parametrize("name", ROBOTS)
def test_idim_rows_match_the_per_sample_path(name):
    """Base columns with a payload of full inertia, and every standard column (frame bodies
    included: the Orthoglide's platform), through the closure's Gᵀ for the closed chains."""
    robot = load_robot(name)
    payload = Payload(2.0, "", (0.01, -0.02, 0.05), (0.01, 0.001, -0.002, 0.02, 0.003, 0.015))
    robot = robot.with_payload(payload)
    q, qd, qdd = robot.random_states(60, seed=5)
    vec = robot._rows
    assert vec._rnea is not None  # every joint of these robots is 1-DOF
    per_sample = TreeRegressor(robot.model, robot.actuated, robot._fixed_frames, robot.closure,
                               vectorised=False)
    out = {}
    warm = None if robot.closure is None else \
        (robot.closure._last, robot.closure._last_a, robot.closure._last_step)
    for key, rows in (("vec", vec), ("pin", per_sample)):
        if warm is not None:  # the same Newton iterates: the same tree states for both
            robot.closure._last, robot.closure._last_a, robot.closure._last_step = warm
        robot._rows = rows
        try:
            out[key] = (robot.observation_block(q, qd, qdd),
                        robot.standard_regressor(q, qd, qdd))
        finally:
            robot._rows = vec
    _close(out["vec"][0], out["pin"][0], axis=(1, 2))  # per column
    _close(out["vec"][1], out["pin"][1], axis=(0,))
    assert np.abs(out["pin"][0][-1]).max() > 0.1  # the payload column is not empty


def test_a_model_with_a_multi_dof_joint_keeps_the_per_sample_path():
    model = pin.buildSampleModelHumanoid()  # free-flyer and spherical joints
    assert not supported(model)
    with pytest.raises(ValueError):
        RneaRegressor(model)
    assert supported(load_robot("ur5").model)
