"""The general (Pinocchio) model on a serial arm, the UR5: its rows against Pinocchio's own RNEA,
its base parameters against the rank of its standard regressor, its payload column against a
body added to the tree.

The references are computed here from a fresh Pinocchio model of the same URDF with random
(physically valid) inertias, armature and friction: RNEA knows nothing of regressors, base
parameters or the product's parameter order.
"""
from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from orthoglide_ident.errors import ConfigError, ModelError
from orthoglide_ident.model.registry import ROBOTS_DIR, load_robot
from orthoglide_ident.model.robot import Payload

URDF = str(ROBOTS_DIR / "ur5.urdf")
G0 = 9.80665


@pytest.fixture(scope="module")
def ur5():
    return load_robot("ur5")


def random_inertia(rng: np.random.Generator) -> pin.Inertia:
    """A physically valid body: mass, centre of mass, principal moments obeying the triangle
    inequality, turned by a random rotation."""
    p = rng.uniform(0.01, 0.1, 3)
    p[2] = min(p[2], 0.95 * (p[0] + p[1]))
    R = pin.exp3(rng.normal(0.0, 1.0, 3))
    return pin.Inertia(rng.uniform(0.5, 5.0), rng.uniform(-0.1, 0.1, 3), R @ np.diag(p) @ R.T)


def dynamic_to_kinds(pi: np.ndarray) -> list[float]:
    """Pinocchio's [m, mx, my, mz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz] -> xx xy xz yy yz zz mx my mz m."""
    m, mx, my, mz, xx, xy, yy, xz, yz, zz = pi
    return [xx, xy, xz, yy, yz, zz, mx, my, mz, m]


def reference_robot(rng: np.random.Generator):
    """(fresh model with random inertias and armature, χ_st in the UR5 model's standard order)."""
    model = pin.buildModelFromUrdf(URDF)
    model.gravity = pin.Motion(np.array([0.0, 0.0, -G0]), np.zeros(3))
    chi = []
    armature = rng.uniform(0.1, 1.0, model.nv)
    model.armature = armature
    for j in range(1, model.njoints):  # the UR5's bodies are labelled 1..6 from the base
        model.inertias[j] = random_inertia(rng)
        fv, fs, tauoff = rng.uniform(0.5, 5.0), rng.uniform(0.5, 5.0), rng.uniform(-1.0, 1.0)
        chi += dynamic_to_kinds(model.inertias[j].toDynamicParameters())
        chi += [armature[j - 1], fv, fs, tauoff]
    return model, np.array(chi)


def test_names_joints_and_bodies(ur5):
    assert ur5.joint_names == ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint",
                               "wrist_1_joint", "wrist_2_joint", "wrist_3_joint")
    assert [j.kind for j in ur5.joints] == ["revolute"] * 6
    assert ur5.nominal_gains.tolist() == [13.0, 13.0, 13.0, 9.3, 9.3, 9.3]
    assert ur5.gain_units == ("N·m/A",) * 6
    assert len(ur5.standard_names) == 6 * 14
    assert ur5.standard_names[:14] == ("xx_1", "xy_1", "xz_1", "yy_1", "yz_1", "zz_1", "mx_1",
                                       "my_1", "mz_1", "m_1", "ia_1", "fv_1", "fs_1", "tauoff_1")
    assert [b.name for b in ur5.bodies] == ["shoulder_link", "upper_arm_link", "forearm_link",
                                            "wrist_1_link", "wrist_2_link", "wrist_3_link"]
    assert ur5.bodies[2].inertial == tuple(range(28, 38))
    assert ur5.payload_frame == "tool0"
    assert ur5.joints[1].lower == pytest.approx(-2 * np.pi) and ur5.joints[1].velocity_limit == 3.15


def test_standard_rows_are_rnea_plus_armature_and_friction(ur5):
    """W_st χ = rnea(q, q̇, q̈) (armature included) + fv q̇ + fs sign(q̇) + tauoff (round-off)."""
    rng = np.random.default_rng(11)
    model, chi = reference_robot(rng)
    data = model.createData()
    q, qd, qdd = ur5.random_states(200, seed=3)
    tau = (ur5.standard_regressor(q, qd, qdd) @ chi).reshape(6, -1).T
    friction = chi.reshape(6, 14)[:, 11:]
    want = np.array([pin.rnea(model, data, q[k], qd[k], qdd[k]) for k in range(len(q))])
    want += friction[:, 0] * qd + friction[:, 1] * np.sign(qd) + friction[:, 2]
    assert np.abs(tau - want).max() <= 1e-11 * np.abs(want).max()


def test_base_parameters_equal_the_rank_and_reproduce_the_standard_model(ur5):
    q, qd, qdd = ur5.random_states(400, seed=21)  # states the QR never saw
    W_st = ur5.standard_regressor(q, qd, qdd)
    s = np.linalg.svd(W_st, compute_uv=False)
    assert int(np.sum(s > 1e-9 * s[0])) == ur5.n_b  # independent of the QR's choice of columns
    W_b = ur5.regressor(q, qd, qdd)
    assert W_b.shape == (6 * 400, ur5.n_b)
    assert np.linalg.cond(W_b) < 1e6
    chi = np.random.default_rng(2).normal(size=len(ur5.standard_names))
    tau = W_st @ chi
    assert np.allclose(W_b @ ur5.base_values(chi), tau, rtol=0, atol=1e-9 * np.abs(tau).max())
    assert len(ur5.expressions) == ur5.n_b
    assert ur5.n_b == 58  # the figure reported; the rank above is what makes it right


def test_observation_block_is_the_kept_standard_columns_with_the_payload_last(ur5):
    q, qd, qdd = ur5.random_states(50, seed=4)
    out = np.full((ur5.n_b + 1, 6, 50), np.nan)
    block = ur5.observation_block(q, qd, qdd, out=out)
    assert block is out and np.all(np.isfinite(out))
    W_st = ur5.standard_regressor(q, qd, qdd)
    kept = [ur5.standard_names.index(p.standard) for p in ur5.parameters]
    assert np.allclose(block[:-1].reshape(ur5.n_b, -1).T, W_st[:, kept], rtol=0, atol=1e-12)


def test_payload_column_is_a_body_fixed_to_the_frame(ur5):
    """mass × payload column = rnea with the payload appended at tool0 - rnea without."""
    payload = Payload(2.0, "tool0", (0.02, -0.01, 0.05),
                      (0.004, 0.0003, -0.0002, 0.005, 0.0001, 0.003))
    loaded = ur5.with_payload(payload)
    q, qd, qdd = ur5.random_states(60, seed=5)
    col = loaded.observation_block(q, qd, qdd)[-1].T  # (m, 6) per kg
    model = pin.buildModelFromUrdf(URDF)
    model.gravity = pin.Motion(np.array([0.0, 0.0, -G0]), np.zeros(3))
    frame = model.frames[model.getFrameId("tool0")]
    xx, xy, xz, yy, yz, zz = payload.inertia
    I_c = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
    body = pin.Inertia(payload.mass, np.array(payload.com), I_c)
    heavy = pin.Model(model)
    heavy.appendBodyToJoint(frame.parentJoint, frame.placement.act(body), pin.SE3.Identity())
    d0, d1 = model.createData(), heavy.createData()
    want = np.array([pin.rnea(heavy, d1, *s) - pin.rnea(model, d0, *s) for s in zip(q, qd, qdd)])
    assert np.abs(payload.mass * col - want).max() <= 1e-11 * np.abs(want).max()
    # the default payload: a point mass at the payload frame's origin
    col = ur5.observation_block(q, qd, qdd)[-1].T
    heavy = pin.Model(model)
    point = pin.Inertia(1.0, frame.placement.translation, np.zeros((3, 3)))
    heavy.appendBodyToJoint(frame.parentJoint, point, pin.SE3.Identity())
    d1 = heavy.createData()
    want = np.array([pin.rnea(heavy, d1, *s) - pin.rnea(model, d0, *s) for s in zip(q, qd, qdd)])
    assert np.abs(col - want).max() <= 1e-11 * np.abs(want).max()
    assert loaded.names == ur5.names  # the same base parameters, only the payload column differs


def test_payload_on_a_frame_the_robot_does_not_have(ur5):
    with pytest.raises(ConfigError, match="payload frame 'gripper'"):
        ur5.with_payload(Payload(1.0, "gripper"))
    with pytest.raises(ConfigError, match="fixed to the world"):
        ur5.with_payload(Payload(1.0, "base_link"))


def test_samples_of_the_wrong_shape_or_not_finite(ur5):
    q = np.zeros((4, 6))
    with pytest.raises(ModelError, match=r"shape \(N, 6\)"):
        ur5.observation_block(q[:, :3], q[:, :3], q[:, :3])
    bad = q.copy()
    bad[2, 1] = np.nan
    with pytest.raises(ModelError, match="sample 2"):
        ur5.regressor(bad, q, q)


def test_table_and_json_name_every_base_parameter(ur5):
    text = ur5.table()
    assert f"{ur5.n_b} base parameters of robot ur5 (of 84 standard" in text
    assert "shoulder_link" in text and "zz_1R" in text
    js = ur5.to_json()
    assert js["n_base"] == ur5.n_b and js["n_standard"] == 84
    assert [p["name"] for p in js["parameters"]] == ur5.names
    assert js["bodies"][0] == {"label": "1", "link": "shoulder_link", "joint": "shoulder_pan_joint"}
