"""The Orthoglide described to the general model (robots/orthoglide_general.yaml: the MDH tree of
Tables 1-2 in a URDF, legs 2 and 3 closed on the platform by 6D loops) against the paper's closed
form (model/orthoglide/base.py): the same standard rows, the same 61 base parameters, the same
identification
on the sample bags.

The two share no kinematics: the closed form solves the loops by hand (eqs. 5-9, 41) and writes
Newton-Euler per body; the general model closes them numerically through Pinocchio's constraint
Jacobians and projects Pinocchio's tree regressor by Gᵀ.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from orthoglide_ident.errors import WorkspaceError
from orthoglide_ident.model.orthoglide.base import base_model
from orthoglide_ident.model.pinocchio_model import PinocchioRobot
from orthoglide_ident.model.registry import ROBOTS_DIR, load_robot, read_yaml

ORTHOGLIDE = load_robot("orthoglide")  # the robot these records are of

BAGS = Path(__file__).resolve().parents[3] / "bags"
ROW_TOL = 1e-9


@pytest.fixture(scope="module")
def general():
    return load_robot("orthoglide_general")


@pytest.fixture(scope="module")
def closed():
    return base_model()


def relative_error(W: np.ndarray, ref: np.ndarray) -> float:
    """Worst column error relative to that column's size. A column below 1e-3 of the matrix's
    largest entry (the platform's rotation terms and body 5's inertia vanish in theory; the
    closed form writes them as exact zeros, a Gᵀ projection as sums of terms of ~|W| that cancel
    to round-off) is measured against 1e-3 |W|: 1e-9 of that is 1e-12 of the matrix."""
    scale = np.maximum(np.abs(ref).max(axis=0), 1e-3 * np.abs(ref).max())
    return float((np.abs(W - ref).max(axis=0) / scale).max())


def test_standard_parameters_are_the_papers(general, closed):
    assert general.standard_names == closed.standard_names  # 208, xx_11 ... m_6, same order
    assert general.joint_names == ("q11", "q12", "q13")
    assert [j.kind for j in general.joints] == ["prismatic"] * 3
    assert general.nominal_gains == pytest.approx(closed.nominal_gains)
    assert [b.name for b in general.bodies][-1] == "platform"
    assert general.bodies[-1].inertial == tuple(range(198, 208))


@pytest.mark.parametrize("seed", [5, 6])
def test_standard_rows_equal_the_closed_forms(general, closed, seed):
    q, qd, qdd = closed.random_states(150, seed=seed)
    assert relative_error(general.standard_regressor(q, qd, qdd),
                          closed.standard_regressor(q, qd, qdd)) <= ROW_TOL


def test_payload_column_equals_the_closed_forms(general, closed):
    """Loaded records: the payload-mass column (eq. 33) on the platform."""
    q, qd, qdd = closed.random_states(150, seed=7)
    W_l = general.observation_block(q, qd, qdd)[-1].reshape(-1)
    ref = closed.payload_mass_column(q, qd, qdd)
    assert np.abs(W_l - ref).max() <= ROW_TOL * np.abs(ref).max()


def test_eq23_column_order_gives_the_closed_forms_base_parameters(general, closed):
    assert general.n_b == 61
    assert general.names == closed.names  # m_11R, m_12R, m_13R, ... symmetric legs
    assert general.expressions == closed.expressions
    q, qd, qdd = closed.random_states(150, seed=8)
    assert relative_error(general.regressor(q, qd, qdd), closed.regressor(q, qd, qdd)) <= ROW_TOL


def test_default_column_order_spans_the_same_space(closed):
    data = read_yaml(ROBOTS_DIR / "orthoglide_general.yaml")
    del data["column_order"]
    plain = PinocchioRobot.from_description(data, ROBOTS_DIR)
    assert plain.n_b == 61 and plain.names != closed.names  # bodies from the base: leg 1 first
    q, qd, qdd = closed.random_states(200, seed=9)
    W_g, W_c = plain.regressor(q, qd, qdd), closed.regressor(q, qd, qdd)
    Q = np.linalg.qr(W_c)[0]
    assert np.linalg.norm(W_g - Q @ (Q.T @ W_g)) <= 1e-9 * np.linalg.norm(W_g)


def test_beyond_the_limits_is_a_workspace_error(general):
    """At q = 0.5 m the spheres of eq. (41) still meet, but with the bars pointing backwards:
    not the robot's assembly mode, which the description's limits (±0.15 m) keep."""
    q = np.array([[0.0, 0.0, 0.0], [0.01, 0.02, 0.5]])
    with pytest.raises(WorkspaceError, match=r"q13 = 0\.5 m at sample 1 is outside its limits "
                       r"\[-0\.15, 0\.15\] m") as err:
        general.observation_block(q, np.zeros((2, 3)), np.zeros((2, 3)))
    assert "\n" not in str(err.value)


def test_identification_on_the_sample_bags_equals_the_closed_forms(general):
    """Gains, base parameters and their σ to 1e-6 relative (measured: ~1e-9)."""
    from orthoglide_ident.identify import identify

    bags = [str(BAGS / "unloaded"), str(BAGS / "loaded")]
    ref, res = identify(bags, model=ORTHOGLIDE), identify(bags, model=general)
    for a, b in zip(ref.drive_gains, res.drive_gains, strict=True):
        assert b.value == pytest.approx(a.value, rel=1e-6)
        assert b.rel_std == pytest.approx(a.rel_std, rel=1e-6)
    assert [p.name for p in res.parameters] == [p.name for p in ref.parameters]
    for a, b in zip(ref.parameters, res.parameters):
        assert b.value == pytest.approx(a.value, rel=1e-6)
        assert b.rel_std == pytest.approx(a.rel_std, rel=1e-6)
        assert b.expression == a.expression
    assert res.residual_rms == pytest.approx(ref.residual_rms, rel=1e-6)
