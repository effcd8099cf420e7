"""Partial answers on issue 43's "big arm, small weighed payload, ~95 Hz" record shape.

    PYTHONPATH=. .venv/bin/python bench/partial_answers.py [--seconds 60] [--pairs 4]

The UR10 (32.7 kg of links; orthoglide_sim/arms/big_arm.py, MuJoCo, its own true inertials,
drives and 0.5 % current noise) records unloaded/loaded pairs, each with its own random
trajectories at 60 % of the limits and noise (seed), logged at 90.9 Hz on a 10/12 ms clock,
positions printed to 1e-4 rad, the 2.8 kg payload's CoM (2.5 cm off the last axis) not told.
Each pair is identified as ``orthoglide-ident identify`` does (default options):

- before: the answer without the subset search (the full set's eq. 37 decides: all or nothing);
- unchecked: the full set's numbers with the checks off (what an all-or-nothing TLS would say);
- after: the partial answer (partial.py's search): per gain the error against the plant's truth
  in % and in σ, or why it is not determined.

Then the pairs side by side: each gain determined in two or more pairs, its weighted mean, the
χ² of the pairs about it (dof = pairs - 1) and the largest pair-to-pair difference in the σ of
that difference: repeated records of the same robot agree within their σ.
"""
from __future__ import annotations

import argparse
import logging
import sys
import time

import numpy as np

from orthoglide_ident.errors import OrthoglideError
from orthoglide_ident.identify import IdentifyOptions, identify_records
from orthoglide_ident.identify.solve import answer
from orthoglide_ident.model.registry import load_robot
from orthoglide_sim.arms.big_arm import UR10_FILE, big_arm_truth, pair_records, simulate_pair


def before(records, model):
    """The answer without the subset search: the full set's failure raised as it was."""
    def no_search(factors, model, opts, left_out, why):
        raise answer.ExcitationError(("no drive gain is determined: " if left_out else "") + why)

    saved, answer._search = answer._search, no_search
    try:
        return identify_records(records, model=model)
    except OrthoglideError as exc:
        return str(exc)
    finally:
        answer._search = saved


def table(res, unchecked, g_true, names) -> list[str]:
    out = []
    for k, name in enumerate(names):
        u = unchecked.drive_gains[k]
        cells = f"  {name:<20} unchecked {100 * (u.value / g_true[k] - 1):+7.2f} % "
        g = res.drive_gains[k] if not isinstance(res, str) else None
        if g is None:
            out.append(cells)
        elif g.determined:
            e = g.value / g_true[k] - 1
            out.append(cells + f"| {g.value:8.4f} ({g_true[k]:.4f}) {100 * e:+6.2f} % σ "
                       f"{100 * g.rel_std:.2f} % ({abs(e) / g.rel_std:.1f} σ)")
        else:
            out.append(cells + "| not determined: " + g.reason)
    return out


def agreement(results, names) -> list[str]:
    out = []
    for k, name in enumerate(names):
        vals = [(r.drive_gains[k].value, r.drive_gains[k].value * r.drive_gains[k].rel_std)
                for r in results if not isinstance(r, str) and r.drive_gains[k].determined]
        if len(vals) < 2:
            out.append(f"  {name:<20} determined in {len(vals)} pair(s)")
            continue
        g, s = np.array(vals).T
        w = 1.0 / s ** 2
        mean = float(np.sum(w * g) / np.sum(w))
        chi2 = float(np.sum(((g - mean) / s) ** 2))
        apart = max(abs(g[a] - g[b]) / np.hypot(s[a], s[b])
                    for a in range(len(g)) for b in range(a + 1, len(g)))
        out.append(f"  {name:<20} {len(g)} pairs: mean {mean:.4f}, spread ±"
                   f"{100 * (g.max() - g.min()) / 2 / mean:.2f} %, χ² {chi2:.2f} (dof "
                   f"{len(g) - 1}), largest pair difference {apart:.2f} σ")
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=60.0, help="per record (60)")
    ap.add_argument("--pairs", type=int, default=4)
    ap.add_argument("--step", type=float, default=2.5e-4, help="the plant's step, s")
    args = ap.parse_args()
    logging.basicConfig(level=logging.WARNING, stream=sys.stderr)
    model, truth = load_robot(str(UR10_FILE)), big_arm_truth()
    g_true, names = truth.drive_array("g_tau"), model.joint_names
    print(f"UR10 + 2.8 kg (CoM unknown), {args.pairs} pairs of {args.seconds:g} s + "
          f"{args.seconds:g} s at 10/12 ms (90.9 Hz), q printed to 1e-4 rad")
    afters = []
    for seed in range(args.pairs):
        t0 = time.perf_counter()
        recs = pair_records(simulate_pair(seed, args.seconds, truth=truth, timestep=args.step))
        t1 = time.perf_counter()
        old = before(recs, model)
        unchecked = identify_records(recs, model=model,
                                     options=IdentifyOptions.of(check_excitation=False))
        t2 = time.perf_counter()
        try:
            res = identify_records(recs, model=model)
        except OrthoglideError as exc:
            res = str(exc)
        t3 = time.perf_counter()
        afters.append(res)
        print(f"\npair {seed} (simulated in {t1 - t0:.0f} s; identified in {t3 - t2:.1f} s)")
        print("  before: " + ("exit 0" if not isinstance(old, str) else f"exit 2: {old}"))
        print("  after: " + ("exit 2: " + res if isinstance(res, str) else
                             f"exit 0, {sum(g.determined for g in res.drive_gains)} of "
                             f"{len(names)} gains determined"))
        print("\n".join(table(res, unchecked, g_true, names)))
    print("\nthe pairs side by side (determined gains):")
    print("\n".join(agreement(afters, names)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
