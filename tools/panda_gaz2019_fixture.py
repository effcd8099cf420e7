"""Convert the Franka Emika Panda exciting-trajectory log of Gaz et al. (2019) into the CSV
fixture of tests/fixtures/panda_gaz2019 (see its README.md for the source, licence and cut).

    python tools/panda_gaz2019_fixture.py SOURCE [--out tests/fixtures/panda_gaz2019]

SOURCE: a clone of github.com/marcocognetti/FrankaEmikaPandaDynModel (a work tree, or a bare
git directory read with ``git show``). Its matlab/data/Exciting_Traj/Trajectory_1/rbt_log holds
one column per file, 7 values per sample (joints 1..7): exciting_traj_time.txt (s, the logger's
clock: ~1 kHz, uneven), _positions.txt (rad), _velocity.txt (rad/s), _torques.txt (N·m, the
joint torque sensors). The fixture keeps every DECIMATION-th sample, values verbatim as printed
there (no filtering, no resampling), split at SPLIT_S into an identification part (a) and a
held-out part (b), gzip-compressed with a fixed mtime so that the bytes are reproducible.
"""
from __future__ import annotations

import argparse
import gzip
import subprocess
from pathlib import Path

LOG = "matlab/data/Exciting_Traj/Trajectory_1/rbt_log/exciting_traj_{}.txt"
JOINTS = tuple(f"panda_joint{i}" for i in range(1, 8))
DECIMATION = 10  # ~100 Hz: what today's pairing tolerates of the log's jitter (README.md)
SPLIT_S = 14.0  # identification before, validation from here


def _lines(source: Path, kind: str) -> list[str]:
    path = LOG.format(kind)
    if (source / path).exists():
        text = (source / path).read_text()
    else:  # a bare git directory (the fetch tool's mirror)
        text = subprocess.run(["git", f"--git-dir={source}", "show", f"HEAD:{path}"],
                              check=True, capture_output=True, text=True).stdout
    return [x.strip() for x in text.splitlines() if x.strip()]


def rows(source: Path) -> list[list[str]]:
    """[t, q1..q7, qd1..qd7, tau1..tau7] per sample, text as published."""
    t = _lines(source, "time")
    cols = {k: _lines(source, k) for k in ("positions", "velocity", "torques")}
    for k, v in cols.items():
        if len(v) != 7 * len(t):
            raise SystemExit(f"{k}: {len(v)} values for {len(t)} samples of 7 joints")
    return [[t[i]] + [cols[k][7 * i + j] for k in ("positions", "velocity", "torques")
                      for j in range(7)] for i in range(len(t))]


def write(path: Path, header: list[str], body: list[list[str]]) -> None:
    text = ",".join(header) + "\n" + "".join(",".join(r) + "\n" for r in body)
    with open(path, "wb") as raw, gzip.GzipFile(fileobj=raw, mode="wb", mtime=0,
                                                filename="") as f:
        f.write(text.encode())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("source", type=Path)
    ap.add_argument("--out", type=Path, default=Path("tests/fixtures/panda_gaz2019"))
    args = ap.parse_args()
    header = ["t"] + [f"{j}.{c}" for c in ("q", "qd", "tau") for j in JOINTS]
    kept = rows(args.source)[::DECIMATION]
    a = [r for r in kept if float(r[0]) < SPLIT_S]
    b = [r for r in kept if float(r[0]) >= SPLIT_S]
    args.out.mkdir(parents=True, exist_ok=True)
    write(args.out / "traj1_a.csv.gz", header, a)
    write(args.out / "traj1_b.csv.gz", header, b)
    print(f"{len(a)} + {len(b)} rows (every {DECIMATION}th of the log) -> {args.out}")


if __name__ == "__main__":
    main()
