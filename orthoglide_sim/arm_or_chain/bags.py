"""Write a simulated robot's bags: unloaded, the heavier payload (TLS) and the lighter one (WLS
check), tagged as the recorder tags them, the payloads' frame, centre of mass and inertia in the
tag.

    python -m orthoglide_sim.arm_or_chain.bags --robot ur5 --duration 60 --out DIR [--seed 0]
        [--params YAML]
    python -m orthoglide_sim.arm_or_chain.bags --robot five_bar --duration 60 --out DIR

A serial arm (arm_record, MuJoCo): bags DIR/unloaded, DIR/loaded_2kg, DIR/loaded_1kg. A closed
chain (a robot YAML with loops: chain_record, MuJoCo with its loops as equality constraints):
the five-bar's DIR/unloaded, DIR/loaded_1kg (TLS), DIR/loaded_0.5kg (WLS). At 1 kHz, laid out
as a ros2_control robot's (joint_state_broadcaster with ``map_interface_to_joint_state: {effort:
current}``): /joint_states with position, velocity and effort = the drive current (A), by the
actuated joints' names.
"""
from __future__ import annotations

import argparse
import shutil
import sys
from pathlib import Path

from orthoglide_ident import bags
from orthoglide_ident.errors import OrthoglideError
from orthoglide_sim.arms.description import load_arm
from orthoglide_sim.arms.record import ArmRecord, simulate_arm
from orthoglide_sim.arms.truth import ArmTruth, load_truth
from orthoglide_sim.chains.description import is_closed_chain, load_chain
from orthoglide_sim.chains.record import simulate_chain
from orthoglide_sim.chains.truth import load_chain_truth

RUNS = (  # bag name, payload, trajectory, seed offset (the UR5's: runs_for gives every robot's)
    ("unloaded", None, "exciting1", 0),
    ("loaded_2kg", "2.0", "exciting2", 1),
    ("loaded_1kg", "1.0", "exciting1", 2),
)


def runs_for(truth: ArmTruth) -> tuple[tuple[str, str | None, str, int], ...]:
    """The records of a robot: unloaded on exciting1, its heaviest payload on exciting2 (the
    TLS's loaded record), the next one on exciting1 (the WLS check); RUNS for the UR5."""
    heavy = sorted(truth.payloads.values(), key=lambda p: -p.mass)[:2]
    trajectories = ("exciting2", "exciting1")
    return (("unloaded", None, "exciting1", 0),) + tuple(
        (f"loaded_{p.mass:g}kg", p.name, trajectories[k], k + 1) for k, p in enumerate(heavy))


def bag_tags(rec: ArmRecord) -> dict[str, str]:
    """custom_data beyond the tag: what was simulated."""
    return {"orthoglide.sim.robot": rec.truth.arm.name, "orthoglide.sim.trajectory": rec.trajectory,
            "orthoglide.sim.seed": str(rec.seed)}


def write_record(path: Path, rec: ArmRecord, mass_only: bool = False) -> Path:
    """One record as a tagged bag at ``path`` (replaced if it exists); ``mass_only``: the
    payload tagged with its mass alone, as a weighed payload of unknown CoM is (Sect. 4.3)."""
    if path.exists():
        shutil.rmtree(path)
    condition = "unloaded" if rec.payload is None else "loaded"
    payload = None if rec.payload is None or mass_only else rec.payload.tag()
    return bags.write_bag(path, rec.stamps_ns, rec.q, rec.v_tau, condition, rec.payload_mass,
                          joint_names=rec.joint_names, extra=bag_tags(rec), layout="joint_states",
                          payload=payload)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m orthoglide_sim.arm_or_chain.bags", description=__doc__.splitlines()[0]
    )
    ap.add_argument(
        "--robot", default="ur5", help="bundled robot name, robot YAML or URDF (default ur5)"
    )
    ap.add_argument("--duration", type=float, default=60.0, help="seconds per record (default 60)")
    ap.add_argument("--out", type=Path, required=True, help="output folder")
    ap.add_argument(
        "--seed", type=int, default=0, help="current-noise seed of the first record (default 0)"
    )
    ap.add_argument("--params", default=None, help="YAML overriding the robot's truth "
                    "(config/arm_plant.yaml, config/five_bar_plant.yaml)")
    args = ap.parse_args(argv)
    try:
        if is_closed_chain(args.robot):
            truth, simulate = load_chain_truth(load_chain(args.robot), args.params), simulate_chain
        else:
            truth, simulate = load_truth(load_arm(args.robot), args.params), simulate_arm
        args.out.mkdir(parents=True, exist_ok=True)
        for name, payload, trajectory, k in runs_for(truth):
            rec = simulate(args.duration, payload=payload, trajectory=trajectory,
                           seed=args.seed + k, truth=truth)
            path = write_record(args.out / name, rec)
            rms = ", ".join(f"{1e3 * v:.3f}" for v in rec.tracking_rms)
            print(
                f"{path}: {args.duration:g} s, {rec.payload_mass:g} kg, {trajectory}, tracking rms "
                f"[{rms}] mrad, {rec.saturated_ticks} saturated ticks"
            )
    except OrthoglideError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
