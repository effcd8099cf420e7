"""A payload known by its mass only (paper Sect. 4.3) vs the same payload taken for a point mass.

    PYTHONPATH=. .venv/bin/python bench/payload_by_mass.py [--robot ur5] [--seconds 60] [--seeds 3]

Per seed: the MuJoCo arm (orthoglide_sim: its own inertials, drives, 0.5 % current noise) records
--seconds unloaded and --seconds with a 2 kg payload whose CoM is 5 cm from the flange (30, 0,
40 mm in tool0: 3 cm off the last axis), tagged with its mass only. The product identifies it
as ``orthoglide-ident identify`` does (in memory): the payload's first moments and inertia join
the unknowns, the mass alone scales the gains (eq. 34's W_kl m_l). Prints the worst gain error,
the largest |error| / honest σ, the identified CoM's error and its |error| / σ; then the same
records with ``payload_known: point`` (the point mass at the flange the product assumed before):
what the checked identification makes of it (refused, or a partial answer naming the gains the
point cannot scale), and its gain error with the checks off. Figures of
issue 32: gains within 0.5 % and 3 σ, CoM within 5 mm.
"""
from __future__ import annotations

import argparse
import sys
import time

import numpy as np
from _figures import Figures, add_json_option

from orthoglide_ident.errors import OrthoglideError
from orthoglide_ident.identify import IdentifyOptions, Record, identify_records
from orthoglide_ident.model.registry import load_robot
from orthoglide_sim.arms.description import load_arm
from orthoglide_sim.arms.record import simulate_arm
from orthoglide_sim.arms.truth import OFFSET_COM, OFFSET_PAYLOAD, load_truth, with_offset_payload

EMITS_JSON = True  # --json PATH: the figures for bench/write_benchmarks.py
BEFORE = "before issue 32, the payload taken for a point mass at the flange: the last two columns"
COLUMNS = ["seed", ("worst gain", "%"), ("max |z|", "σ"), ("CoM error x, y, z", "mm"),
           ("CoM max |z|", "σ"), ("identify", "s"), ("point: worst gain", "%"), "point, checked"]


def _record(sim, name: str) -> Record:
    """What a bag tagged with the payload's mass only holds (no frame, CoM or inertia)."""
    cond = "unloaded" if sim.payload is None else "loaded"
    return Record.from_arrays(name, sim.stamps_ns, sim.q, sim.v_tau, cond, sim.payload_mass,
                              sim.joint_names)


def one_seed(robot: str, seconds: float, seed: int, model, truth) -> dict:
    un = simulate_arm(seconds, payload=None, trajectory="exciting1", seed=2 * seed, truth=truth)
    lo = simulate_arm(seconds, payload=OFFSET_PAYLOAD, trajectory="exciting2", seed=2 * seed + 1,
                      truth=truth)
    recs = [_record(un, f"unloaded-{seed}"), _record(lo, f"loaded-{seed}")]
    g_true = truth.drive_array("g_tau")
    t0 = time.perf_counter()
    res = identify_records(recs, model=model)
    t_id = time.perf_counter() - t0
    g = np.array([x.value for x in res.drive_gains])
    err = g / g_true - 1
    sig = np.array([x.rel_std for x in res.drive_gains])
    com_err = np.array(res.payload.com) - OFFSET_COM
    out = {"err": err, "z": err / sig, "com_err": com_err,
           "com_z": com_err / np.array(res.payload.com_std), "t": t_id}
    try:  # checked: refused, or a partial answer naming the gains it cannot scale
        checked = identify_records(recs, model=model,
                                   options=IdentifyOptions.of(payload_known="point"))
        out["point_refused"] = "partial: " + ", ".join(
            g.name for g in checked.drive_gains if not g.determined) + " not determined" \
            if not checked.complete else "no"
    except OrthoglideError as exc:
        out["point_refused"] = "refused: " + str(exc).split(":")[0][:40]
    point = identify_records(recs, model=model, options=IdentifyOptions.of(
        payload_known="point", check_excitation=False))
    out["point_err"] = np.array([x.value for x in point.drive_gains]) / g_true - 1
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robot", default="ur5")
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--seeds", type=int, default=3)
    add_json_option(ap)
    args = ap.parse_args()
    model = load_robot(args.robot)
    truth = with_offset_payload(load_truth(load_arm(args.robot)))
    print(f"{args.robot}: {args.seconds:g} s unloaded + {args.seconds:g} s with 2 kg, CoM "
          f"{', '.join(f'{1e3 * c:g}' for c in OFFSET_COM)} mm in {truth.arm.payload_frame}, "
          f"tagged with its mass only; {args.seeds} seeds")
    print(f"{'seed':>4} {'worst gain %':>12} {'max |z|':>7} {'CoM err mm (x, y, z)':>22} "
          f"{'max |z|':>7} {'identify s':>10} | {'point: worst gain %':>19}  checked")
    figs = Figures(before=BEFORE)
    table = figs.table(f"{args.robot}: {args.seconds:g} s unloaded + {args.seconds:g} s with 2 kg, "
                       f"CoM {', '.join(f'{1e3 * c:g}' for c in OFFSET_COM)} mm in "
                       f"{truth.arm.payload_frame}, tagged with its mass only", COLUMNS)
    rows = []
    for seed in range(args.seeds):
        r = one_seed(args.robot, args.seconds, seed, model, truth)
        rows.append(r)
        com = ", ".join(f"{1e3 * c:+.2f}" for c in r["com_err"])
        print(f"{seed:>4} {100 * np.abs(r['err']).max():>12.3f} {np.abs(r['z']).max():>7.2f} "
              f"{com:>22} {np.abs(r['com_z']).max():>7.2f} {r['t']:>10.2f} | "
              f"{100 * np.abs(r['point_err']).max():>19.2f}  {r['point_refused']}")
        table.row(seed, f"{100 * np.abs(r['err']).max():.3f}", f"{np.abs(r['z']).max():.2f}", com,
                  f"{np.abs(r['com_z']).max():.2f}", f"{r['t']:.2f}",
                  f"{100 * np.abs(r['point_err']).max():.2f}", r["point_refused"])
    err = np.array([r["err"] for r in rows])
    z = np.abs(np.array([r["z"] for r in rows]))
    com = np.abs(np.array([r["com_err"] for r in rows]))
    point = np.abs(np.array([r["point_err"] for r in rows]))
    for line in (
        f"mass only: worst gain {100 * np.abs(err).max():.3f} % (bar 0.5 %), gains within 3 "
        f"honest σ: {100 * np.mean(z <= 3):.0f} % (max {z.max():.2f}); CoM worst "
        f"{1e3 * com.max():.2f} mm (bar 5 mm), within 3 σ: "
        f"{100 * np.mean(np.abs(np.array([r['com_z'] for r in rows])) <= 3):.0f} %",
        f"point mass at the flange (payload_known: point, checks off): worst gain "
        f"{100 * point.max():.2f} %, mean worst {100 * point.max(axis=1).mean():.2f} %",
    ):
        print(line)
        figs.note(line)
    figs.write(args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
