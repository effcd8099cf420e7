"""The model's rows timed where they are used (issue 48): Pinocchio's
``computeJointTorqueRegressor`` called per sample (model/tree_regressor.py). Until this round a
vectorised recursive Newton–Euler regressor (model/rnea_regressor.py) stood beside it; its
figures against Pinocchio's are in docs/benchmarks.md ("Pinocchio's regressor only").

    python bench/regressor_paths.py [--repeat 3] [--seconds 20]

``identify`` (IDIM-TLS, the simulated UR5's unloaded and 2 kg records of
``--seconds`` s each, and the locked Panda's, tests/locked_panda.py, as long), ``excite design``
(the UR5, 2 kg, 2 periods, 5 random shapes, 50 steps), and the bare observation matrix of
20 000 samples: best wall and CPU time over ``--repeat``. "load": the model loaded anew (its QR
on random states uses the rows too); the other stages reuse it.
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
import locked_panda as L  # noqa: E402
from live_helpers import as_record  # noqa: E402

from orthoglide_ident.cli import main as cli  # noqa: E402
from orthoglide_ident.identify import identify_records  # noqa: E402
from orthoglide_ident.model import registry  # noqa: E402
from orthoglide_ident.model.registry import load_robot  # noqa: E402
from orthoglide_sim.arms.record import simulate_arm  # noqa: E402

DESIGN = ("--payload-mass", "2", "--periods", "2", "--restarts", "5", "--steps", "50")


def best(f, repeat: int) -> tuple[float, float]:
    walls, cpus = [], []
    for _ in range(repeat):
        w, c = time.perf_counter(), time.process_time()
        f()
        walls.append(time.perf_counter() - w)
        cpus.append(time.process_time() - c)
    return min(walls), min(cpus)


def cases(seconds: float, folder: Path) -> dict:
    recs = [as_record(simulate_arm(seconds, payload=p, trajectory=t, seed=s), n)
            for p, t, s, n in ((None, "exciting1", 0, "u"), ("2.0", "exciting2", 1, "l"))]
    out = folder / "traj.yaml"
    q = np.random.default_rng(0).uniform(-1, 1, (3, 20_000, 6))
    panda_file = L.robot_file(folder)
    panda = L.records(seconds, 0.01)
    return {
        "load ur5": lambda: (registry._load.cache_clear(), load_robot("ur5")),
        "identify ur5": lambda: identify_records(recs, model=load_robot("ur5")),
        "identify panda": lambda: identify_records(panda, model=load_robot(panda_file)),
        "excite design ur5": lambda: cli(["excite", "design", "--robot", "ur5", "--out",
                                          str(out), *DESIGN]),
        "W of 20 000 samples": lambda: load_robot("ur5").observation_block(*q),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--seconds", type=float, default=20.0)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as d:
        todo = cases(args.seconds, Path(d))
        times = {name: best(f, args.repeat) for name, f in todo.items()}
    print(f"{'stage':<22} {'wall':>8} {'cpu':>8}")
    for name, (wall, cpu) in times.items():
        print(f"{name:<22} {wall:>7.2f}s {cpu:>7.2f}s")


if __name__ == "__main__":
    main()
