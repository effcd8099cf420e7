"""Accuracy of the identification over several seeds (DESIGN §7 bars).

    PYTHONPATH=. .venv/bin/python bench/identify_accuracy.py [--seeds 5] [--seconds 60]

Per seed: IDIM-TLS on an unloaded and a 1.983 kg record → gain errors vs the plant's truth;
IDIM-WLS on an unloaded and a 1.136 kg record with the identified gains and with the
manufacturer's 2001 N/A → payload errors; cross-validation on a 1.983 kg record of another
trajectory (the simulator's "test2") → residual rms relative to the identification residual (the
noise floor); essential parameters → gain shift. Records come from the simulator when it has an
exciting trajectory, else model data (identify_data.py).
Prints per-seed rows and mean ± spread.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from identify_data import record  # noqa: E402

from orthoglide_ident.errors import OrthoglideError  # noqa: E402
from orthoglide_ident.identify.options import IdentifyOptions  # noqa: E402
from orthoglide_ident.identify.pipeline import identify_records  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--seconds", type=float, default=60.0, help="length of each record (s)")
    ap.add_argument("--no-essential", action="store_true")
    args = ap.parse_args()
    opts = IdentifyOptions()
    rows = []
    source = ""
    print(f"{'seed':>4} {'g1 err%':>8} {'g2 err%':>8} {'g3 err%':>8} {'max%σ g':>8} "
          f"{'m 1.136 id%':>11} {'m manuf%':>9} {'xval/noise':>10} {'ess Δg%':>8} {'s':>5}")
    for seed in range(args.seeds):
        t0 = time.perf_counter()
        try:
            ru, truth = record(args.seconds, 0.0, 1000 + seed)
            rl, _ = record(args.seconds, 1.983, 2000 + seed)
            r2, _ = record(args.seconds, 1.136, 3000 + seed)
            # cross-validation on a different trajectory (paper Fig. 5), when the simulator has it
            rv, _ = record(args.seconds, 1.983, 4000 + seed,
                           trajectory="test2" if truth["source"].startswith("simulator")
                           else "exciting")
            source = truth["source"]
            g_true = truth["g_tau"]
            res = identify_records([ru, rl], options=opts, essential=not args.no_essential,
                                   validation=[rv])
            g = np.array([x.value for x in res.drive_gains])
            gerr = 100 * (g / g_true - 1)
            gsig = 100 * max(x.rel_std for x in res.drive_gains)
            w_id = identify_records([ru, r2], method="wls", gains=g, options=opts)
            w_man = identify_records([ru, r2], method="wls", options=opts)
            m_id = 100 * (w_id.payload_mass.value / 1.136 - 1)
            m_man = 100 * (w_man.payload_mass.value / 1.136 - 1)
            xv = res.validation[0]["joints"]
            xratio = max(j["noise_ratio"] for j in xv)
            dg = np.nan
            if res.essential is not None:
                ge = np.array([x.value for x in res.essential.drive_gains])
                dg = 100 * np.max(np.abs(ge / g - 1))
        except OrthoglideError as exc:
            print(f"{seed:>4} failed: {exc}")
            continue
        dt = time.perf_counter() - t0
        rows.append([*gerr, gsig, m_id, m_man, xratio, dg])
        print(f"{seed:>4} {gerr[0]:8.3f} {gerr[1]:8.3f} {gerr[2]:8.3f} {gsig:8.3f} {m_id:11.2f} "
              f"{m_man:9.2f} {xratio:10.2f} {dg:8.2f} {dt:5.0f}")
    if not rows:
        return 1
    a = np.array(rows)
    mean, std = np.nanmean(a, axis=0), np.nanstd(a, axis=0)
    print(f"{'mean':>4} " + " ".join(f"{m:8.3f}" for m in mean[:4]) + f" {mean[4]:11.2f} "
          f"{mean[5]:9.2f} {mean[6]:10.2f} {mean[7]:8.2f}")
    print(f"{'std':>4} " + " ".join(f"{s:8.3f}" for s in std[:4]) + f" {std[4]:11.2f} "
          f"{std[5]:9.2f} {std[6]:10.2f} {std[7]:8.2f}")
    worst = np.max(np.abs(a[:, :3]))
    print(f"\nsource: {source}; {len(rows)} seeds x 4 records of {args.seconds:g} s")
    print(f"worst gain error {worst:.3f} % (bar 0.5 %); payload 1.136 kg by WLS: "
          f"{np.mean(np.abs(a[:, 4])):.2f} % with identified gains (bar 1 %), "
          f"{np.mean(np.abs(a[:, 5])):.2f} % with the manufacturer's; cross-validation rms / "
          f"identification rms: {np.max(a[:, 6]):.2f} (bar 1.5)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
