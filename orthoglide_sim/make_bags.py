"""Write the sample bags: an unloaded and a 1.983 kg loaded record, tagged as the recorder tags them.

    python -m orthoglide_sim.make_bags [--duration 10] [--out bags] [--seed 0]

The committed bags/ are 10 s each (small enough for git); `make bags DURATION=60` writes the
2 x 60 s records the benchmarks and the paper use.
"""
from __future__ import annotations

import argparse
import shutil
import sys
from pathlib import Path

from orthoglide_ident import bags
from orthoglide_ident.errors import OrthoglideError
from orthoglide_sim.record import simulate

RUNS = (  # name, payload, trajectory, seed offset
    ("unloaded", "none", "exciting", 0),
    ("loaded", "1.983", "exciting2", 1),
)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m orthoglide_sim.make_bags", description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=10.0, help="seconds per record (default 10)")
    ap.add_argument("--out", type=Path, default=Path("bags"), help="output folder (default bags)")
    ap.add_argument("--seed", type=int, default=0, help="current-noise seed (default 0)")
    args = ap.parse_args(argv)
    try:
        args.out.mkdir(parents=True, exist_ok=True)
        for name, payload, trajectory, k in RUNS:
            rec = simulate(args.duration, payload=payload, trajectory=trajectory, seed=args.seed + k)
            path = args.out / name
            if path.exists():
                shutil.rmtree(path)
            cond = "unloaded" if payload == "none" else "loaded"
            bags.write_bag(path, rec.stamps_ns, rec.q, rec.v_tau, cond, rec.payload_mass,
                           extra={"orthoglide.sim.trajectory": trajectory, "orthoglide.sim.seed": str(args.seed + k)})
            size = sum(f.stat().st_size for f in path.iterdir()) / 1e6
            print(f"{path}: {args.duration:g} s, {cond} {rec.payload_mass:g} kg, {trajectory}, {size:.1f} MB")
    except OrthoglideError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
