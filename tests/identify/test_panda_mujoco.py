"""A 7-axis MuJoCo plant end to end (issue 48): the example-robot-data Panda, fingers locked,
designed for, simulated and identified (tests/panda_mujoco_plant.py). First that the plant is the
Panda with its fingers where the robot file locks them: MuJoCo's inverse dynamics of the welded
plant against Pinocchio's RNEA of the full URDF (fingers as joints of their own at 0.03 m)."""
from __future__ import annotations

import locked_panda as L
import numpy as np
import pinocchio as pin
import pytest


def full_urdf_torques(truth, q, qd, qdd, finger: float = L.FINGER) -> np.ndarray:
    """τ of the arm joints by Pinocchio on the full URDF (9 joints, fingers at ``finger``), every
    link's inertial the truth's, + armature q̈ + damping q̇ + offset (friction loss left out)."""
    model = pin.buildModelFromUrdf(str(L.urdf_path()))
    model.gravity = pin.Motion(np.array([0.0, 0.0, -truth.gravity]), np.zeros(3))
    inertias = [pin.Inertia.Zero() for _ in range(model.njoints)]
    for link, rb in truth.bodies.items():
        f = model.frames[model.getFrameId(link)]
        inertias[f.parentJoint] += f.placement.act(pin.Inertia(rb.mass, rb.com, rb.inertia))
    for i in range(1, model.njoints):
        model.inertias[i] = inertias[i]
    data, n = model.createData(), len(L.ARM)
    fingers = np.full(2, finger)
    tau = np.array([pin.rnea(model, data, np.r_[a, fingers], np.r_[b, 0, 0], np.r_[c, 0, 0])[:n]
                    for a, b, c in zip(q, qd, qdd)])
    drive = truth.drive_array
    return tau + drive("armature") * qdd + drive("damping") * qd + drive("offset")


def test_the_welded_panda_is_the_full_urdf_with_its_fingers_at_the_locked_opening(tmp_path):
    from orthoglide_sim.arms.description import load_arm
    from orthoglide_sim.arms.plant import MujocoPlant
    from orthoglide_sim.arms.truth import load_truth

    arm = load_arm(L.robot_file(tmp_path))
    assert arm.joint_names == L.ARM
    assert arm.locked == dict.fromkeys(L.FINGERS, L.FINGER)  # the mimic finger follows
    truth = load_truth(arm)
    plant = MujocoPlant(truth)
    rng = np.random.default_rng(0)
    q, qd, qdd = rng.uniform(-1, 1, (3, 20, 7))
    got = plant.inverse_dynamics(q, qd, qdd)
    want = full_urdf_torques(truth, q, qd, qdd)
    assert np.abs(got - want).max() < 1e-9 * np.abs(want).max(), np.abs(got - want).max()
    # fingers 1 cm off (a weld misplaced; 15 g each) move the torques far beyond that agreement
    moved = full_urdf_torques(truth, q, qd, qdd, L.FINGER - 0.01) - got
    assert np.abs(moved).max() > 1e3 * np.abs(got - want).max()


@pytest.mark.slow
def test_the_panda_designed_simulated_identified_within_three_honest_sigma(tmp_path):
    """excite design (2 periods, a short search), 10 s unloaded + 10 s with 2 kg on MuJoCo,
    IDIM-TLS: every gain determined, within 0.2 % and 3 σ of the plant's, which the nominal
    gains miss by 2-6 %."""
    import panda_mujoco_plant as P

    run = P.end_to_end(tmp_path, P.DESIGN_FAST, seed=0)
    assert run.saturated_ticks == 0  # the drives stayed within their current limits
    assert np.all(np.abs(run.nominal / run.truth - 1) > 0.02)
    assert run.determined.all(), run.warnings
    assert np.abs(run.error).max() < 0.002, run.error
    assert np.all(np.abs(run.error) <= 3 * run.rel_std), run.error / run.rel_std
