"""Does an identified MJCF (model/mjcf_out.py) move as the identified model? MuJoCo's own inverse
dynamics (``mj_inverse``; friction loss, contacts and limits off) against the model's torques
(Pinocchio's standard regressor times χ_st, Coulomb friction and torque offsets aside: they have
no smooth MJCF term), relative rms per actuator. One check for the tests, the CLI's users and the
demos (``make demo-ros2-control``'s verdict); the issue's bar is 1 % rms per joint.

    rms = inverse_dynamics_rms(Path("identified.xml").read_text(), robot, chi_st, q, qd, qdd)
"""
from __future__ import annotations

import numpy as np

RMS_BAR = 0.01  # the identified MJCF's inverse dynamics vs the identified model, rms per joint
NOT_SMOOTH = ("fs_", "tauoff_")  # Coulomb friction and the offset: no term of mj_inverse


def model_torques(robot, chi_st: np.ndarray, q, qd, qdd) -> np.ndarray:
    """(m, n) actuator-side torques of the model at actuator-side states, Coulomb friction and
    offsets aside (τ = W_st(q, q̇, q̈) χ_st, eq. 20's rigid and drive terms)."""
    rigid = np.array(chi_st, float)
    rigid[[i for i, n in enumerate(robot.standard_names) if n.startswith(NOT_SMOOTH)]] = 0.0
    return (robot.standard_regressor(q, qd, qdd) @ rigid).reshape(robot.n_joints, -1).T


def mujoco_torques(text: str, joints, q, qd, qdd) -> np.ndarray:
    """(m, n) generalized forces of ``mj_inverse`` on the MJCF ``text`` at joint-side states."""
    import mujoco

    m = mujoco.MjModel.from_xml_string(text)
    off = mujoco.mjtDisableBit
    m.opt.disableflags |= off.mjDSBL_FRICTIONLOSS | off.mjDSBL_CONTACT | off.mjDSBL_LIMIT
    d = mujoco.MjData(m)
    ids = [m.joint(j).id for j in joints]
    qa, va = m.jnt_qposadr[ids], m.jnt_dofadr[ids]
    out = np.empty((len(q), len(ids)))
    for k in range(len(q)):
        d.qpos[qa], d.qvel[va], d.qacc[va] = q[k], qd[k], qdd[k]
        mujoco.mj_inverse(m, d)
        out[k] = d.qfrc_inverse[va]
    return out


def rms_error(ref: np.ndarray, got: np.ndarray) -> np.ndarray:
    """(n,) rms of ``got - ref`` relative to the rms of ``ref``, per column."""
    return np.sqrt(np.mean((got - ref) ** 2, axis=0) / np.mean(ref ** 2, axis=0))


def inverse_dynamics_rms(text: str, robot, chi_st: np.ndarray, q, qd, qdd) -> np.ndarray:
    """(n,) relative rms per actuator of the MJCF's inverse dynamics against the model's, at
    the robot's (actuator-side) states; behind a transmission the joint-side forces are taken
    back to the motors (τ_j = Nᵀ τ_m)."""
    t = robot.transmission
    ref = model_torques(robot, chi_st, q, qd, qdd)
    if t is None:
        return rms_error(ref, mujoco_torques(text, list(robot.joint_names), q, qd, qdd))
    tau_j = mujoco_torques(text, list(t.joints), t.to_joint_position(q), t.to_joint_rate(qd),
                           t.to_joint_rate(qdd))
    return rms_error(ref, np.linalg.solve(np.asarray(t.N, float).T, tau_j.T).T)
