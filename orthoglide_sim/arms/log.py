"""Simulated arm records as real controllers log them: their own clock, printed positions.

A controller on a non-real-time clock ticks at uneven instants (10/12 ms alternation, a 2 ms
grid, jitter); at each tick it reads the encoder, computes its current and *holds it until its
next tick*, and logs q (printed to ``print_resolution``, e.g. 1e-4 rad), the joint velocity and
the current it sent, stamped with the tick. So the plant-side current is exactly the logged
one held over [t_k, t_k+1) and the plant's state is sampled at the logged instants.

    rec = simulate_arm_log(60.0, clock_10_12(60.0), payload="2.0", trajectory="exciting2")

A logger slower than its controller (a ROS node subscribed to a 1 kHz loop): ``point_sampled``
keeps every 10th-14th tick of a record at the controller's rate, each kept sample the loop's own
q and current at that tick, nothing averaged; the plant's current moves at every controller tick
in between, so the logged one is a point sample of it (not held over the log step):

    fast = simulate_arm_log(60.0, clock_uniform(60.0, 1000.0), print_resolution=0.0)
    rec = point_sampled(fast, KEEP_10_12_14)   # steps 10/12/14 ms, ~83 Hz

The PID is arm_simulator's, retuned for the slower tick (its bandwidth ω at most
``OMEGA_T / T̄``: a discrete loop at ω T̄ ≈ 1 rings); the plant's RK4 step divides every tick
(``timestep``: 0.25 ms by default, finer for a 5 kHz controller). Nothing of the
identification model is used.
"""
from __future__ import annotations

import numpy as np

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.excite import FourierSeries
from orthoglide_sim.arms import simulator as asim
from orthoglide_sim.arms.description import load_arm
from orthoglide_sim.arms.limits import motion_limits
from orthoglide_sim.arms.plant import MujocoPlant
from orthoglide_sim.arms.record import (
    NOISE_STRIDE,
    ArmRecord,
    current_noise_std,
    reference_of,
    trajectory_name,
)
from orthoglide_sim.arms.truth import ArmTruth, load_truth
from orthoglide_sim.common.closed_loop import run_closed_loop

OMEGA_T = 0.1  # the PID's bandwidth x the mean tick, at most (0.1 at 1 kHz: 100 rad/s)


def clock_10_12(duration_s: float) -> np.ndarray:
    """Tick steps (ns) of a controller alternating 10 ms and 12 ms (mean 11 ms, 90.9 Hz)."""
    n = int(duration_s / 0.011)
    return np.tile(np.array([10_000_000, 12_000_000], np.int64), n // 2 + 1)[:n]


def clock_uniform(duration_s: float, rate_hz: float) -> np.ndarray:
    """Steps (ns) of a steady clock at ``rate_hz``."""
    step = int(round(1e9 / rate_hz))
    return np.full(int(round(duration_s * rate_hz)), step, np.int64)


KEEP_10_12_14 = (10, 12, 14)  # controller ticks between kept samples (a ~93 Hz logger of 1 kHz)
KEEP_3_4_5 = (3, 4, 5)  # a ~250 Hz logger of a 1 kHz loop


def point_sampled(rec: ArmRecord, strides: tuple[int, ...] | int, print_resolution: float = 1e-4
                  ) -> ArmRecord:
    """The ticks of ``rec`` (a record at its controller's rate) a slower logger keeps: every
    ``strides`` ticks, cycling (10, 12, 14: steps of 10/12/14 ms from a 1 kHz loop), each kept
    sample the loop's own encoder reading (printed to ``print_resolution``; 0: as read) and
    current reference at that tick. Nothing averaged: the logged current is a point sample of
    one that moves at every controller tick."""
    import dataclasses

    cycle = np.atleast_1d(np.asarray(strides, np.int64))
    if np.any(cycle < 1):
        raise ConfigError(f"strides must be positive tick counts, got {cycle.tolist()}")
    n = rec.stamps_ns.shape[0]
    steps = np.resize(cycle, n)  # more than enough
    idx = np.concatenate([[0], np.cumsum(steps)])
    idx = idx[idx < n]
    q = rec.q[idx]
    if print_resolution:
        q = np.round(q / print_resolution) * print_resolution
    return dataclasses.replace(rec, stamps_ns=rec.stamps_ns[idx], q=q, v_tau=rec.v_tau[idx],
                               q_true=rec.q_true[idx], qd_true=rec.qd_true[idx],
                               q_ref=rec.q_ref[idx], current=rec.current[idx])


def simulate_arm_log(duration_s: float, steps_ns: np.ndarray, robot: str = "ur5",
                     payload: str | None = None, trajectory: str | FourierSeries = "exciting1",
                     seed: int = 0, print_resolution: float = 1e-4, timestep: float = 2.5e-4,
                     truth: ArmTruth | None = None) -> ArmRecord:
    """The arm under a PID that ticks at ``steps_ns`` (each a multiple of ``timestep``); the
    returned record's ``q`` is printed to ``print_resolution`` (0: the encoder's), ``qd_true``
    the plant's velocity at the stamps (what a drive's velocity estimate would log)."""
    if not duration_s > 0:
        raise ConfigError(f"duration must be positive, got {duration_s}")
    truth = truth or load_truth(load_arm(robot))
    arm, load = truth.arm, truth.payload(payload)
    limits, plant = motion_limits(arm), MujocoPlant(truth, load)
    plant.model.opt.timestep = timestep
    sub = np.rint(np.asarray(steps_ns, float) * 1e-9 / timestep).astype(np.int64)
    if np.any(sub < 1) or np.any(np.abs(sub * timestep - steps_ns * 1e-9) > 1e-12):
        raise ConfigError(f"every tick must be a multiple of the plant's {timestep} s step")
    stamps = np.concatenate([[0], np.cumsum(steps_ns)])[:-1].astype(np.int64)
    t = stamps * 1e-9
    N, T = t.shape[0], float(np.mean(steps_ns)) * 1e-9
    q_ref, qd_ref, qdd_ref = reference_of(arm, trajectory).evaluate(t)
    stride = max(1, int(round(NOISE_STRIDE * 1e-3 / T)))
    std = current_noise_std(plant, q_ref[::stride], qd_ref[::stride], qdd_ref[::stride])
    noise = np.random.default_rng(seed).normal(0.0, 1.0, (N, arm.n)) * std
    current_limit = np.array([j.effort for j in arm.joints]) / arm.nominal_gains
    torque0 = plant.inverse_dynamics(q_ref[:1], qd_ref[:1], qdd_ref[:1], friction=True)[0]
    inertia = asim.joint_inertia(MujocoPlant(truth), limits.centre)
    omega = min(asim.OMEGA, OMEGA_T / T)
    tau_v = asim.VELOCITY_FILTER * asim.OMEGA / omega
    pid = asim.arm_pid(inertia, arm.nominal_gains, current_limit, q_ref[0], qd_ref[0], torque0,
                       omega=omega, velocity_filter=tau_v)
    plant.reset(q_ref[0], qd_ref[0])
    arm_drives = asim.ArmDrives(plant, limits)

    def control(k: int, q_meas: np.ndarray) -> np.ndarray:
        dt = steps_ns[k - 1] * 1e-9 if k else T  # the tick just ended
        return pid.current(q_meas, q_ref[k], qd_ref[k], dt)

    def advance(k: int, current: np.ndarray) -> None:  # held until the next tick
        arm_drives.advance(k, current, int(sub[k]))

    out = run_closed_loop(arm_drives.read, control, advance, noise, truth.encoder_resolution,
                          current_limit=pid.current_limit)
    printed = (
        out.q_meas
        if not print_resolution
        else np.round(out.q_meas / print_resolution) * print_resolution
    )
    return ArmRecord(stamps, printed, out.v_tau, truth, load, out.q, out.qd, q_ref, out.current,
                     std, trajectory_name(trajectory), seed, out.saturated)
