"""Issue 43's "big arm, small weighed payload, ~95 Hz" record shape, simulated: the UR10 (32.7 kg
of links, orthoglide_sim/data/ur10) with a 2.8 kg payload whose CoM is off the flange and not
told, logged by its controller on a 10/12 ms clock (90.9 Hz), positions printed to 1e-4 rad, in
unloaded/loaded pairs, each pair its own trajectories and noise (``seed``).

    pair = simulate_pair(seed=0, duration_s=60.0)
    records = pair_records(pair)            # what the product reads: the payload by its mass
    pair.truth.drive_array("g_tau")         # what it should find

The trajectories are random Fourier shapes (excitation.random_trajectory) scaled to ``reach``
of the arm's box, speed and acceleration limits: a real data set's motions, not a designed
exciting trajectory.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from orthoglide_ident.excite import FourierSeries
from orthoglide_sim.arms.description import load_arm
from orthoglide_sim.arms.excitation import random_trajectory
from orthoglide_sim.arms.limits import motion_limits
from orthoglide_sim.arms.log import clock_10_12, simulate_arm_log
from orthoglide_sim.arms.record import ArmRecord
from orthoglide_sim.arms.truth import ArmTruth, load_truth, with_offset_payload

UR10_FILE = Path(__file__).resolve().parents[1] / "data" / "ur10" / "ur10.yaml"
PAYLOAD = "2.8"  # the payload's name in the truth
PAYLOAD_MASS = 2.8  # kg, weighed
PAYLOAD_COM = (0.02, -0.015, 0.06)  # m in tool0: 6 cm from the flange, 2.5 cm off its axis
REACH = 0.6  # of the box, speed and acceleration limits a data set's motion reaches


@dataclass
class Pair:
    """An unloaded and a loaded record of the same robot and their truth."""

    unloaded: ArmRecord
    loaded: ArmRecord
    truth: ArmTruth
    seed: int


def big_arm_truth() -> ArmTruth:
    """The UR10's truth (truth.py's seeded rule) with the 2.8 kg payload of unknown CoM."""
    truth = load_truth(load_arm(str(UR10_FILE)))
    return with_offset_payload(truth, PAYLOAD_MASS, PAYLOAD_COM, name=PAYLOAD)


def gentle_trajectory(truth: ArmTruth, seed: int, reach: float = REACH) -> FourierSeries:
    """A random Fourier shape at ``reach`` of the limits (amplitudes scaled about the centre)."""
    full = random_trajectory(motion_limits(truth.arm), seed)
    return FourierSeries(full.q0, full.a * reach, full.b * reach, full.w_f)


def simulate_pair(seed: int, duration_s: float = 60.0, reach: float = REACH,
                  truth: ArmTruth | None = None, timestep: float = 2.5e-4,
                  loaded: str | None = PAYLOAD) -> Pair:
    """Unloaded (trajectory and noise ``2 seed``) and loaded (``2 seed + 1``) records; the
    plant's step ``timestep`` (s, dividing 10 ms); ``loaded=None``: the payload left off (the
    record still tagged with its mass: a wrong tag)."""
    truth = truth or big_arm_truth()
    recs = [simulate_arm_log(duration_s, clock_10_12(duration_s), payload=p,
                             trajectory=gentle_trajectory(truth, s, reach), seed=s, truth=truth,
                             timestep=timestep)
            for p, s in ((None, 2 * seed), (loaded, 2 * seed + 1))]
    return Pair(recs[0], recs[1], truth, seed)


def pair_records(pair: Pair) -> list:
    """The pair as the product's records, the loaded one tagged with its mass only."""
    from orthoglide_ident.identify.records.record import Record

    return [Record.from_arrays(f"{cond}-{pair.seed}", r.stamps_ns, r.q, r.v_tau, cond, mass,
                               r.joint_names)
            for cond, r, mass in (("unloaded", pair.unloaded, 0.0),
                                  ("loaded", pair.loaded, PAYLOAD_MASS))]
