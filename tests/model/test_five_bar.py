"""A closed chain besides the Orthoglide: the planar five-bar (robots/five_bar.yaml), checked
against Pinocchio's constrained forward dynamics, which solves the loop by Lagrange multipliers
(a KKT system) instead of projecting the tree's regressor by Gᵀ, and against the same robot
written as an MJCF.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from orthoglide_ident.errors import SingularityError
from orthoglide_ident.model.closure import TreeStates
from orthoglide_ident.model.registry import ROBOTS_DIR, load_robot
from orthoglide_ident.model.robot import INERTIAL_KINDS, Payload

URDF = str(ROBOTS_DIR / "five_bar.urdf")
JOINTS = {"joint_1": "1", "joint_3": "2", "joint_2": "3", "joint_4": "4"}  # joint: body label
REFERENCE = {"joint_1": 1.8708, "joint_3": -0.858, "joint_2": 1.2708, "joint_4": 0.858}


@pytest.fixture(scope="module")
def five_bar():
    return load_robot("five_bar")


def tree_states(robot, q, qd, qdd) -> TreeStates:
    st = TreeStates.empty(len(q), robot.model.nq, robot.model.nv, robot.n_joints)
    return robot.closure.states(q, qd, qdd, st)


def kkt_accelerations(chi: dict[str, float], payload: float, st: TreeStates, tau_a: np.ndarray):
    """Actuated accelerations under τ_a by pin.constraintDynamics on a fresh model of the URDF
    (armature ia, joint friction as generalised forces, a point mass at the tip)."""
    model = pin.buildModelFromUrdf(URDF)
    model.gravity = pin.Motion(np.array([0.0, 0.0, -9.80665]), np.zeros(3))
    tip = model.frames[model.getFrameId("tip")]
    if payload:
        model.appendBodyToJoint(tip.parentJoint, pin.Inertia(payload, tip.placement.translation,
                                                             np.zeros((3, 3))), pin.SE3.Identity())
    iv = {n: model.joints[model.getJointId(n)].idx_v for n in JOINTS}
    act = [iv["joint_1"], iv["joint_2"]]
    model.armature = np.array([chi.get(f"ia_{JOINTS[n]}", 0.0) for n in sorted(iv, key=iv.get)])
    other = model.frames[model.getFrameId("tip_2")]
    loop = pin.RigidConstraintModel(pin.ContactType.CONTACT_3D, model, tip.parentJoint,
                                    tip.placement, other.parentJoint, other.placement,
                                    pin.ReferenceFrame.LOCAL)
    loops = pin.StdVec_RigidConstraintModel([loop])
    datas = pin.StdVec_RigidConstraintData([loop.createData()])
    data = model.createData()
    pin.initConstraintDynamics(model, data, loops, datas)
    prox = pin.ProximalSettings(1e-14, 1e-10, 50)  # μ > 0: the planar loop's third row is zero
    out = []
    for k in range(len(tau_a)):
        tau = np.zeros(model.nv)
        for n, lab in JOINTS.items():
            v = st.v[k, iv[n]]
            tau[iv[n]] = -(chi[f"fv_{lab}"] * v + chi[f"fs_{lab}"] * np.sign(v)
                           + chi[f"tauoff_{lab}"])
        tau[act] += tau_a[k]
        a = pin.constraintDynamics(model, data, st.q[k], st.v[k], tau, loops, datas, prox)
        out.append(a[act])
    return np.array(out)


def nominal_with_drive_terms(robot) -> np.ndarray:
    chi = robot.standard_values().copy()
    rng = np.random.default_rng(4)
    for k, name in enumerate(robot.standard_names):
        if name.split("_")[0] in ("ia", "fv", "fs", "tauoff"):
            chi[k] = rng.uniform(0.005, 0.05)
    return chi


def test_description(five_bar):
    assert five_bar.joint_names == ("joint_1", "joint_2")
    assert five_bar.standard_names[:14] == tuple(f"{k}_1" for k in INERTIAL_KINDS) + \
        ("ia_1", "fv_1", "fs_1", "tauoff_1")
    assert "ia_2" not in five_bar.standard_names  # the passive elbow: friction, no rotor
    assert "fv_2" in five_bar.standard_names
    assert len(five_bar.standard_names) == 2 * 14 + 2 * 13
    inertial = five_bar.standard_values()[[i for b in five_bar.bodies for i in b.inertial]]
    assert np.all(inertial != 0.0)  # every standard inertial parameter is non-trivial
    assert [(j.lower, j.upper) for j in five_bar.joints] == [(1.25, 2.75), (0.39, 1.89)]
    assert five_bar.payload_frame == "tip"


def test_tree_states_keep_the_loop_closed(five_bar):
    q, qd, qdd = five_bar.random_states(30, seed=2)
    st = tree_states(five_bar, q, qd, qdd)
    model = pin.buildModelFromUrdf(URDF)
    data = model.createData()
    a, b = model.getFrameId("tip"), model.getFrameId("tip_2")
    for k in range(len(q)):
        pin.forwardKinematics(model, data, st.q[k], st.v[k], st.a[k])
        pin.updateFramePlacements(model, data)
        world = pin.LOCAL_WORLD_ALIGNED
        assert np.allclose(data.oMf[a].translation, data.oMf[b].translation, rtol=0, atol=1e-12)
        assert np.allclose(pin.getFrameVelocity(model, data, a, world).linear,
                           pin.getFrameVelocity(model, data, b, world).linear, rtol=0, atol=1e-12)
        assert np.allclose(pin.getFrameClassicalAcceleration(model, data, a, world).linear,
                           pin.getFrameClassicalAcceleration(model, data, b, world).linear,
                           rtol=0, atol=1e-10)
    assert np.allclose(st.v[:, [0, 2]], qd, rtol=0, atol=1e-13)
    assert np.allclose(st.a[:, [0, 2]], qdd, rtol=0, atol=1e-12)


@pytest.mark.parametrize("mass", [0.0, 0.8])
def test_idim_rows_agree_with_constrained_forward_dynamics(five_bar, mass):
    """τ_a = W_st χ (+ m W_l) drives the KKT forward dynamics to exactly the q̈ of the rows."""
    q, qd, qdd = five_bar.random_states(25, seed=6)
    chi = nominal_with_drive_terms(five_bar)
    tau = (five_bar.standard_regressor(q, qd, qdd) @ chi).reshape(2, -1).T
    if mass:
        tau += mass * five_bar.observation_block(q, qd, qdd)[-1].T
    qdd_kkt = kkt_accelerations(dict(zip(five_bar.standard_names, chi)), mass,
                                tree_states(five_bar, q, qd, qdd), tau)
    assert np.abs(qdd_kkt - qdd).max() <= 1e-9 * np.abs(qdd).max()


def test_base_parameters(five_bar):
    q, qd, qdd = five_bar.random_states(300, seed=8)
    W = five_bar.standard_regressor(q, qd, qdd)
    s = np.linalg.svd(W, compute_uv=False)
    assert int(np.sum(s > 1e-9 * s[0])) == five_bar.n_b == 23
    chi = nominal_with_drive_terms(five_bar)
    assert np.allclose(five_bar.regressor(q, qd, qdd) @ five_bar.base_values(chi), W @ chi,
                       rtol=0, atol=1e-10 * np.abs(W @ chi).max())
    # m_2 and mx_4 only act through the tip, which both distal links carry: regrouped
    assert "m_2" not in [p.standard for p in five_bar.parameters]
    assert any("m_2" in e for e in five_bar.expressions)


def test_payload_elsewhere_than_the_tip(five_bar):
    elbow = five_bar.with_payload(Payload(0.5, "distal_1"))  # a point mass at the elbow joint
    q, qd, qdd = five_bar.random_states(10, seed=9)
    col, tip = elbow.observation_block(q, qd, qdd)[-1], five_bar.observation_block(q, qd, qdd)[-1]
    assert not np.allclose(col, tip)
    assert np.allclose(elbow.observation_block(q, qd, qdd)[:-1],
                       five_bar.observation_block(q, qd, qdd)[:-1])


def test_parallel_singularity_is_a_singularity_error(five_bar):
    """Both elbows at (0, 0.1732) m, the distal links on top of each other pointing up: the
    actuators no longer hold the passive joints (the tip can turn about the elbows)."""
    q_t = np.array([[np.pi / 3, np.pi / 6, 2 * np.pi / 3, -np.pi / 6]])  # joint_1, _3, _2, _4
    st = TreeStates.empty(1, 4, 4, 2)
    zero = np.zeros((1, 2))
    with pytest.raises(SingularityError, match="parallel singularity") as err:
        five_bar.closure.states(q_t[:, [0, 2]], zero, zero, st, q_t)
    assert "\n" not in str(err.value)


def _mjcf_body(name: str, pos: str, angle: float, inertial: str, inner: str, joint: str,
               rng: str) -> str:
    R = pin.utils.rotate("z", angle)
    if name.startswith("proximal"):
        R = pin.utils.rotate("x", np.pi / 2) @ R
    x, y, z, w = (float(c) for c in pin.Quaternion(R).coeffs())
    return (f'<body name="{name}" pos="{pos}" quat="{w!r} {x!r} {y!r} {z!r}">'
            f'<joint name="{joint}" type="hinge" axis="0 0 1" {rng}/>{inertial}{inner}</body>')


def five_bar_mjcf(assembled: dict[str, float] | None) -> str:
    """The five-bar as MJCF: with ``assembled`` joint values (exactly closed) its q = 0 is that
    configuration and an ``<equality connect>`` closes it; otherwise sites and the YAML's loop."""
    ref = assembled or dict.fromkeys(REFERENCE, 0.0)
    inertial = {  # (pos, mass, fullinertia = ixx iyy izz ixy ixz iyz), as five_bar.urdf
        "proximal_1": ("0.092 0.004 0.015", 0.82, "2.6e-4 3.05e-3 2.95e-3 1.1e-5 -2.4e-5 6.0e-6"),
        "distal_1": ("0.141 -0.003 0.024", 0.47, "1.6e-4 3.72e-3 3.66e-3 -8.0e-6 1.9e-5 -4.0e-6"),
        "proximal_2": ("0.095 -0.005 0.013", 0.85, "2.8e-4 3.12e-3 3.01e-3 -1.3e-5 2.1e-5 -7.0e-6"),
        "distal_2": ("0.138 0.002 -0.021", 0.45, "1.5e-4 3.58e-3 3.53e-3 7.0e-6 -1.7e-5 5.0e-6"),
    }

    def ine(link: str) -> str:
        pos, m, full = inertial[link]
        return f'<inertial pos="{pos}" mass="{m}" fullinertia="{full}"/>'

    site = (lambda n: "") if assembled else (lambda n: f'<site name="{n}" pos="0.3 0 0"/>')
    legs = []
    for i, (x, lim) in enumerate([("-0.1", (1.25, 2.75)), ("0.1", (0.39, 1.89))], 1):
        act, pas = ("joint_1", "joint_3") if i == 1 else ("joint_2", "joint_4")
        rng_a = f'range="{lim[0] - ref[act]!r} {lim[1] - ref[act]!r}"'
        distal = _mjcf_body(f"distal_{i}", "0.2 0 0", ref[pas], ine(f"distal_{i}"),
                            site("tip" if i == 1 else "tip_2"), pas, "")
        legs.append(_mjcf_body(f"proximal_{i}", f"{x} 0 0", ref[act], ine(f"proximal_{i}"),
                               distal, act, rng_a))
    connect = '<connect body1="distal_1" body2="distal_2" anchor="0.3 0 0"/>'
    equality = f"<equality>{connect}</equality>" if assembled else ""
    return (f'<mujoco model="five_bar"><compiler angle="radian"/><worldbody>'
            f'<body name="base_link">{"".join(legs)}</body></worldbody>{equality}</mujoco>')


@pytest.mark.parametrize("assembled", [False, True])
def test_the_same_robot_as_mjcf(five_bar, tmp_path: Path, assembled: bool):
    """MJCF with sites and the YAML's loop, or assembled at q = 0 with its own <equality>: the
    same rows (the assembled one's coordinates are offsets from the reference)."""
    from orthoglide_ident.model.pinocchio_model import PinocchioRobot

    q_ref = five_bar.closure.reference  # exactly closed: MJCF anchors are placed at q = 0
    model = five_bar.model
    exact = {n: float(q_ref[model.joints[model.getJointId(n)].idx_q]) for n in JOINTS}
    (tmp_path / "five_bar.xml").write_text(five_bar_mjcf(exact if assembled else None))
    data = {"name": "five_bar_mjcf", "description": "five_bar.xml",
            "actuated_joints": ["joint_1", "joint_2"], "payload_frame": "distal_1"}
    if not assembled:
        data["loops"] = [{"frame_a": "tip", "frame_b": "tip_2", "type": "point"}]
        data["reference_configuration"] = REFERENCE
    mjcf = PinocchioRobot.from_description(data, tmp_path)
    assert mjcf.standard_names == five_bar.standard_names
    assert np.allclose(mjcf.standard_values(), five_bar.standard_values(), rtol=1e-12, atol=1e-15)
    q, qd, qdd = five_bar.random_states(40, seed=10)
    offset = np.array([exact["joint_1"], exact["joint_2"]]) if assembled else 0.0
    W_m = mjcf.standard_regressor(q - offset, qd, qdd)
    W_u = five_bar.standard_regressor(q, qd, qdd)
    assert np.abs(W_m - W_u).max() <= 1e-10 * np.abs(W_u).max()
    assert mjcf.n_b == five_bar.n_b
