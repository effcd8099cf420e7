"""The serial arm's MuJoCo plant: the truth's inertials kept exactly, MuJoCo's dynamics equal to
Pinocchio's RNEA of the same truth (two independent implementations), friction loss realistic."""
from __future__ import annotations

import mujoco
import numpy as np
import pytest
from example_robots import urdf

from orthoglide_ident.errors import ConfigError
from orthoglide_sim.arms.description import load_arm
from orthoglide_sim.arms.pinocchio_truth import TruthDynamics
from orthoglide_sim.arms.plant import PAYLOAD_BODY, MujocoPlant
from orthoglide_sim.arms.truth import RigidBody, apply_overrides, default_truth, load_truth

PAYLOADS = (None, "2.0", "1.0")


@pytest.fixture(scope="module")
def truth():
    return default_truth(load_arm("ur5"))


def _random_states(n: int, seed: int = 7):
    rng = np.random.default_rng(seed)
    return (
        rng.uniform(-np.pi, np.pi, (n, 6)),
        rng.normal(0, 2.0, (n, 6)),
        rng.normal(0, 10.0, (n, 6)),
    )


def test_truth_every_standard_parameter_non_trivial_and_off_nominal(truth):
    arm = truth.arm
    for j in arm.joints:  # the 6 moving links
        urdf = arm.inertials[j.child]
        nominal = RigidBody(urdf.mass, urdf.com, urdf.inertia).standard()
        true = truth.bodies[j.child].standard()
        truth.bodies[j.child].check(j.child)
        # per group (inertia kg·m², first moments kg·m, mass kg): non-zero, and moved by more than
        # 1 % of the nominal value or of a tenth of the group's size (the URDF's zeros)
        size = {(0, 6): np.abs(nominal[:6]).max(), (6, 9): 0.01 * urdf.mass, (9, 10): urdf.mass}
        for (a, b), s in size.items():
            assert np.all(np.abs(true[a:b]) > 1e-3 * s), (j.child, true[a:b])
            moved = np.abs(true[a:b] - nominal[a:b])
            assert np.all(moved > 0.01 * np.maximum(np.abs(nominal[a:b]), 0.1 * s)), (j.child, a)
    g, g_nom = truth.drive_array("g_tau"), arm.nominal_gains
    off = g / g_nom - 1
    assert np.all(np.abs(off) > 0.02) and np.all(np.abs(off) < 0.06)
    assert len(set(np.round(off, 6))) == arm.n  # each joint its own
    for key in ("armature", "damping", "frictionloss", "offset"):
        assert np.all(truth.drive_array(key) != 0), key


@pytest.mark.parametrize("payload", PAYLOADS)
def test_mujoco_keeps_the_truths_inertials(truth, payload):
    plant = MujocoPlant(truth, truth.payload(payload))
    errs = plant.inertial_errors()
    assert set(truth.bodies) <= set(errs)
    assert (PAYLOAD_BODY in errs) == (payload is not None)
    assert max(errs.values()) < 1e-12, errs
    m = plant.model
    for key, field in (("armature", m.dof_armature), ("damping", m.dof_damping),
                       ("frictionloss", m.dof_frictionloss)):
        assert np.array_equal(field[plant.dof], truth.drive_array(key)), key
    assert not m.jnt_limited.any() and m.ngeom == 0  # no limit constraints, no contacts


@pytest.mark.parametrize("payload", PAYLOADS)
def test_mujoco_inverse_dynamics_equals_pinocchio_rnea(truth, payload):
    load = truth.payload(payload)
    q, qd, qdd = _random_states(300)
    a = MujocoPlant(truth, load).inverse_dynamics(q, qd, qdd, friction=True)
    b = TruthDynamics(truth, load).torques(q, qd, qdd, friction=True)
    assert np.abs(a - b).max() <= 1e-9 * np.abs(b).max()


def test_mujoco_forward_dynamics_under_held_torque_equals_pinocchio(truth):
    """What the simulator integrates: MuJoCo's q̈ under qfrc_applied = tau - tauoff (friction
    loss off) satisfies Pinocchio's RNEA + armature + fv q̇ + tauoff = tau."""
    plant, pd = MujocoPlant(truth, truth.payload("2.0")), TruthDynamics(truth, truth.payload("2.0"))
    plant.model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_FRICTIONLOSS
    q, qd, _ = _random_states(50, seed=3)
    tau = np.random.default_rng(4).normal(0, 30.0, q.shape)
    qdd = np.empty_like(q)
    for k in range(len(q)):
        plant.reset(q[k], qd[k])
        plant.data.qfrc_applied[plant.dof] = tau[k] - plant.offset
        mujoco.mj_forward(plant.model, plant.data)
        qdd[k] = plant.data.qacc[plant.dof]
    assert np.abs(pd.torques(q, qd, qdd) - tau).max() <= 1e-9 * np.abs(tau).max()


def test_friction_loss_is_a_bounded_coulomb_force(truth):
    """MuJoCo's frictionloss with the other forces balanced (q̈ = 0 without friction, as under
    the controller): fs against the motion when sliding (±0.05 rad/s), never more, and smooth
    through zero velocity (well under fs at 0.1 mrad/s)."""
    plant = MujocoPlant(truth)
    fs = truth.drive_array("frictionloss")
    q = np.array([0.0, -2.0, 1.2, -1.57, -1.57, 0.0])
    for v, sliding in ((0.05, True), (-0.05, True), (1e-4, False)):
        plant.reset(q, np.full(6, v))
        d = plant.data
        d.qfrc_applied[:] = d.qfrc_bias - d.qfrc_passive
        mujoco.mj_forward(plant.model, d)
        f = d.qfrc_constraint[plant.dof]
        assert np.all(np.abs(f) <= fs * (1 + 1e-9)) and np.all(np.sign(f) == -np.sign(v))
        if sliding:
            assert np.allclose(f, -np.sign(v) * fs, rtol=1e-6)
        else:
            assert np.all(np.abs(f) < 0.5 * fs)


def test_yaml_overrides_reach_the_plant(truth):
    body = {
        "mass": 0.2,
        "com": [0.001, 0.002, 0.003],
        "inertia": [0.02, 0.0, 0.0, 0.02, 0.0, 0.035],
    }
    pay = {"frame": "wrist_3_link", "mass": 3.0, "com": [0.0, 0.0, 0.1],
           "inertia": [0.01, 0.001, 0.0, 0.01, 0.0, 0.005]}
    t = apply_overrides(truth, {"joints": {"elbow_joint": {"g_tau": 12.0, "frictionloss": 3.0}},
                                "bodies": {"wrist_3_link": body}, "payloads": {"3.0": pay},
                                "current_noise": 0.01})
    assert t.drives["elbow_joint"].g_tau == 12.0 and t.drives["elbow_joint"].frictionloss == 3.0
    assert t.drives["elbow_joint"].armature == truth.drives["elbow_joint"].armature
    assert t.current_noise_fraction == 0.01
    plant = MujocoPlant(t, t.payload("3.0"))
    assert max(plant.inertial_errors().values()) < 1e-12
    assert plant.body_inertial("wrist_3_link").mass == 0.2
    assert t.payload("3.0").tag()["payload_frame"] == "wrist_3_link"


@pytest.mark.parametrize("data, reason", [
    ({"joint": {}}, "keys among"),
    ({"joints": {"nope": {"damping": 1.0}}}, "not an actuated joint"),
    ({"joints": {"elbow_joint": {"damping": "x"}}}, "finite number"),
    ({"joints": {"elbow_joint": {"g_tau": 0.0}}}, "positive"),
    ({"bodies": {"wrist_3_link": {"inertia": [0.01, 0, 0, 0.01, 0, 0.05]}}}, "triangle inequality"),
    ({"bodies": {"tool0": {"mass": 1.0}}}, "no link of positive mass"),
    ({"payloads": {"5": {"mass": 5.0}}}, "needs mass, com and inertia"),
    ({"encoder_counts": 1.5}, "integer"),
])
def test_bad_overrides_get_a_one_line_reason(truth, data, reason):
    with pytest.raises(ConfigError, match=reason) as exc:
        apply_overrides(truth, data, "arm.yaml")
    assert "\n" not in str(exc.value)


def test_config_file_is_the_default_truth(truth):
    t = load_truth(truth.arm, "config/arm_plant.yaml")
    for key in ("armature", "damping", "frictionloss", "offset", "g_tau"):
        assert np.allclose(t.drive_array(key), truth.drive_array(key), rtol=1e-12, atol=0), key
    assert t.encoder_counts == 2**19 and t.current_noise_fraction == 0.005


def test_payload_tag_is_its_rigid_body(truth):
    p = truth.payload("2.0")
    tag = p.tag()
    com = np.array(tag["payload_com"], float)
    xx, xy, xz, yy, yz, zz = np.array(tag["payload_inertia"], float)
    assert tag["payload_frame"] == "tool0" and np.array_equal(com, p.body.com)
    assert np.array_equal(np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]]), p.body.inertia)
    assert np.linalg.norm(com) > 0.05 and abs(xy) > 0  # off-centre, not a point mass


def test_true_gains_follow_the_robot_files_nominal_gains():
    """The UR5's URDF alone has nominal gains 1: the true ones are the same few % off them."""
    bare = default_truth(load_arm("orthoglide_ident/robots/ur5.urdf"))
    full = default_truth(load_arm("ur5"))
    assert np.allclose(
        bare.drive_array("g_tau"), full.drive_array("g_tau") / full.arm.nominal_gains
    )


def test_a_urdf_with_package_collision_meshes_builds_its_plant():
    """The example-robot-data UR3 (collision meshes at package:// URIs MuJoCo cannot open): its
    plant builds without geoms and agrees with Pinocchio's RNEA of the same truth."""
    ur3 = urdf("ur_description/urdf/ur3_robot.urdf")
    text = ur3.read_text()
    assert "package://" in text and "<collision" in text
    truth = default_truth(load_arm(str(ur3)))
    plant = MujocoPlant(truth)
    assert plant.model.ngeom == 0
    q, qd, qdd = _random_states(100)
    a = plant.inverse_dynamics(q, qd, qdd, friction=True)
    b = TruthDynamics(truth, None).torques(q, qd, qdd, friction=True)
    assert np.abs(a - b).max() <= 1e-9 * np.abs(b).max()
