"""Time to build the base-parameter observation matrix (issues 3, 24): 120 000 samples = 2 min
at 1 kHz.

Prints wall and CPU time and samples/s for [W | payload column], the form the identification
uses, for the Orthoglide's closed form and for the general (Pinocchio) model of the bundled
robots: the UR5 (serial, 6 joints), the planar five-bar and the Orthoglide described to the
general model (closed chains: Newton on the loops per sample, then Gᵀ projection). Each general
model's rows come from Pinocchio's regressor called per sample (model/tree_regressor.py).

The closed form runs on random states (the platform in a ±0.1 m cube); the general models on a
smooth 1 kHz trajectory inside the joint limits (sinusoids per joint), which is what recorded
data is: a closed chain's loops are solved warm-started from the previous sample.

Run: .venv/bin/python bench/model_regressor.py [--samples N] [--repeat R] [--robots ur5,five_bar]
"""
from __future__ import annotations

import argparse
import time

import numpy as np
from _figures import Figures, add_json_option

from orthoglide_ident.model.orthoglide.base import base_model, random_states
from orthoglide_ident.model.registry import load_robot

GENERAL = ("ur5", "five_bar", "orthoglide_general")
RATE_HZ = 1000.0
EMITS_JSON = True  # --json PATH: the figures for bench/write_benchmarks.py
COLUMNS = ["robot", "samples", "[W | W_l]", ("wall best", "s"), ("wall median", "s"),
           ("cpu best", "s"), "samples/s"]


def trajectory(robot, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Sinusoids over 40 % of each joint's range around its middle (1 kHz), q̇ and q̈ exact."""
    lo = np.array([j.lower for j in robot.joints])
    hi = np.array([j.upper for j in robot.joints])
    mid, amp = (lo + hi) / 2, 0.2 * (hi - lo)
    if robot.name == "orthoglide_general":  # its limits are not symmetric about the workspace
        mid, amp = np.full(3, 0.015), np.full(3, 0.08)
    w = 2 * np.pi * np.linspace(0.2, 0.5, robot.n_joints)[None, :]
    t = np.arange(n)[:, None] / RATE_HZ
    phase = np.arange(robot.n_joints)[None, :]
    return (mid + amp * np.sin(w * t + phase), amp * w * np.cos(w * t + phase),
            -amp * w ** 2 * np.sin(w * t + phase))


def timed(f, repeat: int) -> tuple[list[float], list[float], np.ndarray]:
    walls, cpus = [], []
    out = None
    for _ in range(repeat):
        w0, c0 = time.perf_counter(), time.process_time()
        out = f()
        walls.append(time.perf_counter() - w0)
        cpus.append(time.process_time() - c0)
    return walls, cpus, out


def row(name: str, n: int, shape: tuple, walls: list[float], cpus: list[float]) -> list[str]:
    """The cells of one robot's row (COLUMNS)."""
    best = min(walls)
    return [name, str(n), str(shape), f"{best:.3f}", f"{np.median(walls):.3f}",
            f"{min(cpus):.3f}", f"{n / best:,.0f}"]


def printed(cells: list[str]) -> str:
    name, n, shape, best, median, cpu, rate = cells
    return f"{name:<20} {n:>9} {shape:>16} {best:>9}s {median:>11}s {cpu:>8}s {rate:>11}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--samples", type=int, default=120_000)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--robots", default=",".join(GENERAL), help="general-model robots to time")
    add_json_option(ap)
    args = ap.parse_args()
    t0 = time.perf_counter()
    bm = base_model()
    loads = [f"orthoglide (closed form, QR on 600 random states) {time.perf_counter() - t0:.2f} s, "
             f"n_b = {bm.n_b}"]
    q, qd, qdd = random_states(args.samples, seed=1)
    lines = [row("orthoglide", args.samples, (bm.n_b + 1, 3, args.samples),
                 *timed(lambda: bm.observation_block(q, qd, qdd), args.repeat)[:2])]
    for name in filter(None, args.robots.split(",")):
        t0 = time.perf_counter()
        robot = load_robot(name)
        loads.append(f"{name} (general, QR on random states) {time.perf_counter() - t0:.2f} s, "
                     f"n_b = {robot.n_b} of {len(robot.standard_names)} standard")
        q, qd, qdd = trajectory(robot, args.samples)
        out = np.empty((robot.n_b + 1, robot.n_joints, args.samples))
        walls, cpus, _ = timed(lambda: robot.observation_block(q, qd, qdd, out=out), args.repeat)
        lines.append(row(name, args.samples, out.shape, walls, cpus))
    print("models:\n  " + "\n  ".join(loads))
    print(f"{'robot':<20} {'samples':>9} {'[W | W_l]':>16} {'wall best':>10} {'wall median':>12} "
          f"{'cpu best':>9} {'samples/s':>11}")
    print("\n".join(printed(cells) for cells in lines))
    figs = Figures(before="new (issues 3, 24)")
    table = figs.table(f"{args.samples} samples → [W | W_l], best of {args.repeat}", COLUMNS)
    for cells in lines:
        table.row(*cells)
    figs.notes += [f"model load: {x}" for x in loads]
    figs.write(args.json)


if __name__ == "__main__":
    main()
