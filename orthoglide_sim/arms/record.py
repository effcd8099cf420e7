"""Simulated records of a serial arm: what its controller would log (q, v_tau at 1 kHz) and the
truth, in memory.

    rec = simulate_arm(60.0, "ur5", payload="2.0", trajectory="exciting2", seed=1)
    rec.stamps_ns, rec.q, rec.v_tau, rec.truth      # what a bag holds, and the plant's truth

The current noise is white, ``truth.current_noise_fraction`` (0.5 %) of each joint's rms current
along the reference (the truth's inverse dynamics with friction, divided by g_tau), drawn from
``seed`` before the run; the encoder rounds to ``truth.encoder_counts`` counts per revolution.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.excite import FourierSeries
from orthoglide_sim.arms import simulator as asim
from orthoglide_sim.arms.description import load_arm
from orthoglide_sim.arms.excitation import designed_trajectory
from orthoglide_sim.arms.limits import MotionLimits, motion_limits
from orthoglide_sim.arms.plant import MujocoPlant
from orthoglide_sim.arms.truth import ArmPayload, ArmTruth, load_truth
from orthoglide_sim.arms.unmodelled import DriveState, Unmodelled
from orthoglide_sim.common.closed_loop import LoopResult, quantise

NOISE_STRIDE = 10  # ticks between the reference samples the rms current is taken over
STIFFNESS_STRIDE = 50  # ticks between the reference poses the PID's stiffness is checked at


class TrackedRun:
    """What a record of a run tells of its tracking (fields payload, q_true, q_ref)."""

    @property
    def payload_mass(self) -> float:
        return 0.0 if self.payload is None else self.payload.mass

    @property
    def tracking_rms(self) -> np.ndarray:
        """(n,) rms of q_true - q_ref, rad (the joint side)."""
        return np.sqrt(np.mean((self.q_true - self.q_ref) ** 2, axis=0))


@dataclass
class ArmRecord(TrackedRun):
    """One simulated run; arrays per controller tick (N, n), columns in ``joint_names`` order."""

    stamps_ns: np.ndarray  # (N,) int64, t_k in ns from start_ns
    q: np.ndarray  # (N, n) rad, encoder readings the controller saw
    v_tau: np.ndarray  # (N, n) A, current references held over [t_k, t_k+1)
    truth: ArmTruth
    payload: ArmPayload | None
    q_true: np.ndarray  # (N, n) rad
    qd_true: np.ndarray  # (N, n) rad/s
    q_ref: np.ndarray  # (N, n) rad, the reference
    current: np.ndarray  # (N, n) A, the motors' currents: v_tau + noise
    current_noise_std: np.ndarray  # (n,) A
    trajectory: str
    seed: int
    saturated_ticks: int

    @property
    def joint_names(self) -> tuple[str, ...]:
        return self.truth.arm.joint_names


def reference_of(arm, trajectory: str | FourierSeries) -> FourierSeries:
    """A trajectory given by name (designed_trajectory) or as a FourierSeries itself."""
    return (
        trajectory
        if isinstance(trajectory, FourierSeries)
        else designed_trajectory(arm, trajectory)
    )


def trajectory_name(trajectory: str | FourierSeries) -> str:
    return trajectory if isinstance(trajectory, str) else "designed"


def current_noise_std(
    plant: MujocoPlant, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray
) -> np.ndarray:
    """(n,) A: the truth's noise fraction of each joint's rms current along the reference."""
    tau = plant.inverse_dynamics(q, qd, qdd, friction=True)
    i_ref = tau / plant.truth.drive_array("g_tau")
    return plant.truth.current_noise_fraction * np.sqrt(np.mean(i_ref**2, axis=0))


def simulate_arm(duration_s: float, robot: str = "ur5", payload: str | None = None,
                 trajectory: str | FourierSeries = "exciting1", seed: int = 0,
                 truth: ArmTruth | None = None, noise: bool = True, start_ns: int = 0,
                 limits: MotionLimits | None = None,
                 effects: Unmodelled | None = None, omega: float = asim.OMEGA,
                 scheduled: bool | None = None) -> ArmRecord:
    """The arm tracking ``trajectory`` for ``duration_s`` s under the 1 kHz PID (arm_simulator).

    robot: a bundled name, robot YAML or URDF (ignored when ``truth`` is given); payload: None,
    "2.0", "1.0" or another of ``truth.payloads``; trajectory: "exciting1", "exciting2", a .json
    or a FourierSeries (designed_runs.py: a run the product designed); limits: the stop
    limits (default arm_limits.motion_limits); effects: drive effects the identification's model
    lacks (orthoglide_sim/arms/unmodelled.py), None: the plant the model describes; omega: the
    PID's bandwidth, rad/s (simulator.arm_pid); scheduled: the mass-matrix PID
    (simulator.ScheduledPID) or the joint PID tuned once at ``limits.centre``; None: the former
    where the latter is over MAX_STIFFNESS times too stiff along the reference (simulator.py).
    Raises ConfigError on bad arguments, WorkspaceError if the arm leaves its stop limits.
    """
    if not duration_s > 0:
        raise ConfigError(f"duration must be positive, got {duration_s}")
    truth = truth or load_truth(load_arm(robot))
    arm, load = truth.arm, truth.payload(payload)
    limits, plant = limits or motion_limits(arm), MujocoPlant(truth, load)
    (q_ref, qd_ref, qdd_ref), noise_a, std = reference_and_noise(plant, trajectory, duration_s,
                                                                 seed, noise)
    current_limit = np.array([j.effort for j in arm.joints]) / arm.nominal_gains
    torque0 = plant.inverse_dynamics(q_ref[:1], qd_ref[:1], qdd_ref[:1], friction=True)[0]
    unloaded = MujocoPlant(truth)
    inertia = asim.joint_inertia(unloaded, limits.centre)  # tuned once, unloaded
    q_prev = quantise(q_ref[0] - qd_ref[0] * asim.TICK, truth.encoder_resolution)
    if scheduled is None:  # too stiff somewhere along the run: the mass-matrix PID
        scheduled = asim.stiffness(unloaded, q_ref[::STIFFNESS_STRIDE], inertia) > \
            asim.MAX_STIFFNESS
    make = (lambda *a: asim.ScheduledPID(unloaded, *a)) if scheduled else \
        (lambda *a: asim.arm_pid(inertia, *a))
    pid = make(arm.nominal_gains, current_limit, q_prev, qd_ref[0], torque0, omega)
    plant.reset(q_ref[0], qd_ref[0])
    drive = None
    if effects is not None and effects.any:
        drive = _drive_state(plant, effects, inertia, torque0, q_ref[0], qd_ref[0], qdd_ref[0],
                             arm.nominal_gains)
    res = asim.run_arm(plant, pid, q_ref, qd_ref, noise_a, limits, drive)
    return ArmRecord(**record_fields(res, truth, load, q_ref, std, trajectory, seed, start_ns))


def reference_and_noise(plant: MujocoPlant, trajectory: str | FourierSeries,
                        duration_s: float, seed: int, noise: bool) -> tuple:
    """The reference (q, qd, qdd) (N, n) at 1 kHz over ``duration_s``, the current noise (N, n)
    A drawn from ``seed`` and its std (n,): white, the truth's fraction of each joint's rms
    current along the reference (current_noise_std); zeros without ``noise``."""
    arm = plant.truth.arm
    N = int(round(duration_s / asim.TICK))
    q_ref, qd_ref, qdd_ref = reference_of(arm, trajectory).evaluate(np.arange(N) * asim.TICK)
    s = slice(None, None, NOISE_STRIDE)
    std = current_noise_std(plant, q_ref[s], qd_ref[s], qdd_ref[s])
    if not noise:
        return (q_ref, qd_ref, qdd_ref), np.zeros((N, arm.n)), np.zeros(arm.n)
    white = np.random.default_rng(seed).normal(0.0, 1.0, (N, arm.n))
    return (q_ref, qd_ref, qdd_ref), white * std, std


def record_fields(res: LoopResult, truth: ArmTruth, load: ArmPayload | None, q_ref: np.ndarray,
                  std: np.ndarray, trajectory: str | FourierSeries, seed: int,
                  start_ns: int) -> dict:
    """ArmRecord's fields of one closed-loop run at 1 kHz from ``start_ns``."""
    stamps = start_ns + np.arange(len(q_ref), dtype=np.int64) * int(round(asim.TICK * 1e9))
    return dict(stamps_ns=stamps, q=res.q_meas, v_tau=res.v_tau, truth=truth, payload=load,
                q_true=res.q, qd_true=res.qd, q_ref=q_ref, current=res.current,
                current_noise_std=std, trajectory=trajectory_name(trajectory), seed=seed,
                saturated_ticks=res.saturated)


def _drive_state(plant: MujocoPlant, effects: Unmodelled, inertia: np.ndarray, torque0: np.ndarray,
                 q0: np.ndarray, qd0: np.ndarray, qdd0: np.ndarray,
                 nominal_gains: np.ndarray) -> DriveState:
    """The unmodelled effects' states at t_0, in steady state on the reference. Behind a spring
    the rotor inertia is the motor's, no longer the link's (MuJoCo's armature set to 0)."""
    armature = plant.truth.drive_array("armature")
    drive = DriveState(effects, inertia, armature, plant.truth.drive_array("frictionloss"),
                       asim.TIMESTEP)
    if effects.two_mass:
        plant.model.dof_armature[plant.dof] = 0.0
    drive.start(q0, qd0, torque0 / nominal_gains, torque0 - armature * qdd0)
    return drive
