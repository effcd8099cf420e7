"""Records of the coupled-wrist UR5 (coupled_wrist) under a 1 kHz PID per motor, and their bags
on either signal side.

    rec = simulate_coupled(60.0, payload="2.0", trajectory="exciting2", seed=1)
    rec.q_motor, rec.q_joint, rec.v_tau      # motor encoders, joint-side positions, currents
    write_coupled_bag(path, rec, position_side="joint")   # or "actuator"

The controller works on the motor side, as an industrial drive does: each motor's encoder
(MOTOR_ENCODER_COUNTS per revolution, offset) is read, the joint reference is brought to the
motor, q_m,ref = N q_ref + offset, q̇_m,ref = N q̇_ref, and arm_simulator's PID (triple pole at
-ω, velocity feed-forward, filtered D) is tuned on each motor's apparent inertia (the diagonal of
N⁻ᵀ M(q_c) N⁻¹, rotor inertias included, unloaded, at the box centre). Its current reference
(torque / the motor's nominal gain, clipped to the current limit) plus white noise
(``current_noise_fraction`` of each motor's rms current along the reference) is held over the
tick: SUBSTEPS MuJoCo RK4 steps. Leaving arm_limits' stop limits raises WorkspaceError.

The joint-side positions are what a ros2_control hardware interface with this transmission
publishes: q_j = N⁻¹ (q_m - offset) from the motor encoders. Currents are per motor, reported
under the name of the joint of the motor's row (the actuators repeat the joint names).
"""
from __future__ import annotations

import shutil
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml

from orthoglide_ident import bags
from orthoglide_ident.errors import ConfigError
from orthoglide_ident.excite import FourierSeries
from orthoglide_ident.model import registry
from orthoglide_sim.arms import simulator as asim
from orthoglide_sim.arms.limits import MotionLimits, motion_limits
from orthoglide_sim.arms.record import NOISE_STRIDE, TrackedRun, reference_of, trajectory_name
from orthoglide_sim.arms.truth import ArmPayload
from orthoglide_sim.common.closed_loop import PID, LoopResult, quantise, run_closed_loop
from orthoglide_sim.coupled.plant import CoupledPlant
from orthoglide_sim.coupled.truth import CoupledTruth, default_coupled_truth

SIDES = bags.tags.SIDES


@dataclass
class CoupledRecord(TrackedRun):
    """One run; arrays per controller tick (K, n): joint columns in ``truth.arm.joint_names``
    order, motor columns in the rows of N."""

    stamps_ns: np.ndarray  # (K,) int64
    q_motor: np.ndarray  # motor encoder readings, rad (offset included)
    q_joint: np.ndarray  # N⁻¹ (q_motor - offset): the joint-side positions published, rad
    v_tau: np.ndarray  # motor current references, A (held over [t_k, t_k+1))
    current: np.ndarray  # the motors' currents: v_tau + noise, A
    q_true: np.ndarray  # joint positions, rad
    qd_true: np.ndarray  # joint velocities, rad/s
    qd_motor_true: np.ndarray  # MuJoCo's tendon velocities, rad/s
    q_ref: np.ndarray  # joint reference, rad
    truth: CoupledTruth
    payload: ArmPayload | None
    current_noise_std: np.ndarray  # (n,) A
    trajectory: str
    seed: int
    saturated_ticks: int



def motor_inertia(plant: CoupledPlant, q: np.ndarray) -> np.ndarray:
    """(n,) diagonal of the mass matrix in motor coordinates, N⁻ᵀ M(q) N⁻¹ (rotors included)."""
    M = asim.mass_matrix(plant, q)
    Ninv = np.linalg.inv(plant.truth.reduction)
    return np.diag(Ninv.T @ M @ Ninv)


def current_limits(truth: CoupledTruth) -> np.ndarray:
    """(n,) A: each motor's current at which its own joint (N's diagonal) gets its URDF effort."""
    effort = np.array([j.effort for j in truth.arm.joints])
    return effort / (np.abs(np.diag(truth.reduction)) * truth.motor_array("nominal_gain"))


def _run(plant: CoupledPlant, pid: PID, qm_ref: np.ndarray, qdm_ref: np.ndarray,
         noise: np.ndarray, limits: MotionLimits) -> LoopResult:
    """The common closed loop on the motor side; ``logged``: the motors' velocities at t_k. The
    drive (the motor's gain and offset) is MuJoCo's actuator on the tendon: ``plant.step`` takes
    the currents."""
    def read():
        return plant.q, plant.qd, plant.q_motor

    def advance(k: int, current: np.ndarray) -> np.ndarray:
        qd_motor = plant.qd_motor
        plant.step(current, asim.SUBSTEPS)
        asim.check_limits(plant, limits, k, current)
        return qd_motor

    return run_closed_loop(read, lambda k, q: pid.current(q, qm_ref[k], qdm_ref[k]), advance,
                           noise, plant.truth.encoder_resolution,
                           current_limit=pid.current_limit)


def simulate_coupled(duration_s: float, payload: str | None = None,
                     trajectory: str | FourierSeries = "exciting1", seed: int = 0,
                     truth: CoupledTruth | None = None, noise: bool = True) -> CoupledRecord:
    """The coupled-wrist UR5 tracking ``trajectory`` (a UR5 exciting trajectory by name, a .json
    or a FourierSeries) for ``duration_s`` s; payload None, "2.0", "1.0" (arm_truth's).
    ConfigError on bad arguments, WorkspaceError if the arm leaves its stop limits."""
    if not duration_s > 0:
        raise ConfigError(f"duration must be positive, got {duration_s}")
    truth = truth or default_coupled_truth()
    arm, load, N = truth.arm, truth.payload(payload), truth.reduction
    limits, plant = motion_limits(arm), CoupledPlant(truth, load)
    K = int(round(duration_s / asim.TICK))
    q_ref, qd_ref, qdd_ref = reference_of(arm, trajectory).evaluate(np.arange(K) * asim.TICK)
    qm_ref, qdm_ref = truth.motor_positions(q_ref), qd_ref @ N.T
    s = slice(None, None, NOISE_STRIDE)
    tau_m = plant.motor_torques(q_ref[s], qd_ref[s], qdd_ref[s])
    std = truth.current_noise_fraction * np.sqrt(
        np.mean((tau_m / truth.motor_array("gain")) ** 2, axis=0)
    )
    std = std if noise else np.zeros(arm.n)
    noise_a = np.random.default_rng(seed).normal(0.0, 1.0, (K, arm.n)) * std
    torque0 = plant.motor_torques(q_ref[:1], qd_ref[:1], qdd_ref[:1])[0]
    inertia = motor_inertia(CoupledPlant(truth), limits.centre)  # tuned once, unloaded
    q_prev = quantise(
        truth.motor_positions(q_ref[0] - qd_ref[0] * asim.TICK), truth.encoder_resolution
    )
    pid = asim.arm_pid(inertia, truth.motor_array("nominal_gain"), current_limits(truth),
                       q_prev, qdm_ref[0], torque0)
    plant.reset(q_ref[0], qd_ref[0])
    out = _run(plant, pid, qm_ref, qdm_ref, noise_a, limits)
    stamps = np.arange(K, dtype=np.int64) * int(round(asim.TICK * 1e9))
    return CoupledRecord(stamps, out.q_meas, truth.joint_positions(out.q_meas), out.v_tau,
                         out.current, out.q, out.qd, out.logged, q_ref, truth, load, std,
                         trajectory_name(trajectory), seed, out.saturated)


def joint_efforts(rec: CoupledRecord) -> np.ndarray:
    """(K, n) N·m: the joint torques a drive reports when it publishes joint-side efforts,
    Nᵀ (g_nominal ⊙ v) (its configured gains: it does not know the true ones)."""
    return (rec.v_tau * rec.truth.motor_array("nominal_gain")) @ rec.truth.reduction


def write_coupled_bag(path: str | Path, rec: CoupledRecord, position_side: str = "joint",
                      effort_side: str = "actuator") -> Path:
    """One record as a tagged bag in the ros2_control layout (/joint_states: position, velocity,
    effort), replaced if it exists. ``position_side``: ``joint`` (q_j, as a hardware interface
    with the transmission publishes) or ``actuator`` (the motor encoders, offset included);
    ``effort_side``: ``actuator`` (each motor's current, A) or ``joint`` (joint_efforts, N·m,
    tagged orthoglide.effort_unit torque). Channels carry the joints' names (the actuators
    repeat them); the tag says which side (orthoglide.position_side, orthoglide.effort_side)."""
    for key, side in (("position_side", position_side), ("effort_side", effort_side)):
        if side not in SIDES:
            raise ConfigError(f"{key} must be one of {', '.join(SIDES)}, got {side!r}")
    path = Path(path)
    if path.exists():
        shutil.rmtree(path)
    q = rec.q_joint if position_side == "joint" else rec.q_motor
    effort = rec.v_tau if effort_side == "actuator" else joint_efforts(rec)
    condition = "unloaded" if rec.payload is None else "loaded"
    payload = None if rec.payload is None else rec.payload.tag()
    extra = {"orthoglide.sim.robot": rec.truth.name, "orthoglide.sim.trajectory": rec.trajectory,
             "orthoglide.sim.seed": str(rec.seed)}
    return bags.write_bag(
        path,
        rec.stamps_ns,
        q,
        effort,
        condition,
        rec.payload_mass,
        joint_names=rec.truth.actuators,
        extra=extra,
        layout="joint_states",
        payload=payload,
        effort_unit=None if effort_side == "actuator" else "torque",
        position_side=position_side,
        effort_side=effort_side,
    )


def write_robot_files(folder: str | Path, truth: CoupledTruth) -> tuple[Path, Path]:
    """The robot YAMLs of the coupled-wrist UR5 for the identification (issue 33's
    ``transmission`` key), with a copy of the UR5's URDF beside them: ``ur5_coupled_wrist.yaml``
    (position_side joint) and ``ur5_coupled_wrist_actuator.yaml`` (position_side actuator).
    ``nominal_gains`` are the motors' (N·m/A at the motor shaft, in the actuators' order)."""
    src = registry.resolve("ur5")
    data = registry.read_yaml(src)
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    urdf = (src.parent / str(data["description"])).resolve()
    shutil.copyfile(urdf, folder / urdf.name)
    out = []
    for side, stem in (("joint", "ur5_coupled_wrist"), ("actuator", "ur5_coupled_wrist_actuator")):
        d = dict(data, name="ur5_coupled_wrist", description=urdf.name,
                 nominal_gains=truth.motor_array("nominal_gain").tolist(),
                 transmission=dict(truth.transmission(), position_side=side))
        path = folder / f"{stem}.yaml"
        path.write_text(
            "# The UR5 with a coupled wrist (orthoglide_sim.coupled.truth): motor 6 turns "
            "with q5 + q6;\n# nominal_gains per motor (N·m/A at the motor shaft)\n"
            + yaml.safe_dump(d, sort_keys=False, allow_unicode=True, default_flow_style=None)
        )
        out.append(path)
    return out[0], out[1]
