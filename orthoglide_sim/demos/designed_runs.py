"""The product's designed exciting trajectories (orthoglide_ident.excite) on the simulated plants.

    traj = load_trajectory("ur5_traj.yaml")
    rec = simulate_designed(traj, "loaded", truth, payload="2.0", seed=1)   # ArmRecord/ChainRecord

A run of the trajectory file is tracked as its periodic Fourier series (``traj.series(run)``:
the one type the simulator's stored trajectories are, at rest at t = 0) by the plant's 1 kHz PID
for the run's duration. The
stop limits are those the design was checked against (the file's ``limits``: the URDF's and the
robot file's), not the simulator's hand-written boxes (arm_limits), which a design for the whole
range leaves; the PID is tuned at the run's start pose.
"""
from __future__ import annotations

import numpy as np

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.excite.trajectory import ExcitationTrajectory
from orthoglide_sim.arms.limits import MotionLimits
from orthoglide_sim.arms.truth import ArmTruth
from orthoglide_sim.chains.truth import ChainTruth


def stop_limits(traj: ExcitationTrajectory, run: str) -> MotionLimits:
    """The plant's stop limits for a run: the position limits the file was checked against,
    centred (for the PID's tuning) on the run's start pose."""
    try:
        rows = traj.extra["limits"]["joints"]
        lo = np.array([float(rows[j]["lower"]) for j in traj.joints])
        hi = np.array([float(rows[j]["upper"]) for j in traj.joints])
        vel = np.array([float(rows[j]["velocity"]) for j in traj.joints])
        acc = np.array([float(rows[j]["acceleration"]) for j in traj.joints])
    except (KeyError, TypeError, ValueError):
        raise ConfigError("the trajectory file has no limits.joints (write it with excite "
                          "design)") from None
    start = traj.start_pose(run)
    return MotionLimits(start, 0.5 * (hi - lo), vel, acc, lo, hi)


def simulate_designed(traj: ExcitationTrajectory, run: str, truth: ArmTruth,
                      payload: str | None = None, seed: int = 0, noise: bool = True,
                      duration_s: float | None = None, start_ns: int = 0):
    """The plant of ``truth`` (a serial arm or a closed chain) tracking run ``run`` for its
    duration (or ``duration_s``): an ArmRecord or a ChainRecord."""
    if tuple(truth.arm.joint_names) != tuple(traj.joints):
        raise ConfigError(f"the trajectory's joints {list(traj.joints)} are not the plant's "
                          f"{list(truth.arm.joint_names)}")
    seconds = duration_s or traj.duration
    kw = dict(payload=payload, trajectory=traj.series(run), seed=seed, truth=truth,
              noise=noise, start_ns=start_ns, limits=stop_limits(traj, run))
    if isinstance(truth, ChainTruth):
        from orthoglide_sim.chains.record import simulate_chain

        return simulate_chain(seconds, **kw)
    from orthoglide_sim.arms.record import simulate_arm

    return simulate_arm(seconds, **kw)
