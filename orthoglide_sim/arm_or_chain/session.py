"""Tick-by-tick simulation of a serial arm or a closed chain (a robot by name) and its 1 kHz PID
for the ros2_control stand-in (no ROS).

The same plant, controller and noise as ``arm_record.simulate_arm``, one tick per call, so that a
node can publish each tick as it happens and change the payload or the trajectory while it runs:

    s = ArmSession("ur5", payload=None, trajectory="exciting1", seed=0)
    tick = s.tick()        # k, q_meas (encoder), velocity estimate, v_tau (A) held over [t_k,
    t_k+1)
    s.set_payload("2.0")   # mounted now: the motion goes on from the same state
    s.set_trajectory("exciting2", s.k)   # blends in over 2 s (common.reference.BLEND_TIME)
    goal = s.start_goal(times, q, qd, qdd, tolerances)   # a FollowJointTrajectory goal from now on
    s.cancel_goal()                       # ... or let it run: goal.status, goal.reason

``trajectory="hold"`` keeps the arm at rest at the centre of its box until a goal moves it (a
joint_trajectory_controller's robot). A goal starts from the reference of the current tick
(joint_trajectory.JointTrajectory); after it the arm holds its last point, or where it was
when the goal was cancelled or aborted.

Run from the start with one trajectory and payload, ``tick()`` reproduces ``simulate_arm`` of
the same seed tick for tick when ``noise_window_s`` is that run's duration (the current noise's
size is the truth's fraction of the rms current over that window; default: one period of the
trajectory). A simulated arm that leaves its stop limits stops (``fault``, the reason) until
``reset()`` puts it back on its reference.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from orthoglide_ident.errors import ConfigError, WorkspaceError
from orthoglide_sim.arms import simulator as asim
from orthoglide_sim.arms.description import load_arm
from orthoglide_sim.arms.excitation import designed_trajectory
from orthoglide_sim.arms.limits import motion_limits
from orthoglide_sim.arms.plant import MujocoPlant
from orthoglide_sim.arms.record import NOISE_STRIDE, current_noise_std
from orthoglide_sim.arms.truth import ArmPayload, ArmTruth, RigidBody, load_truth
from orthoglide_sim.chains.description import load_chain
from orthoglide_sim.chains.plant import ChainPlant
from orthoglide_sim.chains.truth import ChainTruth, load_chain_truth
from orthoglide_sim.common.closed_loop import quantise
from orthoglide_sim.common.joint_trajectory import (
    PATH_TOLERANCE_VIOLATED,
    GoalTracker,
    Hold,
    JointTrajectory,
    Tolerances,
)
from orthoglide_sim.common.reference import Reference

NOISE_BLOCK = 1000  # ticks of current noise drawn at once (the same stream as one draw of all)
# m, a point-mass payload is a sphere this size (its inertia ~1e-3 of the noise)
POINT_RADIUS = 0.005
MAX_POINT_MASS = 20.0  # kg
HOLD = "hold"  # the trajectory parameter: at rest at the box centre (until a goal moves the arm)
NOISE_TRAJECTORY = "exciting1"  # the motion whose rms current sizes the noise when holding


@dataclass(frozen=True)
class ArmTick:
    """What the drives report at tick k, in the arm's joint order (n,) each."""

    k: int
    position: np.ndarray  # rad (m): the encoder reading at t_k
    velocity: np.ndarray  # rad/s (m/s): the controller's low-passed estimate
    current: np.ndarray  # A: the current reference v_tau applied over [t_k, t_k+1)


class ArmSession:
    """The arm, its PID and its drives, one tick at a time (see the module docstring)."""

    def __init__(self, robot: str = "ur5", payload: object = None, trajectory: str = "exciting1",
                 seed: int = 0, noise: bool = True, params_file: str | None = None,
                 noise_window_s: float | None = None, truth: ArmTruth | None = None):
        self.truth = truth or robot_truth(robot, params_file or None)
        self.Plant = ChainPlant if isinstance(self.truth, ChainTruth) else MujocoPlant
        arm = self.truth.arm
        self.limits = motion_limits(arm)
        self._internal: dict[str, object] = {HOLD: Hold(self.limits.centre)}  # goals, holds
        self.reference = Reference(trajectory, self._trajectory)
        self.period = designed_trajectory(
            arm, NOISE_TRAJECTORY if trajectory == HOLD else trajectory
        ).period
        self.goal: GoalTracker | None = None
        self._goal_k0 = 0
        self.payload = resolve_payload(self.truth, payload)
        self.plant = self.Plant(self.truth, self.payload)
        self.g_tau = self.truth.drive_array("g_tau")
        self.current_limit = np.array([j.effort for j in arm.joints]) / arm.nominal_gains
        # tuned unloaded
        self.inertia = (ChainPlant(self.truth).actuated_inertia(self.limits.centre)
                        if self.Plant is ChainPlant
                        else asim.joint_inertia(MujocoPlant(self.truth), self.limits.centre))
        self.rng = np.random.default_rng(seed)
        self.noise_std = self._noise_std(noise_window_s) if noise else np.zeros(arm.n)
        self.k = 0
        self.saturated = 0  # ticks whose current reference hit the limit on some joint
        self.fault: str | None = None
        self._noise = np.zeros((0, arm.n))
        self._noise_k0 = 0
        self._start_on_reference()

    @property
    def joint_names(self) -> tuple[str, ...]:
        return self.truth.arm.joint_names

    def _noise_std(self, window_s: float | None) -> np.ndarray:
        """(n,) A: simulate_arm's rule over the first ``window_s`` s (one period by default)."""
        window = window_s if window_s else self.period
        reference = (Reference(NOISE_TRAJECTORY, self._trajectory) if self.reference.name == HOLD
                     else self.reference)
        q, qd, qdd = reference.evaluate(np.arange(int(round(window / asim.TICK))))
        return current_noise_std(
            self.plant, q[::NOISE_STRIDE], qd[::NOISE_STRIDE], qdd[::NOISE_STRIDE]
        )

    def _start_on_reference(self) -> None:
        """The plant at rest on the reference of tick k, the PID pre-loaded as simulate_arm's."""
        q, qd, qdd = (v[:1] for v in self.reference.evaluate(self.k))
        torque0 = self.plant.inverse_dynamics(q, qd, qdd, friction=True)[0]
        res = self.truth.encoder_resolution
        self.pid = asim.arm_pid(self.inertia, self.truth.arm.nominal_gains, self.current_limit,
                                quantise(q[0] - qd[0] * asim.TICK, res), qd[0], torque0)
        self.plant.reset(q[0], qd[0])
        self.drives = asim.ArmDrives(self.plant, self.limits)

    # ---- changes while running ---------------------------------------------------------------
    def set_payload(self, name: object) -> None:
        """Mount payload ``name`` (resolve_payload): the motion goes on from the same state; the
        PID keeps its tuning, as on a real arm. ConfigError if unknown."""
        load = resolve_payload(self.truth, name)
        q, qd = self.plant.q, self.plant.qd
        self.payload, self.plant = load, self.Plant(self.truth, load)
        self.plant.reset(q, qd)
        self.drives = asim.ArmDrives(self.plant, self.limits)

    def _trajectory(self, name: str):
        """A reference by name: hold, a goal's (internal), or the arm's designed ones."""
        return (
            self._internal[name]
            if name in self._internal
            else designed_trajectory(self.truth.arm, name)
        )

    def set_trajectory(self, name: str, k: int) -> None:
        """Blend into trajectory ``name`` from tick ``k`` on. ConfigError if unknown, still
        blending, or while a goal runs."""
        if self.goal is not None and self.goal.status == "active":
            raise ConfigError("a FollowJointTrajectory goal is running: cancel it first")
        self.reference.switch(name, k)

    # ---- FollowJointTrajectory goals ---------------------------------------------------------
    def start_goal(
        self,
        times: np.ndarray,
        q: np.ndarray,
        qd: np.ndarray | None,
        qdd: np.ndarray | None,
        tolerances: Tolerances,
        effort: np.ndarray | None = None,
    ) -> GoalTracker:
        """Follow points at ``times`` (s from the next tick; arrays (N, n) in the arm's joint
        order) from the reference of the next tick on; ``effort`` (N, n) N·m, when given, is
        fed forward (divided by the nominal gains, as the hardware does with an effort command).
        ConfigError while a goal runs or in fault."""
        if self.goal is not None and self.goal.status == "active":
            raise ConfigError("a goal is already running")
        if self.fault is not None:
            raise ConfigError(f"the arm is stopped ({self.fault}): reset it first")
        start = tuple(v[0] for v in self.reference.evaluate(self.k))
        self._internal["goal"] = JointTrajectory(times, q, qd, qdd, start, effort)
        self.reference = Reference("goal", self._trajectory, start_tick=self.k)
        self._goal_k0 = self.k
        self.goal = GoalTracker(self._internal["goal"], tolerances, self.joint_names)
        return self.goal

    def cancel_goal(self) -> None:
        """End the running goal: the arm holds where it is."""
        if self.goal is not None and self.goal.status == "active":
            self.goal.cancel()
            self._hold_here()

    def _hold_here(self) -> None:
        self._internal["held"] = Hold(self.plant.q)
        self.reference = Reference("held", self._trajectory, start_tick=self.k)

    def reset(self) -> None:
        """Clear a fault: the arm back at rest on the reference of the current tick."""
        self.fault = None
        self._start_on_reference()

    # ---- one tick ----------------------------------------------------------------------------
    def _noise_at(self, k: int) -> np.ndarray:
        i = k - self._noise_k0
        if not 0 <= i < len(self._noise):
            self._noise_k0, i = k, 0
            self._noise = self.rng.normal(0.0, 1.0, (NOISE_BLOCK, len(self.g_tau))) * self.noise_std
        return self._noise[i]

    def tick(self) -> ArmTick | None:
        """Tick k as the common closed loop runs it: encoder reading, PID current, the drive's
        torque held over the tick (SUBSTEPS MuJoCo steps); None while in fault."""
        if self.fault is not None:
            return None
        k = self.k
        q_meas = quantise(self.drives.read()[2], self.truth.encoder_resolution)
        q_ref, qd_ref, qdd_ref = self.reference.at(k)
        if self.goal is not None and self.goal.status == "active":
            self.goal.update((k - self._goal_k0) * asim.TICK, q_meas, self.pid.v_filtered.copy(),
                             (q_ref, qd_ref, qdd_ref))
            if self.goal.status == "aborted":  # the JTC holds where the arm is
                self._hold_here()
                q_ref, qd_ref, _ = self.reference.at(k)
        v = self.pid.current(q_meas, q_ref, qd_ref)
        if self.goal is not None and self.goal.status == "active":
            effort = self.goal.trajectory.effort_at((k - self._goal_k0) * asim.TICK)
            if effort is not None:  # the JTC's feed-forward: effort command / nominal gain
                v = np.clip(
                    v + effort / self.pid.nominal_gain, -self.current_limit, self.current_limit
                )
        self.saturated += bool(np.any(np.abs(v) >= self.pid.current_limit))
        try:
            self.drives.advance(k, v + self._noise_at(k))
        except WorkspaceError as exc:
            self.fault = str(exc)
            if self.goal is not None and self.goal.status == "active":
                self.goal.status, self.goal.code, self.goal.reason = (
                    "aborted",
                    PATH_TOLERANCE_VIOLATED,
                    self.fault,
                )
        self.k += 1
        self.reference.settle(self.k)
        return ArmTick(k, q_meas, self.pid.v_filtered.copy(), v)


def robot_truth(robot: str, params_file: str | None = None) -> ArmTruth:
    """The plant's truth of a robot file: a serial arm's, or a closed chain's when the file has
    loop closures (chain_truth; its plant is ChainPlant, MuJoCo with equality constraints)."""
    from orthoglide_ident.model.registry import read_yaml, resolve

    path = resolve(robot)
    closed = path is not None and path.suffix in (".yaml", ".yml") and read_yaml(path).get("loops")
    if closed:
        return load_chain_truth(load_chain(robot), params_file)
    return load_truth(load_arm(robot), params_file)


def resolve_payload(truth: ArmTruth, value: object) -> ArmPayload | None:
    """The ``payload`` parameter: none / "" / 0 -> None; one of the truth's payloads by its name
    ("2.0", "1.0": off-centre bodies, whose bags need the payload's shape in their tag); any other
    mass in kg (e.g. 2.5) -> a point mass at the payload frame's origin (a POINT_RADIUS sphere:
    what the recorder's mass-only tag describes). ConfigError otherwise."""
    text = str(value).strip()
    if text.lower() in ("", "none", "0", "0.0"):
        return None
    if text in truth.payloads:
        return truth.payloads[text]
    try:
        mass = float(text)
    except ValueError:
        mass = math.nan
    if not 0.0 < mass < MAX_POINT_MASS:
        raise ConfigError(
            f"payload {value!r}: none, one of {', '.join(sorted(truth.payloads))} (the plant's "
            f"bodies) or a point mass in kg (0, {MAX_POINT_MASS:g})"
        )
    inertia = 0.4 * mass * POINT_RADIUS**2 * np.eye(3)
    return ArmPayload(
        f"{mass:g} kg point", truth.arm.payload_frame, RigidBody(mass, np.zeros(3), inertia)
    )
