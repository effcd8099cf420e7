"""The product's figures on a busy machine next to a quiet one (issue 35): identification speed and
`make demo`'s live graph (Table 4 over ROS, the recorder), without and with a CPU hog beside them.

    PYTHONPATH=. .venv/bin/python bench/busy_machine.py [--hog N] [--what identify,demo]
                                                         [--repeat 5] [--keep DIR]

``--hog N``: N busy processes (``while True: pass``) run beside the measured work; default one
per core minus one (one on the 2-core reference machine). Every figure is measured quiet, then
with the hog, and the two are printed side by side with the bar (issue 35):

  identify   2 x 60 s at 1 kHz of the UR5 (MuJoCo, 2 kg payload) and of the Orthoglide: the
             median of ``--repeat`` runs of a plain rosbags read of both bags (AnyReader +
             deserialize) and of `orthoglide-ident identify`, like for like: both in this process
             (the CLI's main, imported once before; the ratio the bars apply to: UR5 <= 0.6,
             Orthoglide <= 0.5) and both as programs of their own (interpreter start and imports
             included: what a user waits for), and, as first printed, the program against the
             in-process read;
  demo       `python -m orthoglide_sim.demos.node_set` (the graph started as the launch file does, 2
  x
             --record-seconds recorded, identified, Table 4 over ROS); read from its FIXED lines
             (DESIGN §9): per Table 4 run "driver: N of M ticks late, K without a fresh
             feed-forward", per test "CTC over ROS / in-process a, b, c" (bar <= 1.5), and the
             recorder's stop messages (missing ticks, bar 0).

Table layout (one row per figure):
    figure                                         quiet     hog N      bar
    identify ur5: rosbags read, in-process (s)      1.25      1.90
    identify ur5: identify, in-process (s)          0.70      1.00
    identify ur5: identify / rosbags read           0.56      0.53     <= 0.6
    identify ur5: ... a program (s), programs, program / in-process read
    ...
    demo test1: CTC over ROS / in-process (worst)   1.02      1.40     <= 1.5
    demo: CTC ticks without a fresh ff (worst run)  0.02 %    0.80 %   <= 1 %
    demo: CTC ticks late (worst run)                0.0 %     2.1 %
    demo: ctc lead at sending, min (worst run, ms)  38.2      12.5
    demo: ctc CPU (worst run, % of a core)          9         12
    demo: recorder missing ticks                    0         0        0

Timing figures depend on everything else the machine runs: say its load with them.
"""
from __future__ import annotations

import argparse
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))

HOG_CODE = "while True: pass"
BARS = {"ur5": 0.6, "orthoglide": 0.5}


@contextmanager
def cpu_hog(n: int) -> Iterator[None]:
    """n busy processes for the duration of the block (ended by their pids)."""
    procs = [subprocess.Popen([sys.executable, "-c", HOG_CODE]) for _ in range(n)]
    try:
        time.sleep(0.5 if n else 0.0)
        yield
    finally:
        for p in procs:
            p.kill()
        for p in procs:
            p.wait()


def _bags(keep: Path) -> dict[str, list[Path]]:
    """2 x 60 s bags of the UR5 and of the Orthoglide (written once into ``keep``)."""
    from identify_data import record
    from identify_speed import arm_bags  # noqa: E402 (bench/ on the path)

    from orthoglide_ident import bags
    from orthoglide_ident.model.registry import load_robot

    joints = load_robot("orthoglide").joint_names  # the robot these records are of
    out = {"ur5": arm_bags(keep / "ur5", "ur5", 60.0)[0]}
    og = keep / "orthoglide"
    paths = []
    for name, m, seed in (("unloaded", 0.0, 1), ("loaded", 1.983, 2)):
        if not (og / name).exists():
            rec, _ = record(60.0, m, seed)
            bags.write_bag(og / name, rec.stamps_q_ns, rec.q, rec.v_tau, rec.condition, m,
                           joint_names=joints)
        paths.append(og / name)
    out["orthoglide"] = paths
    return out


def identify_figures(bag_sets: dict[str, list[Path]], repeat: int) -> dict[str, float]:
    """Medians of ``repeat`` interleaved runs, like for like: identify and the rosbags read both
    in this process (the bar's ratio) and both as programs of their own (what a user waits for:
    interpreter start and imports included)."""
    from identify_speed import identify_in_process, rosbags_read, rosbags_read_subprocess

    out = {}
    for robot, paths in bag_sets.items():
        argv = ["identify", *map(str, paths), "-q"] + (
            ["--robot", robot] if robot != "orthoglide" else [])
        cmd = [sys.executable, "-P", "-m", "orthoglide_ident.cli", *argv]  # -P: PYTHONPATH decides
        env = {k: v for k, v in os.environ.items()
               if k not in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")}
        identify_in_process(argv)  # imports, once
        runs: dict[str, list[float]] = {k: [] for k in ("read", "identify", "read_p", "identify_p")}
        for _ in range(repeat):  # interleaved: all four see the same load
            runs["read"].append(rosbags_read(paths)[0])
            runs["identify"].append(identify_in_process(argv))
            runs["read_p"].append(rosbags_read_subprocess(paths))
            t0 = time.perf_counter()
            subprocess.run(cmd, env=env, cwd=ROOT, check=True, stdout=subprocess.DEVNULL)
            runs["identify_p"].append(time.perf_counter() - t0)
        m = {k: statistics.median(v) for k, v in runs.items()}
        out[f"identify {robot}: rosbags read, in-process (s)"] = m["read"]
        out[f"identify {robot}: identify, in-process (s)"] = m["identify"]
        out[f"identify {robot}: identify / rosbags read"] = m["identify"] / m["read"]
        out[f"identify {robot}: rosbags read, a program (s)"] = m["read_p"]
        out[f"identify {robot}: identify, a program (s)"] = m["identify_p"]
        out[f"identify {robot}: identify / rosbags read, programs"] = m["identify_p"] / m["read_p"]
        out[f"identify {robot}: identify program / in-process read"] = m["identify_p"] / m["read"]
    return out


def parse_demo(text: str) -> dict[str, float]:
    """The figures of `make demo`'s output (its FIXED lines, DESIGN §9)."""
    out: dict[str, float] = {}
    for test, values in re.findall(r"(test\d): .*CTC over ROS / in-process ([\d., ]+)", text):
        out[f"demo {test}: CTC over ROS / in-process (worst)"] = max(
            float(x) for x in values.replace(" ", "").strip(",").split(","))
    held, late, expired = [], [], []
    for n_late, n_ticks, rest in re.findall(r"driver: (\d+) of (\d+) ticks late(.*)", text):
        late.append(100 * int(n_late) / max(int(n_ticks), 1))
        m = re.match(
            r", (\d+) without a fresh feed-forward \(previous one held\)(?:, (\d+) of them past)?",
            rest,
        )
        if m:
            held.append(100 * int(m.group(1)) / max(int(n_ticks), 1))
            expired.append(100 * int(m.group(2) or 0) / max(int(n_ticks), 1))
    if held:
        out["demo: CTC ticks without a fresh ff (worst run, %)"] = max(held)
        out["demo: CTC ticks on PID + vel. ff alone (worst run, %)"] = max(expired)
    if late:
        out["demo: driver ticks late (worst run, %)"] = max(late)
    ctc = re.findall(r"ctc: lead min (-?[\d.]+) / median (-?[\d.]+) ms, CPU (\d+) %", text)
    if ctc:
        out["demo: ctc lead at sending, min (worst run, ms)"] = min(float(a) for a, _, _ in ctc)
        out["demo: ctc lead at sending, median (median run, ms)"] = statistics.median(
            float(b) for _, b, _ in ctc
        )
        out["demo: ctc CPU (worst run, % of a core)"] = max(float(c) for _, _, c in ctc)
    for line in re.findall(r"CPU while recording \(% of one core\): (.*)", text):
        for node, pct in re.findall(r"(\w+) (\d+)", line):
            out[f"demo: {node} CPU while recording (% of a core)"] = float(pct)
    missing = [int(x) for x in re.findall(r"(\d+) (?:ticks )?missing", text)]
    if missing:
        out["demo: recorder missing ticks"] = sum(missing)
    return out


def demo_figures(record_s: float, out_dir: Path) -> dict[str, float]:
    proc = subprocess.run(
        [
            sys.executable,
            "-P",  # not the working directory first: PYTHONPATH decides
            "-m",
            "orthoglide_sim.demos.node_set",
            "--record-seconds",
            str(record_s),
            "--out",
            str(out_dir),
        ],
        cwd=ROOT,
        capture_output=True,
        text=True,
    )
    (out_dir.parent / (out_dir.name + ".txt")).write_text(proc.stdout + proc.stderr)
    if proc.returncode != 0:
        print(f"demo failed (exit {proc.returncode}); its output: {out_dir}.txt", file=sys.stderr)
    return parse_demo(proc.stdout + proc.stderr)


def bar(name: str) -> str:
    if name.endswith("identify / rosbags read"):  # the bar's ratio: both in-process
        return f"<= {BARS[name.split()[1].rstrip(':')]}"
    if "CTC over ROS / in-process" in name:
        return "<= 1.5"
    if "without a fresh ff" in name:
        return "<= 1 %"
    if "missing" in name:
        return "0"
    return ""


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--hog", type=int, default=max(1, (os.cpu_count() or 2) - 1),
                    help="busy processes beside the hog run (default: cores - 1)")
    ap.add_argument("--what", default="identify,demo", help="identify, demo or both")
    ap.add_argument("--repeat", type=int, default=5, help="runs per identify figure (median)")
    ap.add_argument("--record-seconds", type=float, default=45.0, help="the demo's recordings")
    ap.add_argument("--keep", help="bags and demo outputs here (reused; default a temp dir)")
    args = ap.parse_args()
    tmp = tempfile.TemporaryDirectory()
    keep = Path(args.keep or tmp.name)
    keep.mkdir(parents=True, exist_ok=True)
    what = set(args.what.split(","))
    bag_sets = _bags(keep) if "identify" in what else {}
    columns = {}
    for label, n in (("quiet", 0), (f"hog {args.hog}", args.hog)):
        print(f"measuring: {label} (load average {os.getloadavg()[0]:.1f})", file=sys.stderr)
        figures: dict[str, float] = {}
        with cpu_hog(n):
            if bag_sets:
                figures.update(identify_figures(bag_sets, args.repeat))
            if "demo" in what:
                figures.update(demo_figures(args.record_seconds, keep / f"demo_{n}"))
        columns[label] = figures
    names = list(dict.fromkeys(k for c in columns.values() for k in c))
    w = max(len(n) for n in names) + 2
    print(f"\nthe product on a busy machine ({os.cpu_count()} cores; load average now "
          f"{os.getloadavg()[0]:.1f})")
    print(f"{'figure':<{w}}" + "".join(f"{c:>12}" for c in columns) + f"{'bar':>9}")
    for n in names:
        cells = "".join(f"{columns[c][n]:>12.3g}" if n in columns[c] else f"{'-':>12}"
                        for c in columns)
        print(f"{n:<{w}}{cells}{bar(n):>9}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
