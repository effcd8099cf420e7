"""The five-bar's MuJoCo plant: the truth's inertials and friction kept, the loop a stiff MuJoCo
equality constraint, MuJoCo's constrained dynamics equal to Pinocchio's constraintDynamics of
the same truth to the constraint's softness, and that equal to the product's rows."""
from __future__ import annotations

import mujoco
import numpy as np
import pytest

from orthoglide_ident.errors import ConfigError, WorkspaceError
from orthoglide_ident.model.registry import load_robot
from orthoglide_ident.model.robot import Payload
from orthoglide_sim.arms import simulator as asim
from orthoglide_sim.arms.excitation import designed_trajectory
from orthoglide_sim.arms.plant import PAYLOAD_BODY, TIMESTEP
from orthoglide_sim.arms.truth import RigidBody
from orthoglide_sim.chains.description import is_closed_chain, load_chain
from orthoglide_sim.chains.pinocchio_truth import (
    ChainDynamics,
    rigid_loop_currents,
    standard_vector,
)
from orthoglide_sim.chains.plant import LOOP_SOLIMP, ChainPlant
from orthoglide_sim.chains.record import simulate_chain
from orthoglide_sim.chains.truth import apply_chain_overrides, default_chain_truth, load_chain_truth

PAYLOADS = (None, "1.0", "0.5")


@pytest.fixture(scope="module")
def truth():
    return default_chain_truth(load_chain("five_bar"))


@pytest.fixture(scope="module")
def robot():
    return load_robot("five_bar")


def payload_of(truth, name) -> Payload | None:
    p = truth.payload(name)
    if p is None:
        return None
    I = p.body.inertia
    return Payload(
        p.mass, p.frame, tuple(p.body.com), (I[0, 0], I[0, 1], I[0, 2], I[1, 1], I[1, 2], I[2, 2])
    )


def closed_states(plant: ChainPlant, robot, n: int, seed: int):
    """n random regular states of the product's model, assembled by the plant (MuJoCo), and
    random actuated torques (N·m) of the size of the five-bar's."""
    q, qd, _ = robot.random_states(n, seed)
    tau = np.random.default_rng(seed + 1).normal(0.0, 3.0, q.shape)
    return q, qd, tau


def mujoco_forward(plant: ChainPlant, q, qd, tau) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """MuJoCo's constrained accelerations (friction loss off) at the plant's assembled state."""
    plant.reset(q, qd)
    d = plant.data
    d.qfrc_applied[:] = -plant.tree_offset
    d.qfrc_applied[plant.dof] += tau
    mujoco.mj_forward(plant.model, d)
    return d.qpos.copy(), d.qvel.copy(), d.qacc.copy()


def test_truth_every_standard_parameter_non_trivial_and_off_nominal(truth):
    chain = truth.arm
    for j in chain.joints + chain.passive:  # the 4 moving links
        urdf = chain.inertials[j.child]
        nominal = RigidBody(urdf.mass, urdf.com, urdf.inertia).standard()
        true = truth.bodies[j.child].standard()
        truth.bodies[j.child].check(j.child)
        size = {(0, 6): np.abs(nominal[:6]).max(), (6, 9): 0.01 * urdf.mass, (9, 10): urdf.mass}
        for (a, b), s in size.items():
            assert np.all(np.abs(true[a:b]) > 1e-3 * s), (j.child, true[a:b])
            moved = np.abs(true[a:b] - nominal[a:b])
            assert np.all(moved > 0.01 * np.maximum(np.abs(nominal[a:b]), 0.1 * s)), (j.child, a)
    off = truth.drive_array("g_tau") / chain.nominal_gains - 1
    assert (
        np.all(np.abs(off) > 0.02)
        and np.all(np.abs(off) < 0.06)
        and len(set(np.round(off, 6))) == 2
    )
    for key in ("armature", "damping", "frictionloss", "offset"):
        assert np.all(truth.drive_array(key) != 0), key
    for key in ("damping", "frictionloss", "offset"):
        assert np.all(truth.passive_array(key) != 0), key


@pytest.mark.parametrize("payload", PAYLOADS)
def test_mujoco_keeps_the_truth_and_closes_the_loop_with_sites(truth, payload):
    plant = ChainPlant(truth, truth.payload(payload))
    errs = plant.inertial_errors()
    assert set(truth.bodies) <= set(errs) and (PAYLOAD_BODY in errs) == (payload is not None)
    assert max(errs.values()) < 1e-12, errs
    m = plant.model
    for dof, values in ((plant.dof, truth.drive_array), (plant.passive_dof, truth.passive_array)):
        for key in ("damping", "frictionloss"):
            field = m.dof_damping if key == "damping" else m.dof_frictionloss
            assert np.array_equal(field[dof], values(key)), key
    assert np.array_equal(m.dof_armature[plant.dof], truth.drive_array("armature"))
    assert np.all(m.dof_armature[plant.passive_dof] == 0)  # no rotor on a passive elbow
    assert not m.jnt_limited.any() and m.ngeom == 0
    # the loop: one connect between two sites (not anchors), as stiff as MuJoCo allows
    assert m.neq == 1 and m.eq_type[0] == mujoco.mjtEq.mjEQ_CONNECT
    assert m.eq_objtype[0] == mujoco.mjtObj.mjOBJ_SITE
    assert np.allclose(m.eq_solimp[0], LOOP_SOLIMP) and m.eq_solref[0][0] == 2 * TIMESTEP
    # the working mode: elbows out, tip above the base, loop closed to round-off
    plant.reset(np.array([2.05, 1.09]), np.zeros(2))
    assert plant.loop_error() < 1e-12
    q_t = plant.q_tree
    assert q_t[1] < 0 < q_t[3]  # joint_3 (elbow of leg 1) bends one way, joint_4 the other
    tip = plant.data.site_xpos[0]
    assert tip[2] > 0.3 and abs(tip[0]) < 0.1


@pytest.mark.parametrize("payload", (None, "1.0"))
def test_exact_constrained_dynamics_equals_the_models_rows(truth, robot, payload):
    """Pinocchio's constraintDynamics of the truth (rigid loop) at the plant's states: the
    product's standard rows times the truth's standard parameters (with the payload's known
    column) give back the applied torques, to round-off. Friction loss off on both sides."""
    plant, dyn = (
        ChainPlant(truth, truth.payload(payload)),
        ChainDynamics(truth, truth.payload(payload)),
    )
    q, qd, tau = closed_states(plant, robot, 40, seed=5)
    qdd = np.empty_like(q)
    for k in range(len(q)):
        plant.reset(q[k], qd[k])
        qdd[k] = dyn.forward(plant.data.qpos.copy(), plant.data.qvel.copy(), tau[k])[plant.dof]
    chi = standard_vector(truth, robot)
    chi[[k for k, n in enumerate(robot.standard_names) if n.startswith("fs_")]] = 0.0
    model = robot if payload is None else robot.with_payload(payload_of(truth, payload))
    rows = (model.standard_regressor(q, qd, qdd) @ chi).reshape(2, -1).T
    if payload is not None:
        rows += truth.payload(payload).mass * model.payload_mass_column(q, qd, qdd).reshape(2, -1).T
    assert np.abs(rows - tau).max() <= 1e-9 * np.abs(tau).max()


def _softness_error(truth, robot, payload, seed=5, n=40, solimp=None) -> np.ndarray:
    """Per state: |Gᵀ M G (q̈_a MuJoCo - q̈_a exact)| / max|τ| (the torque the softness is worth)."""
    plant, dyn = (
        ChainPlant(truth, truth.payload(payload)),
        ChainDynamics(truth, truth.payload(payload)),
    )
    if solimp is not None:
        plant.model.eq_solimp[0] = solimp
    plant.model.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_FRICTIONLOSS)
    q, qd, tau = closed_states(plant, robot, n, seed)
    out = np.empty(n)
    for k in range(n):
        qpos, qvel, a_mj = mujoco_forward(plant, q[k], qd[k], tau[k])
        a_pin = dyn.forward(qpos, qvel, tau[k])
        M = np.zeros((plant.model.nv, plant.model.nv))
        mujoco.mj_fullM(plant.model, plant.data, M)
        G = plant.rate_map(qpos)
        out[k] = np.abs(G.T @ M @ G @ (a_mj - a_pin)[plant.dof]).max() / np.abs(tau[k]).max()
    return out


@pytest.mark.parametrize("payload", (None, "1.0"))
def test_mujoco_constrained_dynamics_equals_pinocchio_to_the_loops_softness(truth, robot, payload):
    """MuJoCo's loop is a soft constraint (impedance d = 0.9999, its maximum): at a closed state
    its accelerations differ from the rigid loop's by ~(1 - d) times the conditioning of the
    loop's J M⁻¹ Jᵀ. Measured as a torque on the actuated joints: median 8e-5 (unloaded) and
    1e-3 (1 kg at the tip) of the applied torque, at most 3e-4 and 2.5e-3, i.e. 0.5-14 (1 - d);
    softening the loop tenfold (d = 0.999) makes it tenfold larger at every state (to 1 %):
    the softness is the whole difference."""
    err = _softness_error(truth, robot, payload)
    assert np.median(err) < (2e-4 if payload is None else 2e-3)
    assert err.max() < (1e-3 if payload is None else 5e-3)
    softer = _softness_error(truth, robot, payload, solimp=(0.999, 0.999, 0.001, 0.5, 2.0))
    assert np.allclose(softer / err, 10.0, rtol=0.05)


def test_the_soft_loop_costs_the_identification_nothing(truth):
    """Where the identification sees the loop: the currents the PID needs to drive MuJoCo's
    five-bar and Pinocchio's rigid one along the same 1 kg reference (noise, friction loss and
    encoder quantisation off: sign() against MuJoCo's smooth friction, or one count more or
    less — ~2 noise σ through the PID — would differ by themselves). Measured: 4e-5 to 2e-4
    of the current noise's σ rms, 5e-3 at most; the bar is 1e-2 (rms) and 5e-2 (max)."""
    off = {"joints": {j: {"frictionloss": 0.0} for j in truth.arm.joint_names},
           "passive_joints": {j: {"frictionloss": 0.0} for j in truth.arm.passive_names},
           "encoder_counts": 2**48}
    t = apply_chain_overrides(truth, off)
    rec = simulate_chain(1.5, payload="1.0", trajectory="exciting2", truth=t, noise=False)
    ref = designed_trajectory(t.arm, "exciting2").evaluate(np.arange(len(rec.q)) * asim.TICK)
    rigid = rigid_loop_currents(t, rec.payload, *ref)
    sigma = 0.005 * np.sqrt(np.mean(rec.v_tau**2, axis=0))  # the records' current noise
    diff = (rec.v_tau - rigid) / sigma
    print("soft - rigid loop currents / noise σ: rms", np.sqrt(np.mean(diff**2, axis=0)),
          "max", np.abs(diff).max(0))
    assert np.all(np.sqrt(np.mean(diff**2, axis=0)) < 1e-2) and np.abs(diff).max() < 5e-2
    assert rec.loop_error.max() < 1e-7


def test_inverse_dynamics_inverts_the_plant(truth, robot):
    """inverse_dynamics (MuJoCo's forward dynamics inverted) gives back the torque that
    produced MuJoCo's accelerations; with friction it adds Gᵀ fs sign(q̇_t)."""
    plant = ChainPlant(truth, truth.payload("0.5"))
    q, qd, tau = closed_states(plant, robot, 10, seed=2)
    plant.model.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_FRICTIONLOSS)
    qdd = np.array(
        [mujoco_forward(plant, q[k], qd[k], tau[k])[2][plant.dof] for k in range(len(q))]
    )
    plant.model.opt.disableflags &= ~int(mujoco.mjtDisableBit.mjDSBL_FRICTIONLOSS)
    got = plant.inverse_dynamics(q, qd, qdd)
    assert np.abs(got - tau).max() < 1e-9 * np.abs(tau).max()  # measured 6e-11
    fs = plant.inverse_dynamics(q, qd, qdd, friction=True) - got
    for k in range(len(q)):
        plant.reset(q[k], qd[k])
        G = plant.rate_map(plant.data.qpos.copy())
        expected = G.T @ (plant.model.dof_frictionloss * np.sign(plant.data.qvel))
        assert np.allclose(fs[k], expected, rtol=1e-9, atol=1e-12)


def test_a_broken_loop_or_a_folded_elbow_stops_the_robot(truth):
    plant = ChainPlant(truth)
    plant.reset(np.array([2.05, 1.09]), np.zeros(2))
    plant.model.eq_active0[0] = 0
    plant.data.eq_active[0] = 0  # the pin at the tip gives way: the two legs fall apart
    with pytest.raises(WorkspaceError, match="loops of five_bar broke"):
        for _ in range(200):
            plant.step(np.zeros(2), asim.SUBSTEPS)
    plant = ChainPlant(truth)
    plant.reset(np.array([1.45, 1.69]), np.zeros(2))  # proximal links folded towards each other
    with pytest.raises(WorkspaceError, match=r"passive joint joint_\d = .* left its limits"):
        plant.step(np.zeros(2), asim.SUBSTEPS)


def test_yaml_overrides_reach_the_plant(truth):
    t = apply_chain_overrides(truth, {"joints": {"joint_1": {"g_tau": 0.55}},
                                      "passive_joints": {"joint_4": {"frictionloss": 0.05}},
                                      "current_noise": 0.01})
    assert t.drives["joint_1"].g_tau == 0.55 and t.passive["joint_4"].frictionloss == 0.05
    assert t.passive["joint_4"].damping == truth.passive["joint_4"].damping
    plant = ChainPlant(t)
    assert plant.model.dof_frictionloss[plant.passive_dof[1]] == 0.05
    assert t.current_noise_fraction == 0.01
    loaded = load_chain_truth(truth.arm, "config/five_bar_plant.yaml")
    for key in ("armature", "damping", "frictionloss", "offset", "g_tau"):
        assert np.allclose(loaded.drive_array(key), truth.drive_array(key), rtol=1e-12, atol=0), key
    for key in ("damping", "frictionloss", "offset"):
        assert np.array_equal(loaded.passive_array(key), truth.passive_array(key)), key


@pytest.mark.parametrize("data, reason", [
    ({"passive_joints": {"joint_1": {"damping": 1.0}}}, "not a passive joint"),
    ({"passive_joints": {"joint_3": {"armature": 1.0}}}, "mapping of damping"),
    ({"passive_joints": {"joint_3": {"damping": -1.0}}}, "out of range"),
    ({"joints": {"joint_3": {"damping": 1.0}}}, "not an actuated joint"),
    ({"bodies": {"tip": {"mass": 1.0}}}, "no link of positive mass"),
])
def test_bad_overrides_get_a_one_line_reason(truth, data, reason):
    with pytest.raises(ConfigError, match=reason) as exc:
        apply_chain_overrides(truth, data, "five_bar.yaml")
    assert "\n" not in str(exc.value)


def test_description_of_the_closed_chain():
    chain = load_chain("five_bar")
    assert chain.joint_names == ("joint_1", "joint_2") and chain.passive_names == (
        "joint_3",
        "joint_4",
    )
    assert chain.tree_joints == ("joint_1", "joint_3", "joint_2", "joint_4")
    assert [(lp.frame_a, lp.frame_b, lp.kind) for lp in chain.loops] == [("tip", "tip_2", "point")]
    assert chain.payload_frame == "tip" and np.allclose(chain.nominal_gains, 0.5)
    assert is_closed_chain("five_bar") and not is_closed_chain("ur5")
    with pytest.raises(ConfigError, match="no loops"):
        load_chain("ur5")
