"""Accuracy of the identification of a simulated serial arm and honesty of its σ, over seeds.

    PYTHONPATH=. .venv/bin/python bench/arm_accuracy.py [--robot ur5] [--seconds 60] [--seeds 5]
        [--model orthoglide_ident/robots/ur5.urdf]

Per seed: the MuJoCo arm (orthoglide_sim: its own true inertials, armature, damping,
frictionloss, offsets, gains off nominal, 0.5 % current noise, 2^19-count encoders) records
--seconds unloaded, with the 2 kg off-centre payload (TLS, its mass, CoM and inertia known) and
with the 1 kg one (WLS check); the product identifies them with ``--robot`` (the general
Pinocchio model) exactly as ``orthoglide-ident identify`` does (in memory, no bags). Prints per
seed the worst gain error, the largest |error| / honest σ, the 1 kg payload re-estimated by WLS
with the identified and with the nominal gains; then the mean ± sd of each gain's error and the
share of gains within 2 and 3 honest σ (issue 24's figures: every gain within 0.5 % and 3 σ,
the 1 kg payload within 2 %). ``--model`` gives the product another description of the same
arm than the simulated one, e.g. the plain URDF (no nominal gains: issue 32's figure, every gain
within 0.5 % and 3 honest σ without a gain band).
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from _figures import Figures, add_json_option  # noqa: E402
from identify.test_on_arm import as_record  # noqa: E402

from orthoglide_ident.identify import identify_records  # noqa: E402
from orthoglide_ident.model.registry import load_robot  # noqa: E402
from orthoglide_sim.arms.record import simulate_arm  # noqa: E402

EMITS_JSON = True  # --json PATH: the figures for bench/write_benchmarks.py
BEFORE = {  # what the figures were, by the description the product is given
    "": "new (issue 24)",
    "orthoglide_ident/robots/ur5.urdf": "refused: \"implausible (expected 0.1-10)\" (issue 32)",
}
COLUMNS = ["seed", ("worst gain error", "%"), ("max |z|", "σ"), ("σ, mean", "%"),
           ("WLS 1 kg error", "%"), ("with the nominal gains", "%"), ("identify", "s")]


def one_seed(robot: str, seconds: float, seed: int, model) -> dict:
    runs = {
        "unloaded": ("exciting1", None),
        "2kg": ("exciting2", "2.0"),
        "1kg": ("exciting1", "1.0"),
    }
    recs, truth = {}, None
    for k, (name, (traj, payload)) in enumerate(runs.items()):
        sim = simulate_arm(seconds, robot, payload=payload, trajectory=traj, seed=3 * seed + k)
        recs[name], truth = as_record(sim, f"{name}-{seed}"), sim.truth
    t0 = time.perf_counter()
    tls = identify_records([recs["unloaded"], recs["2kg"]], model=model)
    t_id = time.perf_counter() - t0
    g = np.array([x.value for x in tls.drive_gains])
    g_true = np.array([truth.drives[j].g_tau for j in model.joint_names])
    err = g / g_true - 1
    sigma = np.array([x.rel_std for x in tls.drive_gains])
    wls = identify_records(
        [recs["unloaded"], recs["1kg"]], method="wls", gains=list(g), model=model
    )
    nom = identify_records([recs["unloaded"], recs["1kg"]], method="wls", model=model)
    return {"err": err, "z": err / sigma, "sigma": sigma, "t": t_id,
            "wls": wls.payload_mass.value - 1.0, "wls_nominal": nom.payload_mass.value - 1.0}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robot", default="ur5")
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--model", default="", help="the robot file the product is given (default "
                    "--robot); e.g. orthoglide_ident/robots/ur5.urdf, the plain URDF")
    add_json_option(ap)
    args = ap.parse_args()
    model = load_robot(args.model or args.robot)
    print(
        f"{args.robot} (given as {args.model or args.robot}): {args.seconds:g} s unloaded + "
        f"{args.seconds:g} s with 2 kg (TLS), "
        f"1 kg for WLS; {args.seeds} seeds"
    )
    print(f"{'seed':>4} {'worst gain err %':>16} {'max |z|':>8} {'σ % (mean)':>10} "
          f"{'WLS 1 kg err %':>14} {'nominal gains %':>15} {'identify s':>10}")
    figs = Figures(before=BEFORE.get(args.model, ""))
    table = figs.table(f"{args.robot} given as {args.model or args.robot}: {args.seconds:g} s "
                       f"unloaded + {args.seconds:g} s with 2 kg (TLS), 1 kg for WLS", COLUMNS)
    rows = []
    for seed in range(args.seeds):
        r = one_seed(args.robot, args.seconds, seed, model)
        rows.append(r)
        cells = (f"{100 * np.abs(r['err']).max():.3f}", f"{np.abs(r['z']).max():.2f}",
                 f"{100 * r['sigma'].mean():.3f}", f"{100 * r['wls']:+.3f}",
                 f"{100 * r['wls_nominal']:+.3f}", f"{r['t']:.2f}")
        print(f"{seed:>4} {cells[0]:>16} {cells[1]:>8} {cells[2]:>10} {cells[3]:>14} "
              f"{cells[4]:>15} {cells[5]:>10}")
        table.row(seed, *cells)
    err = np.array([r["err"] for r in rows])
    z = np.abs(np.array([r["z"] for r in rows]))
    for line in (
        "gain error mean ± sd (%): " + ", ".join(
            f"{j} {100 * m:+.3f} ± {100 * s:.3f}" for j, m, s in zip(
                model.joint_names, err.mean(0),
                err.std(0, ddof=1) if len(rows) > 1 else 0 * err[0])),
        f"gains within 2 honest σ: {100 * np.mean(z <= 2):.0f} %, within 3: "
        f"{100 * np.mean(z <= 3):.0f} % (max {z.max():.2f}); worst gain "
        f"{100 * np.abs(err).max():.3f} % (bar 0.5 %); WLS 1 kg worst "
        f"{100 * max(abs(r['wls']) for r in rows):.3f} % (bar 2 %), with nominal gains "
        f"{100 * max(abs(r['wls_nominal']) for r in rows):.3f} %",
    ):
        print(line)
        figs.note(line)
    figs.write(args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
