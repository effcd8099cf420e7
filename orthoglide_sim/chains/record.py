"""Simulated records of a closed chain: what its controller would log (actuated q, v_tau at
1 kHz) and the truth, in memory — arm_record for a robot whose actuated joints are not all its
movable joints.

    rec = simulate_chain(60.0, "five_bar", payload="1.0", trajectory="exciting2", seed=1)
    rec.stamps_ns, rec.q, rec.v_tau, rec.truth, rec.loop_error

The controller and drive are the arm's (arm_simulator: the 1 kHz PID tuned on each actuated
joint's reduced inertia Gᵀ M G, zero-order hold of g_tau (v_tau + noise), encoder quantisation,
current limit); the plant is chain_plant's MuJoCo model with its loops. The current noise is
``truth.current_noise_fraction`` (0.5 %) of each actuated joint's rms current along the
reference (MuJoCo's constrained inverse dynamics with friction, divided by g_tau).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.excite import FourierSeries
from orthoglide_sim.arms import simulator as asim
from orthoglide_sim.arms.limits import MotionLimits, motion_limits
from orthoglide_sim.arms.record import ArmRecord, record_fields, reference_and_noise
from orthoglide_sim.chains.description import load_chain
from orthoglide_sim.chains.plant import ChainPlant
from orthoglide_sim.chains.truth import ChainTruth, load_chain_truth
from orthoglide_sim.common.closed_loop import PID, quantise


@dataclass
class ChainRecord(ArmRecord):
    """An ArmRecord of a closed chain, with the tree's state and the loops' error per tick."""

    q_tree: np.ndarray  # (N, n_tree) rad, every tree joint at t_k (truth.arm.tree_joints order)
    loop_error: np.ndarray  # (N,) m, max |e| of the loops after each tick


def tuned_pid(plant: ChainPlant, q0: np.ndarray, qd0: np.ndarray, qdd0: np.ndarray) -> PID:
    """The arm's PID for the chain: tuned once on the unloaded chain's reduced inertia at the
    box centre, its integrator pre-loaded with the torque the reference (q0, qd0, qdd0) needs
    on ``plant`` (the plant starts on the reference)."""
    truth = plant.truth
    chain = truth.arm
    current_limit = np.array([j.effort for j in chain.joints]) / chain.nominal_gains
    torque0 = plant.inverse_dynamics(q0[None], qd0[None], qdd0[None], friction=True)[0]
    inertia = ChainPlant(truth).actuated_inertia(motion_limits(chain).centre)
    return asim.arm_pid(
        inertia,
        chain.nominal_gains,
        current_limit,
        quantise(q0 - qd0 * asim.TICK, truth.encoder_resolution),
        qd0,
        torque0,
    )


def simulate_chain(duration_s: float, robot: str = "five_bar", payload: str | None = None,
                   trajectory: str | FourierSeries = "exciting1", seed: int = 0,
                   truth: ChainTruth | None = None, noise: bool = True, start_ns: int = 0,
                   limits: MotionLimits | None = None) -> ChainRecord:
    """The chain tracking ``trajectory`` for ``duration_s`` s under the 1 kHz PID.

    robot: a bundled name or robot YAML with loops (ignored when ``truth`` is given); payload:
    None or one of ``truth.payloads`` ("1.0", "0.5" for the five-bar); trajectory: "exciting1",
    "exciting2" (data/<robot>_exciting<k>.json), a .json or a FourierSeries; limits: the stop
    limits (default arm_limits.motion_limits). Raises ConfigError on bad
    arguments, WorkspaceError if the robot leaves its limits or its loops break.
    """
    if not duration_s > 0:
        raise ConfigError(f"duration must be positive, got {duration_s}")
    truth = truth or load_chain_truth(load_chain(robot))
    chain, load = truth.arm, truth.payload(payload)
    limits, plant = limits or motion_limits(chain), ChainPlant(truth, load)
    (q_ref, qd_ref, qdd_ref), noise_a, std = reference_and_noise(plant, trajectory, duration_s,
                                                                 seed, noise)
    pid = tuned_pid(plant, q_ref[0], qd_ref[0], qdd_ref[0])
    plant.reset(q_ref[0], qd_ref[0])
    res = asim.run_arm(plant, pid, q_ref, qd_ref, noise_a, limits)
    return ChainRecord(**record_fields(res, truth, load, q_ref, std, trajectory, seed, start_ns),
                       q_tree=np.array(plant.tree_log), loop_error=np.array(plant.loop_errors))

