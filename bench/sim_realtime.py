"""Real-time factor of the simulated Orthoglide with its controller (plant at 10 kHz, PID at 1 kHz).

    PYTHONPATH=. .venv/bin/python bench/sim_realtime.py [--duration 10]
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from orthoglide_sim.record import simulate


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=10.0, help="simulated seconds per run (default 10)")
    args = ap.parse_args()
    t0 = time.perf_counter()
    simulate(1.0, trajectory="test2")  # compile
    t_compile = time.perf_counter() - t0
    print(f"compile + first second: {t_compile:.1f} s")
    print(f"{'controller':<10} {'payload':<8} {'trajectory':<10} {'sim s':>6} {'wall s':>7} {'x real time':>11} {'rms err um':>18}")
    for controller, payload, traj in (("pid", "none", "exciting"), ("pid_ff", "1.983", "test2")):
        simulate(1.0, payload, traj, controller)  # compile this controller
        t0 = time.perf_counter()
        rec = simulate(args.duration, payload, traj, controller)
        wall = time.perf_counter() - t0
        rms = np.sqrt(np.mean((rec.q_ref - rec.q_true) ** 2, axis=0)) * 1e6
        print(f"{controller:<10} {payload:<8} {traj:<10} {args.duration:>6.1f} {wall:>7.2f} {args.duration / wall:>11.1f} "
              f"{np.array2string(rms, precision=0):>18}")


if __name__ == "__main__":
    main()
