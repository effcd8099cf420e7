"""Exciting-trajectory design (orthoglide-ident excite design) on the UR5 and the five-bar.

    PYTHONPATH=. .venv/bin/python bench/excitation_design.py [--robots ur5,five_bar] [--seeds 3]
                                                             [--restarts 20] [--steps 400]
                                                             [--search walk|gradient]

Per robot, the design with its defaults (12 periods of 5 s per run, 5 harmonics, the plant's
payload with its known CoM and inertia: UR5 2 kg, five-bar 1 kg) and:

- the criterion (log max σ(g)/g + ¼ log κ), the worst gain σ and κ of the design against the
  median of the random shapes made feasible (20 restarts), and the design's wall time;
- the worst slack to each limit on the 1 ms grid of ``excite check`` less the margin it keeps
  (≥ 0), and the smallest distance between checked bodies (> 0);
- predicted vs achieved σ of the gains: the designed runs simulated on the MuJoCo plants
  (orthoglide_sim.demos.designed_runs: the plants' own parameters, gains off nominal, 0.5 % current
  noise, encoders) for ``--seeds`` seeds and identified by the product's TLS; the prediction is
  eq. (39) at the nominal model with each run's simulated current noise. Printed per joint:
  predicted σ, the identification's eq. (39) σ and its honest σ (means over seeds), and the sd of
  the gain errors over seeds (a rough figure with few seeds); the prediction's noise comes from a
  previous identification of the simulator's own 20 s records (another trajectory: what a user
  has before designing), and, "same", from seed 0's identification of the designed runs.
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402
from _figures import Figures, add_json_option  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from identify.test_on_arm import as_record  # noqa: E402

from orthoglide_ident.excite.collision import CollisionModel  # noqa: E402
from orthoglide_ident.excite.design import DesignOptions, design  # noqa: E402
from orthoglide_ident.excite.limits import read_limits  # noqa: E402
from orthoglide_ident.excite.prediction import (  # noqa: E402
    DEFAULT_CURRENT_NOISE,
    RunSamples,
    noise_from_result,
    predict,
)
from orthoglide_ident.excite.summary import with_extras  # noqa: E402
from orthoglide_ident.identify import identify_records  # noqa: E402
from orthoglide_ident.model.registry import load_robot  # noqa: E402
from orthoglide_ident.model.robot import Payload  # noqa: E402
from orthoglide_sim.arm_or_chain.session import robot_truth  # noqa: E402
from orthoglide_sim.arms.record import simulate_arm  # noqa: E402
from orthoglide_sim.chains.record import simulate_chain  # noqa: E402
from orthoglide_sim.demos.designed_runs import simulate_designed  # noqa: E402

PAYLOADS = {"ur5": "2.0", "five_bar": "1.0"}  # the plants' off-centre payload bodies
EMITS_JSON = True  # --json PATH: the figures for bench/write_benchmarks.py
FIGS = Figures(before="new; the walk search before the gradient one: docs/benchmarks.md, issue 46")


def plant_payload(truth, name: str) -> Payload:
    p = truth.payloads[name]
    I = p.body.inertia
    return Payload(p.mass, p.frame, tuple(p.body.com),
                   (I[0, 0], I[0, 1], I[0, 2], I[1, 1], I[1, 2], I[2, 2]))


def designed(robot_name: str, restarts: int, steps: int | None, search: str = "gradient"):
    robot = load_robot(robot_name)
    truth = robot_truth(robot_name)
    limits = read_limits(robot)
    collision = CollisionModel(robot, "mesh")
    opt = DesignOptions(plant_payload(truth, PAYLOADS[robot_name]),
                        np.full(robot.n_joints, DEFAULT_CURRENT_NOISE), restarts=restarts,
                        steps=steps, search=search)
    d = design(robot, limits, collision, opt, progress=lambda s: print("  " + s, file=sys.stderr))
    return robot, truth, limits, collision, d


def print_design(name: str, d) -> None:
    rand = d.random
    med = lambda f: float(np.median([f(e) for e in rand])) if rand else float("nan")  # noqa: E731
    p = d.prediction
    print(f"\n{name}: designed in {d.seconds:.1f} s ({d.problem.opt.restarts} restarts, "
          f"{d.problem.opt.steps} steps; wall time on the shared 2-core machine)")
    print(f"  {'':<24}{'criterion':>10}{'worst gain σ %':>16}{'κ':>9}")
    print(f"  {'designed':<24}{d.criterion:>10.3f}{100 * p.worst_gain:>16.4f}{p.condition:>9.1f}")
    table = FIGS.table(f"{name}: designed in {d.seconds:.1f} s ({d.problem.opt.restarts} "
                       f"restarts, {d.problem.opt.steps} steps)",
                       ["", "criterion", ("worst gain σ", "%"), "κ"])
    table.row("designed", f"{d.criterion:.3f}", f"{100 * p.worst_gain:.4f}", f"{p.condition:.1f}")
    table.row(f"random feasible (median of {len(rand)})", f"{med(lambda e: e.criterion):.3f}",
              f"{100 * med(lambda e: e.prediction.worst_gain):.4f}",
              f"{med(lambda e: e.prediction.condition):.1f}")
    print(
        f"  {f'random feasible (median of {len(rand)})':<24}"
        f"{med(lambda e: e.criterion):>10.3f}{100 * med(lambda e: e.prediction.worst_gain):>16.4f}"
        f"{med(lambda e: e.prediction.condition):>9.1f}"
    )
    print("  1 ms check (worst slack, margin kept, worst - margin):")
    for kind, s in d.check.by_kind().items():
        print(f"    {kind:<13} {s.value:>9.4g} {s.required:>7.3g} {s.value - s.required:>+9.4g}  "
              f"{s.where}")
        FIGS.note(f"{name}, 1 ms check, {kind}: worst slack {s.value:.4g}, margin kept "
                  f"{s.required:.3g}, worst - margin {s.value - s.required:+.4g} ({s.where})")


def previous_record_noise(robot, truth) -> np.ndarray:
    """A (n,): --noise-from of an identification of the simulator's own exciting1 (unloaded) and
    exciting2 (with the payload) 20 s records: what a user has before designing."""
    sim = simulate_chain if robot.closure is not None else simulate_arm
    runs = [sim(20.0, robot.name, payload=p, trajectory=t, seed=100 + k, truth=truth)
            for k, (t, p) in enumerate((("exciting1", None), ("exciting2", PAYLOADS[robot.name])))]
    res = identify_records([as_record(r, f"prev{k}") for k, r in enumerate(runs)], model=robot)
    return noise_from_result(res.to_json(), robot.joint_names, "previous record")


def achieved(robot, truth, d, limits, collision, seeds: int) -> None:
    traj, payload_name = with_extras(d, limits, collision, "plant"), PAYLOADS[robot.name]
    prev = previous_record_noise(robot, truth)
    print(f"  current noise from a previous record (A at 1 kHz): {np.round(prev, 4).tolist()}")
    load = d.problem.opt.payload
    t = np.linspace(0.0, traj.period_s, 400, endpoint=False)
    errs, honest, paper, pred, same = [], [], [], [], None
    g_true = np.array([truth.drives[j].g_tau for j in robot.joint_names])
    for seed in range(seeds):
        t0 = time.perf_counter()
        u = simulate_designed(traj, "unloaded", truth, None, seed=2 * seed)
        lo = simulate_designed(traj, "loaded", truth, payload_name, seed=2 * seed + 1)
        res = identify_records([as_record(u, f"u{seed}"), as_record(lo, f"l{seed}")], model=robot)
        g = np.array([x.value for x in res.drive_gains])
        errs.append(g / g_true - 1)
        honest.append([x.rel_std for x in res.drive_gains])
        paper.append([x.rel_std_paper for x in res.drive_gains])
        runs = [RunSamples(*traj.evaluate(name, t), traj.duration, pl)
                for name, pl in (("unloaded", None), ("loaded", load))]
        pred.append(predict(robot, runs, prev, lag=True, period_s=traj.period_s).gain_rel_std)
        if same is None:  # a previous record on the designed trajectory itself: seed 0's
            same = predict(robot, runs, noise_from_result(res.to_json(), robot.joint_names,
                                                          "seed 0"),
                           lag=True, period_s=traj.period_s).gain_rel_std
        print(f"  seed {seed}: simulated and identified in {time.perf_counter() - t0:.0f} s; "
              f"saturated ticks {u.saturated_ticks + lo.saturated_ticks}", file=sys.stderr)
    errs, honest, paper, pred = map(np.array, (errs, honest, paper, pred))
    sd = errs.std(axis=0, ddof=1) if seeds > 1 else np.full(errs.shape[1], np.nan)
    print(f"  predicted vs achieved σ of the gains (%), {traj.duration:g} s + {traj.duration:g} s, "
          f"{seeds} seeds:")
    print(f"    {'joint':<20}{'predicted':>10}{'eq. 39':>9}{'honest':>9}{'sd(err)':>9}"
          f"{'mean err':>10}{'eq39/pred':>10}{'pred same':>10}{'eq39/same':>10}")
    table = FIGS.table(f"{robot.name}: predicted vs achieved σ of the gains, {traj.duration:g} s + "
                       f"{traj.duration:g} s, {seeds} seeds (predicted: noise from a previous "
                       "identification of the simulator's own records; pred same: from seed 0's "
                       "identification of these runs)",
                       ["joint", ("predicted", "%"), ("eq. 39", "%"), ("honest", "%"),
                        ("sd(err)", "%"), ("mean err", "%"), "eq39/pred", ("pred same", "%"),
                        "eq39/same"])
    for j, name in enumerate(robot.joint_names):
        print(
            f"    {name:<20}{100 * pred[:, j].mean():>10.4f}{100 * paper[:, j].mean():>9.4f}"
            f"{100 * honest[:, j].mean():>9.4f}{100 * sd[j]:>9.4f}{100 * errs[:, j].mean():>+10.4f}"
            f"{paper[:, j].mean() / pred[:, j].mean():>10.2f}{100 * same[j]:>10.4f}"
            f"{paper[:, j].mean() / same[j]:>10.2f}"
        )
        table.row(name, f"{100 * pred[:, j].mean():.4f}", f"{100 * paper[:, j].mean():.4f}",
                  f"{100 * honest[:, j].mean():.4f}", f"{100 * sd[j]:.4f}",
                  f"{100 * errs[:, j].mean():+.4f}",
                  f"{paper[:, j].mean() / pred[:, j].mean():.2f}", f"{100 * same[j]:.4f}",
                  f"{paper[:, j].mean() / same[j]:.2f}")
    print("  (predicted: noise from a previous identification of the simulator's own records; "
          "pred same: from seed 0's identification of these runs)")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robots", default="ur5,five_bar")
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--restarts", type=int, default=20)
    ap.add_argument("--steps", type=int, default=None)
    ap.add_argument("--search", default="gradient", help="gradient | walk (excite/gradient.py)")
    add_json_option(ap)
    args = ap.parse_args()
    for name in args.robots.split(","):
        robot, truth, limits, collision, d = designed(name, args.restarts, args.steps,
                                                      args.search)
        print_design(name, d)
        if args.seeds:
            achieved(robot, truth, d, limits, collision, args.seeds)
    FIGS.write(args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
