"""CSV import speed: ``orthoglide-ident import`` on a log of N rows (a time column, then
position, velocity and effort of J joints), timed by stage.

    python bench/csv_import_speed.py [--rows 1000000] [--joints 7] [--gzip]

Prints the file size, the parse time (numpy's C reader and the cell-count check), the bag
write time (the product's write_bag: bulk CDR encoding, then the MCAP writer tick by tick), the
rows/s of each and the peak RSS. Timings on a shared machine are distorted by other load.
"""
from __future__ import annotations

import argparse
import gzip
import resource
import tempfile
import time
from pathlib import Path

import numpy as np
from _figures import Figures, add_json_option

from orthoglide_ident.bags.csv_import import ColumnMap, import_csv, read_csv

EMITS_JSON = True  # --json PATH: the figures for bench/write_benchmarks.py


def write_log(path: Path, rows: int, joints: int, compress: bool) -> Path:
    rng = np.random.default_rng(0)
    t = np.arange(rows) * 1e-3
    cols = [t] + [rng.normal(0, 1, rows) for _ in range(3 * joints)]
    names = ["t"] + [f"j{j}.{k}" for k in ("q", "qd", "tau") for j in range(joints)]
    data = np.column_stack(cols)
    opener = gzip.open if compress else open
    with opener(path, "wt") as f:
        np.savetxt(f, data, fmt="%.6g", delimiter=",", header=",".join(names), comments="")
    return path


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rows", type=int, default=1_000_000)
    ap.add_argument("--joints", type=int, default=7)
    ap.add_argument("--gzip", action="store_true", help="a .csv.gz log")
    add_json_option(ap)
    args = ap.parse_args()
    cmap = ColumnMap(velocity="{joint}.qd", effort="{joint}.tau", effort_unit="N·m")
    with tempfile.TemporaryDirectory() as d:
        csv = write_log(Path(d) / ("log.csv.gz" if args.gzip else "log.csv"), args.rows,
                        args.joints, args.gzip)
        t0 = time.perf_counter()
        rec = read_csv(csv, cmap)
        t1 = time.perf_counter()
        import_csv([csv], Path(d) / "bag", cmap)
        t2 = time.perf_counter()
        size = csv.stat().st_size / 1e6
    parse, total = t1 - t0, t2 - t1
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(
        f"rows {args.rows}, joints {args.joints}, file {size:.1f} "
        f"MB{' (gzip)' if args.gzip else ''}"
    )
    print(f"{'stage':<28}{'s':>8}{'rows/s':>12}")
    print(f"{'parse (read_csv)':<28}{parse:8.2f}{args.rows / parse:12.3g}")
    print(f"{'import (parse + write bag)':<28}{total:8.2f}{args.rows / total:12.3g}")
    print(f"peak RSS {rss:.0f} MiB; q {rec.q.shape}")
    figs = Figures(before="new")
    table = figs.table(f"rows {args.rows}, joints {args.joints}, file {size:.1f} MB"
                       f"{' (gzip)' if args.gzip else ''}, peak RSS {rss:.0f} MiB",
                       ["stage", ("time", "s"), "rows/s"])
    table.row("parse (read_csv)", f"{parse:.2f}", f"{args.rows / parse:.3g}")
    table.row("import (parse + write bag)", f"{total:.2f}", f"{args.rows / total:.3g}")
    figs.write(args.json)


if __name__ == "__main__":
    main()
