"""The coupled-wrist UR5 plant (issue 33): six motors behind N (gears of both signs, motor 6 on
q5 + q6), motor-side rotor inertia, friction and gains, integrated by MuJoCo; checked against
Pinocchio's RNEA of the same rigid bodies, and its records on both signal sides."""
from __future__ import annotations

import xml.etree.ElementTree as ET

import mujoco
import numpy as np
import pinocchio as pin
import pytest
import yaml

from orthoglide_ident.bags import read_bag
from orthoglide_ident.errors import ConfigError
from orthoglide_sim.arms.description import load_arm
from orthoglide_sim.arms.pinocchio_truth import truth_model
from orthoglide_sim.arms.transmission_urdf import (
    SIMPLE,
    read_simple_transmissions,
    write_simple_transmission_robot,
)
from orthoglide_sim.coupled.check import torque_balance
from orthoglide_sim.coupled.plant import CoupledPlant
from orthoglide_sim.coupled.record import (
    current_limits,
    simulate_coupled,
    write_coupled_bag,
    write_robot_files,
)
from orthoglide_sim.coupled.truth import REDUCTION, default_coupled_truth, simple_transmission_truth

# rad/s at the motor: outside this band every motor's soft Coulomb friction (mujoco_plant's
# FRICTION_TIMECONST on the tendon) has reached fs; measured: it turns through zero within
# 0.1 rad/s of motor velocity (0.002-0.003 rad/s at the joint)
SLIDING = 0.5
# relative to the largest joint torque: round-off of two implementations (measured 1e-15)
BALANCE_TOL = 1e-12


@pytest.fixture(scope="module")
def truth():
    return default_coupled_truth()


@pytest.fixture(scope="module", params=[None, "2.0"], ids=["unloaded", "loaded_2kg"])
def rec(request, truth):
    return simulate_coupled(0.6, payload=request.param,
                            trajectory="exciting1" if request.param is None else "exciting2",
                            seed=3, truth=truth)


def test_truth_is_the_issue_drive_chain(truth):
    assert np.array_equal(truth.reduction, REDUCTION)
    assert truth.reduction[5, 4] == truth.reduction[5, 5] == 32 and truth.reduction[3, 3] < 0
    assert abs(np.linalg.det(truth.reduction)) > 1.0
    g, g0 = truth.motor_array("gain"), truth.motor_array("nominal_gain")
    assert np.all(np.abs(g / g0 - 1) > 0.02)  # the true gains are off the drive's nominal ones
    for key in ("inertia", "viscous", "coulomb"):
        assert np.all(truth.motor_array(key) > 0)
    # the joints carry nothing: armature, friction and offset are the motors'
    assert all(
        d.armature == d.damping == d.frictionloss == d.offset == 0
        for d in truth.rigid.drives.values()
    )


def test_mass_matrix_holds_the_rotors_through_n(truth):
    """MuJoCo's joint mass matrix = the rigid arm's (Pinocchio CRBA) + Nᵀ diag(Ia) N."""
    plant = CoupledPlant(truth)
    model, _ = truth_model(truth.rigid)
    data = model.createData()
    q = np.array([0.3, -1.9, 1.1, -1.4, -1.7, 0.5])
    plant.reset(q, np.zeros(6))
    M = np.zeros((6, 6))
    mujoco.mj_fullM(plant.model, plant.data, M)
    M_rigid = pin.crba(model, data, q)
    M_rigid = np.triu(M_rigid) + np.triu(M_rigid, 1).T
    N = truth.reduction
    assert np.allclose(
        M, M_rigid + N.T @ np.diag(truth.motor_array("inertia")) @ N, rtol=0, atol=1e-12
    )


def test_motor_velocities_are_n_times_the_joint_velocities(rec):
    N = rec.truth.reduction
    scale = np.abs(rec.qd_motor_true).max()
    assert scale > 10.0  # the motors turn
    assert np.abs(rec.qd_motor_true - rec.qd_true @ N.T).max() <= 1e-12 * scale
    # the coupled motor turns with q5 + q6
    assert np.allclose(
        rec.qd_motor_true[:, 5], 32 * (rec.qd_true[:, 4] + rec.qd_true[:, 5]), rtol=0, atol=1e-10
    )


def test_torque_balance_equals_pinocchio_rnea(rec):
    bal = torque_balance(rec)
    worst, share = bal.sliding_error(SLIDING)
    assert share > 0.6 and worst <= BALANCE_TOL
    # near zero velocity the soft friction is inside its Coulomb bound, never beyond it
    assert np.all(np.abs(bal.friction) <= bal.coulomb * (1 + 1e-9) + BALANCE_TOL * bal.tau_max)
    assert np.abs(bal.error).max() > 1e-3  # (and there it is not fs sign q̇_m: the band is real)


def test_joint_and_motor_positions_agree_through_n(rec):
    t, N = rec.truth, rec.truth.reduction
    assert (
        np.abs(rec.q_motor - (rec.q_joint @ N.T + t.motor_offset)).max()
        < 1e-12 * np.abs(rec.q_motor).max()
    )
    # the encoders read the true motor angles to half a count; the joint side is N⁻¹ of that
    half = t.encoder_resolution / 2
    assert np.all(np.abs(rec.q_motor - t.motor_positions(rec.q_true)) <= half * (1 + 1e-6))
    assert np.all(np.abs(rec.q_joint - rec.q_true) <= np.abs(np.linalg.inv(N)) @ half * (1 + 1e-6))
    counts = rec.q_motor / t.encoder_resolution  # whole counts of each motor's encoder
    assert np.allclose(counts, np.round(counts), rtol=0, atol=1e-6)
    assert np.all(np.abs(rec.q_true - rec.q_ref).max(axis=0) < 2e-3)  # it tracks the reference


def test_a_negative_reduction_reverses_the_motor(rec, truth):
    dq4, dm4 = np.diff(rec.q_true[:, 3]), np.diff(rec.q_motor[:, 3])
    assert np.corrcoef(dq4, dm4)[0, 1] < -0.999
    assert np.sign(rec.qd_motor_true[:, 3]).tolist() == np.sign(-rec.qd_true[:, 3]).tolist()
    # a positive current on motor 4 alone accelerates wrist_1 backwards (MuJoCo's forward dynamics)
    plant, q, qd = CoupledPlant(truth), rec.q_true[100], rec.qd_true[100]
    base = plant.acceleration(q, qd, rec.current[100])
    push = plant.acceleration(q, qd, rec.current[100] + np.eye(6)[3])
    assert push[3] - base[3] < -1.0
    # and motor 6 moves both wrist joints: torques Nᵀ τ_m = 32 g6 on wrist_2 and wrist_3
    push6 = plant.acceleration(q, qd, rec.current[100] + np.eye(6)[5]) - base
    assert np.abs(push6[4]) > 1e-3 and np.abs(push6[5]) > 1e-3


def test_current_limits_and_noise(rec, truth):
    assert rec.saturated_ticks == 0
    assert np.all(np.abs(rec.v_tau).max(axis=0) < current_limits(truth))
    rms = np.sqrt(np.mean(rec.v_tau ** 2, axis=0))
    assert np.all(rec.current_noise_std > 0.001 * rms) and np.all(
        rec.current_noise_std < 0.02 * rms
    )


def test_bags_on_both_sides_agree_through_n(rec, tmp_path):
    t, N = rec.truth, rec.truth.reduction
    joint = read_bag(write_coupled_bag(tmp_path / "joint", rec, "joint"))
    motor = read_bag(write_coupled_bag(tmp_path / "actuator", rec, "actuator"))
    for bag in (joint, motor):
        assert bag.positions.names == t.actuators
        assert np.array_equal(bag.current.current, rec.v_tau)  # per motor, under its joint's name
        assert bag.tags.payload_mass == rec.payload_mass
    qj, qm = joint.positions.position, motor.positions.position
    assert np.abs(qm - (qj @ N.T + t.motor_offset)).max() < 1e-12 * np.abs(qm).max()
    custom = yaml.safe_load((tmp_path / "actuator" / "metadata.yaml").read_text())[
        "rosbag2_bagfile_information"]["custom_data"]
    assert (
        custom["orthoglide.position_side"] == "actuator"
        and custom["orthoglide.effort_side"] == "actuator"
    )
    with pytest.raises(ConfigError, match="position_side"):
        write_coupled_bag(tmp_path / "x", rec, "motor")
    # joint-side efforts: Nᵀ (g_nominal v), N·m, tagged as torques; back to the currents exactly
    torque = read_bag(write_coupled_bag(tmp_path / "torque", rec, "joint", effort_side="joint"))
    assert torque.tags.effort_unit == "torque"
    back = np.linalg.solve(N.T, torque.current.current.T).T / t.motor_array("nominal_gain")
    assert np.abs(back - rec.v_tau).max() < 1e-12 * np.abs(rec.v_tau).max()


def test_robot_files_carry_the_transmission(truth, tmp_path):
    joint_yaml, motor_yaml = write_robot_files(tmp_path, truth)
    for path, side in ((joint_yaml, "joint"), (motor_yaml, "actuator")):
        data = yaml.safe_load(path.read_text())
        tr = data["transmission"]
        assert np.array_equal(np.array(tr["reduction"]), truth.reduction)
        assert np.array_equal(np.array(tr["offset"]), truth.motor_offset)
        assert tr["actuators"] == list(truth.actuators) == data["actuated_joints"]
        assert tr["position_side"] == side and tr["effort_side"] == "actuator"
        assert np.array_equal(data["nominal_gains"], truth.motor_array("nominal_gain"))
        assert (tmp_path / data["description"]).is_file()


def test_simple_transmissions_with_negative_reductions(tmp_path):
    """One motor per joint behind diag(32, -32, 45, -48, 45, -32), written as ros2_control
    SimpleTransmissions in the URDF: read back, q_j = q_a / n + x holds on the bags of both
    sides."""
    truth = simple_transmission_truth()
    urdf, robot_yaml = write_simple_transmission_robot(tmp_path, truth)
    text = urdf.read_text()
    assert text.count(SIMPLE) == 6 and "<mechanical_reduction>-48.0</mechanical_reduction>" in text
    N, offset = read_simple_transmissions(text, truth.arm.joint_names)
    assert np.array_equal(N, truth.reduction) and np.allclose(
        offset, truth.motor_offset, rtol=0, atol=1e-15
    )
    arm = load_arm(str(robot_yaml))  # the URDF still loads as the same serial arm
    assert arm.joint_names == truth.arm.joint_names
    pin.buildModelFromXML(text)
    rec = simulate_coupled(0.3, trajectory="exciting2", seed=5, truth=truth)
    joint = read_bag(write_coupled_bag(tmp_path / "joint", rec, "joint")).positions.position
    motor = read_bag(write_coupled_bag(tmp_path / "actuator", rec, "actuator")).positions.position
    n = np.diag(N)
    x = np.array(
        [float(e.findtext("offset")) for e in ET.fromstring(text).iter("joint") if e.get("role")]
    )
    assert np.abs(joint - (motor / n + x)).max() < 1e-12
    for k in np.flatnonzero(n < 0):  # those motors turn against their joints
        assert np.corrcoef(np.diff(joint[:, k]), np.diff(motor[:, k]))[0, 1] < -0.999
    assert np.abs(torque_balance(rec).sliding_error(SLIDING)[0]) <= BALANCE_TOL
    with pytest.raises(ConfigError, match="diagonal"):
        write_simple_transmission_robot(tmp_path, default_coupled_truth())


@pytest.mark.slow
@pytest.mark.parametrize("make_truth", [default_coupled_truth, simple_transmission_truth])
def test_the_60_s_records_stay_in_the_workspace_unsaturated(make_truth):
    truth = make_truth()
    for payload, trajectory in ((None, "exciting1"), ("2.0", "exciting2")):
        rec = simulate_coupled(60.0, payload=payload, trajectory=trajectory, seed=1, truth=truth)
        assert rec.saturated_ticks == 0 and np.all(rec.tracking_rms < 1e-3)
