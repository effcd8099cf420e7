"""Time to build the base-parameter observation matrix (issue 3): 120 000 samples = 2 min at 1 kHz.

Prints wall and CPU time and samples/s for W (3 N, n_b) plus the payload-mass column, the form the
identification uses. Run: .venv/bin/python bench/model_regressor.py [--samples N] [--repeat R]
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from orthoglide_ident.model.base import base_model, random_states


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--samples", type=int, default=120_000)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    t0 = time.perf_counter()
    bm = base_model()
    t_base = time.perf_counter() - t0
    q, qd, qdd = random_states(args.samples, seed=1)
    walls, cpus = [], []
    for _ in range(args.repeat):
        w0, c0 = time.perf_counter(), time.process_time()
        W, w_m7 = bm.observation(q, qd, qdd)
        walls.append(time.perf_counter() - w0)
        cpus.append(time.process_time() - c0)
    best = min(walls)
    print(f"base model (QR on 600 random states): {t_base:.3f} s, n_b = {bm.n_b}")
    print(f"{'samples':>9} {'W shape':>14} {'wall best':>10} {'wall median':>12} {'cpu best':>9} {'samples/s':>11}")
    print(
        f"{args.samples:>9} {str(W.shape):>14} {best:>9.3f}s {np.median(walls):>11.3f}s {min(cpus):>8.3f}s "
        f"{args.samples / best:>11,.0f}"
    )


if __name__ == "__main__":
    main()
