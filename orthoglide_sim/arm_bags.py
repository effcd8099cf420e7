"""Write a simulated serial arm's bags: unloaded, the 2 kg payload (TLS) and the 1 kg one (WLS
check), tagged as the recorder tags them, the payloads' frame, centre of mass and inertia in the tag.

    python -m orthoglide_sim.arm_bags --robot ur5 --duration 60 --out DIR [--seed 0] [--params YAML]

Bags DIR/unloaded, DIR/loaded_2kg, DIR/loaded_1kg at 1 kHz, laid out as a ros2_control robot's
(joint_state_broadcaster with ``map_interface_to_joint_state: {effort: current}``): /joint_states
with position, velocity and effort = the drive current (A), by the arm's joint names.
"""
from __future__ import annotations

import argparse
import shutil
import sys
from pathlib import Path

from orthoglide_ident import bags
from orthoglide_ident.errors import OrthoglideError
from orthoglide_sim.arm_description import load_arm
from orthoglide_sim.arm_record import ArmRecord, simulate_arm
from orthoglide_sim.arm_truth import load_truth

RUNS = (  # bag name, payload, trajectory, seed offset
    ("unloaded", None, "exciting1", 0),
    ("loaded_2kg", "2.0", "exciting2", 1),
    ("loaded_1kg", "1.0", "exciting1", 2),
)


def bag_tags(rec: ArmRecord) -> dict[str, str]:
    """custom_data beyond the tag: what was simulated."""
    return {"orthoglide.sim.robot": rec.truth.arm.name, "orthoglide.sim.trajectory": rec.trajectory,
            "orthoglide.sim.seed": str(rec.seed)}


def write_record(path: Path, rec: ArmRecord) -> Path:
    """One record as a tagged bag at ``path`` (replaced if it exists)."""
    if path.exists():
        shutil.rmtree(path)
    condition = "unloaded" if rec.payload is None else "loaded"
    return bags.write_bag(path, rec.stamps_ns, rec.q, rec.v_tau, condition, rec.payload_mass,
                          joint_names=rec.joint_names, extra=bag_tags(rec), layout="joint_states",
                          payload=None if rec.payload is None else rec.payload.tag())


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m orthoglide_sim.arm_bags", description=__doc__.splitlines()[0])
    ap.add_argument("--robot", default="ur5", help="bundled robot name, robot YAML or URDF (default ur5)")
    ap.add_argument("--duration", type=float, default=60.0, help="seconds per record (default 60)")
    ap.add_argument("--out", type=Path, required=True, help="output folder")
    ap.add_argument("--seed", type=int, default=0, help="current-noise seed of the first record (default 0)")
    ap.add_argument("--params", default=None, help="YAML overriding the arm's truth (config/arm_plant.yaml)")
    args = ap.parse_args(argv)
    try:
        truth = load_truth(load_arm(args.robot), args.params)
        args.out.mkdir(parents=True, exist_ok=True)
        for name, payload, trajectory, k in RUNS:
            rec = simulate_arm(args.duration, payload=payload, trajectory=trajectory,
                               seed=args.seed + k, truth=truth)
            path = write_record(args.out / name, rec)
            rms = ", ".join(f"{1e3 * v:.3f}" for v in rec.tracking_rms)
            print(f"{path}: {args.duration:g} s, {rec.payload_mass:g} kg, {trajectory}, tracking rms "
                  f"[{rms}] mrad, {rec.saturated_ticks} saturated ticks")
    except OrthoglideError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
