"""The truth of the simulated UR5 with an industrial drive chain: six motors behind gears of both
signs, the last one turning with q5 + q6 (a coupled wrist, as on many Stäubli, KUKA and ABB
wrists; issue 33). What the identification is meant to find, kept apart from it.

Drive chain (ros2_control's convention, the robot YAML's ``transmission.reduction``):

    q_m = N q_j + offset          motor positions (rad), N the reduction matrix (REDUCTION)
    q̇_m = N q̇_j                   motor velocities
    τ_j = Nᵀ τ_m                  joint torques from the motor torques

Each motor m has its own current → motor torque gain g_m (τ_m = g_m v_m, N·m/A at the motor
shaft), rotor inertia Ia_m (kg·m²), viscous fv_m (N·m·s/rad) and Coulomb fs_m (N·m) friction
on ITS velocity q̇_m, and an offset torque off_m (N·m). Reflected to the joints these are
Nᵀ diag(Ia) N (a coupled motor's rotor inertia couples q5 and q6), Nᵀ diag(fv) N, ...: the
joints themselves carry no armature or friction here.

The links and payloads are arm_truth's UR5 (its perturbed rigid bodies); the motors' numbers are
the UR5 table's joint-side values brought to the motor shaft (armature / n², damping / n²,
friction / |n|, gain / |n|) and then set apart, the coupled motor's Coulomb friction 2.0 N·m
at the joint (0.0625 N·m at the motor) and motor 5's 3.0 N·m (the issue's peer figures).

Units: rad, kg·m², N·m·s/rad, N·m, N·m/A, all on the motor shaft unless said otherwise.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from orthoglide_sim.arms.description import ArmDescription, load_arm
from orthoglide_sim.arms.truth import (
    CURRENT_NOISE_FRACTION,
    ArmPayload,
    ArmTruth,
    JointDrive,
    default_truth,
)

# N: motor velocity = N · joint velocity (rows: motors, columns: shoulder_pan ... wrist_3)
REDUCTION = np.array([[32, 0, 0, 0, 0, 0],
                      [0, 32, 0, 0, 0, 0],
                      [0, 0, 45, 0, 0, 0],
                      [0, 0, 0, -48, 0, 0],
                      [0, 0, 0, 0, 45, 0],
                      [0, 0, 0, 0, 32, 32]], dtype=float)
# A SimpleTransmission arm (ros2_control): one motor per joint, reductions of both signs
SIMPLE_REDUCTION = np.diag([32.0, -32.0, 45.0, -48.0, 45.0, -32.0])
# rad, motor side: where each motor's encoder reads zero (q_m = N q_j + offset)
MOTOR_OFFSET = np.array([0.4, -1.1, 2.3, -0.7, 1.6, -2.9])
MOTOR_ENCODER_COUNTS = 2**16  # counts per motor revolution (a 16-bit motor encoder)
# per motor: (rotor inertia Ia kg·m², viscous fv N·m·s/rad, Coulomb fs N·m, offset N·m,
# nominal gain N·m/A (the drive's configured torque constant), true gain / nominal gain)
MOTORS: tuple[tuple[float, float, float, float, float, float], ...] = (
    (3.4e-4, 2.34e-3, 0.159, 0.013, 0.40, 1.042),
    (3.2e-4, 2.83e-3, 0.181, -0.017, 0.40, 0.968),
    (1.33e-4, 9.4e-4, 0.093, 0.0069, 0.29, 1.031),
    (4.3e-5, 2.7e-4, 0.030, -0.0025, 0.19, 0.957),
    (4.5e-5, 2.7e-4, 0.067, 0.0020, 0.21, 1.048),
    (8.5e-5, 5.0e-4, 0.0625, -0.0022, 0.29, 0.975),
)


@dataclass(frozen=True)
class MotorDrive:
    """One motor: rotor inertia (kg·m²), viscous (N·m·s/rad) and Coulomb (N·m) friction on its
    own velocity, offset torque (N·m), nominal and true current → torque gains (N·m/A)."""

    inertia: float
    viscous: float
    coulomb: float
    offset: float
    nominal_gain: float
    gain: float


@dataclass(frozen=True)
class CoupledTruth:
    """The rigid arm (``rigid``: arm_truth's bodies and payloads, joints without drive terms),
    the reduction N, the motor offsets and drives; motors named after the joint of their row
    (``actuators``), as a hardware that reports each motor under its joint's index name."""

    rigid: ArmTruth
    reduction: np.ndarray  # (n, n) N
    motor_offset: np.ndarray  # (n,) rad
    motors: tuple[MotorDrive, ...]
    current_noise_fraction: float = CURRENT_NOISE_FRACTION
    encoder_counts: int = MOTOR_ENCODER_COUNTS
    name: str = "ur5_coupled_wrist"  # the simulated robot, in its bags' orthoglide.sim.robot

    @property
    def arm(self) -> ArmDescription:
        return self.rigid.arm

    @property
    def actuators(self) -> tuple[str, ...]:
        return self.arm.joint_names

    def motor_array(self, key: str) -> np.ndarray:
        """(n,) one MotorDrive field over the motors in order, e.g. "gain"."""
        return np.array([getattr(m, key) for m in self.motors])

    @property
    def encoder_resolution(self) -> np.ndarray:
        """(n,) motor encoder step, rad at the motor shaft."""
        return np.full(len(self.motors), 2.0 * math.pi / self.encoder_counts)

    def payload(self, name: str | float | None) -> ArmPayload | None:
        return self.rigid.payload(name)

    # the drive chain ---------------------------------------------------------------------
    def motor_positions(self, q: np.ndarray) -> np.ndarray:
        """(..., n) q_m = N q_j + offset for joint positions (..., n)."""
        return np.asarray(q, float) @ self.reduction.T + self.motor_offset

    def joint_positions(self, q_m: np.ndarray) -> np.ndarray:
        """(..., n) q_j = N⁻¹ (q_m - offset): what a hardware interface publishes joint-side."""
        return np.linalg.solve(self.reduction, (np.asarray(q_m, float) - self.motor_offset).T).T

    def transmission(self) -> dict:
        """The robot YAML's ``transmission`` mapping (issue 33) of this drive chain."""
        return {"actuators": list(self.actuators),
                "reduction": [[float(v) for v in row] for row in self.reduction],
                "offset": [float(v) for v in self.motor_offset],
                "position_side": "joint", "effort_side": "actuator"}


def rigid_truth(truth: ArmTruth) -> ArmTruth:
    """``truth`` with every joint's armature, friction and offset removed (they are the motors'
    here); g_tau 1 is unused."""
    bare = JointDrive(armature=0.0, damping=0.0, frictionloss=0.0, offset=0.0, g_tau=1.0)
    return replace(truth, drives={j: bare for j in truth.drives})


def default_coupled_truth(
    arm: ArmDescription | None = None, reduction: np.ndarray = REDUCTION
) -> CoupledTruth:
    """The UR5 with the coupled-wrist drive chain (REDUCTION, MOTORS, MOTOR_OFFSET), or with
    another ``reduction`` of the same motors (SIMPLE_REDUCTION: simple_transmission_truth)."""
    arm = arm or load_arm("ur5")
    if arm.n != reduction.shape[1]:
        raise ValueError(f"the drive chain has {reduction.shape[1]} joints, {arm.name} {arm.n}")
    motors = tuple(MotorDrive(ia, fv, fs, off, g, g * f) for ia, fv, fs, off, g, f in MOTORS)
    return CoupledTruth(
        rigid_truth(default_truth(arm)), np.array(reduction, float), MOTOR_OFFSET.copy(), motors
    )


def simple_transmission_truth(arm: ArmDescription | None = None) -> CoupledTruth:
    """The UR5 with one motor per joint behind SIMPLE_REDUCTION (negative reductions on
    shoulder_lift, wrist_1 and wrist_3): ros2_control SimpleTransmissions (ros2_control_urdf)."""
    return replace(default_coupled_truth(arm, SIMPLE_REDUCTION), name="ur5_simple_transmission")


def truth_summary(truth: CoupledTruth) -> dict:
    """The drive chain's truth as JSON-ready numbers (per motor, in N's row order): what an
    identification of the coupled-wrist records is compared with."""
    keys = ("gain", "nominal_gain", "inertia", "viscous", "coulomb", "offset")
    return {"actuators": list(truth.actuators), "reduction": truth.reduction.tolist(),
            "motor_offset_rad": truth.motor_offset.tolist(),
            "units": {"gain": "N·m/A", "nominal_gain": "N·m/A", "inertia": "kg·m²",
                      "viscous": "N·m·s/rad", "coulomb": "N·m", "offset": "N·m"},
            "motors": {k: truth.motor_array(k).tolist() for k in keys}}
