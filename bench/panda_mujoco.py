"""A 7-axis MuJoCo plant end to end (issue 48): the example-robot-data Panda, fingers locked,
``excite design`` with its defaults and the 2 kg payload's mass, the unloaded and the loaded run
simulated on MuJoCo (the plant's own parameters, gains 2-6 % off nominal, rotor inertia,
friction; tests/panda_mujoco_plant.py), identified by IDIM-TLS through the robot file.

    python bench/panda_mujoco.py [--fast] [--seeds 0,1,2]

Per seed (the design's search and the current noise): per joint the gain's error in % over its σ
in %, the error in σ, and the wall time of each stage (design, simulate both runs, identify).
``--fast``: the slow test's design (2 periods of 5 s, 3 random shapes, 30 search steps).
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
import panda_mujoco_plant as P  # noqa: E402


def report(seed: int, run: P.RunFigures) -> None:
    print(f"seed {seed}: {run.run_s:g} s + {run.run_s:g} s, {run.saturated_ticks} saturated ticks; "
          + ", ".join(f"{k} {v:.1f} s" for k, v in run.seconds.items()))
    print("  nominal off  " + "  ".join(f"{100 * x:+14.2f}%" for x in run.nominal / run.truth - 1))
    print("  error/σ      " + "  ".join(f"{100 * e:+7.3f}%/{100 * s:.3f}%"
                                        for e, s in zip(run.error, run.rel_std)))
    print("  error in σ   " + "  ".join(f"{e / s:+14.2f}σ" for e, s in zip(run.error, run.rel_std))
          + ("" if run.determined.all() else "   not all determined"))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--fast", action="store_true")
    ap.add_argument("--seeds", default="0,1,2")
    args = ap.parse_args()
    options = P.DESIGN_FAST if args.fast else P.DESIGN_DEFAULTS
    worst = []
    for seed in map(int, args.seeds.split(",")):
        with tempfile.TemporaryDirectory() as d:
            run = P.end_to_end(Path(d), options, seed)
        if seed == int(args.seeds.split(",")[0]):
            print("joints       " + "  ".join(f"{j[-6:]:>15}" for j in run.joints))
        report(seed, run)
        worst.append(np.abs(run.error / run.rel_std).max())
    print(f"worst |error| / σ over seeds: {max(worst):.2f}")


if __name__ == "__main__":
    main()
