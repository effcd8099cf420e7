"""Write the sample bags: an unloaded and a 1.983 kg loaded record, tagged as the recorder tags
them.

    python -m orthoglide_sim.orthoglide.make_bags [--duration 10] [--out bags] [--seed 0] [--profile
    realistic]

The committed bags/ are 10 s each (small enough for git); `make bags DURATION=60` writes the
2 x 60 s records the benchmarks and the paper use. ``--profile realistic`` simulates a drive with
what the IDIM lacks (current-loop lag, Stribeck breakaway, screw friction ripple, 2 mA noise).
"""
from __future__ import annotations

import argparse
import shutil
import sys
from pathlib import Path

from orthoglide_ident import bags
from orthoglide_ident.errors import OrthoglideError
from orthoglide_ident.model.registry import load_robot
from orthoglide_sim.orthoglide.record import simulate
from orthoglide_sim.orthoglide.truth import load_parameters

ORTHOGLIDE = load_robot("orthoglide")  # the robot these records are of

RUNS = (  # name, payload, trajectory, seed offset
    ("unloaded", "none", "exciting", 0),
    ("loaded", "1.983", "exciting2", 1),
)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m orthoglide_sim.orthoglide.make_bags", description=__doc__.splitlines()[0]
    )
    ap.add_argument("--duration", type=float, default=10.0, help="seconds per record (default 10)")
    ap.add_argument("--out", type=Path, default=Path("bags"), help="output folder (default bags)")
    ap.add_argument("--seed", type=int, default=0, help="current-noise seed (default 0)")
    ap.add_argument("--profile", default=None,
                    help="plant profile: nominal (default), realistic, or one named in --params")
    ap.add_argument(
        "--params", default=None, help="YAML overriding the true parameters (config/plant.yaml)"
    )
    args = ap.parse_args(argv)
    try:
        params = load_parameters(args.params)
        params.plant_profile(args.profile)  # unknown profile: say so before simulating
        args.out.mkdir(parents=True, exist_ok=True)
        for name, payload, trajectory, k in RUNS:
            rec = simulate(
                args.duration,
                payload=payload,
                trajectory=trajectory,
                seed=args.seed + k,
                params=params,
                profile=args.profile,
            )
            path = args.out / name
            if path.exists():
                shutil.rmtree(path)
            cond = "unloaded" if payload == "none" else "loaded"
            bags.write_bag(
                path,
                rec.stamps_ns,
                rec.q,
                rec.v_tau,
                cond,
                rec.payload_mass,
                extra={
                    "orthoglide.sim.trajectory": trajectory,
                    "orthoglide.sim.seed": str(args.seed + k),
                    "orthoglide.sim.profile": rec.profile,
                },
                joint_names=ORTHOGLIDE.joint_names,
            )
            size = sum(f.stat().st_size for f in path.iterdir()) / 1e6
            print(f"{path}: {args.duration:g} s, {cond} {rec.payload_mass:g} kg, {trajectory}, "
                  f"profile {rec.profile}, {size:.1f} MB")
    except OrthoglideError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
