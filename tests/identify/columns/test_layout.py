"""The column layout (columns/layout.py): [W | W_ul | lag | ripple | W_kl] laid out once per
robot and options, its names and index ranges, and its block next to the robot's own."""
from __future__ import annotations

import numpy as np
from synthetic import SyntheticModel, trajectory

from orthoglide_ident.identify.columns.layout import column_layout, plain_layout
from orthoglide_ident.identify.columns.payload_unknowns import payload_basis
from orthoglide_ident.model.registry import load_robot
from orthoglide_ident.model.robot import INERTIAL_KINDS, Payload

LEAD = 0.010  # m


def test_the_ranges_follow_eq_33_order_and_the_robot_is_not_changed():
    """UR5, payload known by its mass, lag modelled: χ (n_b), χ_ul (the payload's QR), one lag
    column per joint; W_kl last in the block, not an unknown."""
    robot = load_robot("ur5")
    names = list(robot.names)
    layout = column_layout(robot, 0.0, lag=True)
    basis = payload_basis(robot, "")
    n_b, n_ul, n_j = len(names), basis.n, robot.n_joints
    assert n_ul > 0  # a serial arm's flange payload has first moments and inertia that act
    assert layout.names == names + list(basis.names) + [f"lag_{j}" for j in robot.joint_names]
    assert layout.payload_slice == slice(n_b, n_b + n_ul)
    assert layout.lag_column == n_b + n_ul and layout.n_columns == n_b + n_ul + n_j
    assert robot.names == names  # the robot is never wrapped nor changed
    # the solve's derived layouts: no payload column filled, the lag left out
    kept = layout.keeping(()).without_lag()
    assert kept.names == names and kept.lag_column is None and not kept.has_payload_unknowns
    assert layout.keeping((1, 0)).payload_names == [basis.names[1], basis.names[0]]


def test_the_block_is_the_robot_s_with_the_payload_s_unknown_columns_beside_it():
    """A loaded record whose payload is known by its mass: W and W_kl are the robot's bound to
    its known part (a point mass), W_ul the payload's standard columns of its unknown kinds
    regrouped by the basis (here single parameters: the basis' K rows are unit vectors)."""
    robot = load_robot("ur5")
    layout = column_layout(robot, 0.0, lag=True)
    q, qd, qdd = robot.random_states(40, 3)
    payload = Payload(2.0, known="mass")
    bound = robot.with_payload(payload.known_part())
    X = layout.observation_block(bound, q, qd, qdd, payload=payload)
    n_b, n = len(robot.names), layout.n_columns
    ref = bound.observation_block(q, qd, qdd)
    # the same Pinocchio regressor on the same states: equal to rounding (its calls may batch
    # the samples differently)
    np.testing.assert_allclose(X[:n_b], ref[:n_b], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(X[n], ref[n_b], rtol=1e-12, atol=1e-12)
    std = robot.payload_standard_block(q, qd, qdd, "")
    for i, c in enumerate(layout.payload_columns):
        kind = layout.basis.kinds[c]
        np.testing.assert_allclose(X[n_b + i], std[INERTIAL_KINDS.index(kind)], rtol=1e-12,
                                   atol=1e-12)
    assert not X[layout.lag_column:n].any()  # the lag's instrument: the stream fills it
    unloaded = layout.observation_block(robot, q, qd, qdd)
    assert not unloaded[layout.payload_slice].any()  # W_ul: zero in an unloaded record


def test_the_ripple_columns_and_a_plain_layout():
    robot = SyntheticModel()
    assert plain_layout(robot).names == robot.names and plain_layout(robot).n_extra == 0
    layout = column_layout(robot, LEAD)
    q, qd, qdd = trajectory(np.linspace(0.0, 1.0, 200), seed=5)
    X = layout.observation_block(robot, q, qd, qdd)
    s = layout.ripple_slice
    assert s == slice(len(robot.names), len(robot.names) + 6)
    for j in range(3):  # sign(q̇_j) cos, sin(2π q_j / λ) in joint j's rows only
        np.testing.assert_allclose(X[s.start + 2 * j, j],
                                   np.sign(qd[:, j]) * np.cos(2 * np.pi * q[:, j] / LEAD))
        np.testing.assert_allclose(X[s.start + 2 * j + 1, j],
                                   np.sign(qd[:, j]) * np.sin(2 * np.pi * q[:, j] / LEAD))
    assert layout.expressions[s.start] == f"sign(q̇ q11) cos(2π q11 / {LEAD:g} m)"
