"""Speed and memory of `orthoglide-ident identify` next to rosbags merely reading the same bags.

    PYTHONPATH=. .venv/bin/python bench/identify_speed.py [--seconds 60] [--keep DIR] [--robot ur5]

Writes an unloaded and a loaded bag of --seconds each at 1 kHz from the simulator
(identify_data.py; with --robot, the MuJoCo arm's ros2_control-layout bags, 2 kg payload), then
in the same run:
  1. rosbags: AnyReader + deserialize_cdr of every message of both bags (read only);
  2. `orthoglide-ident identify` as a subprocess, end to end (start-up, reading, filtering, W,
     decimation, TLS, printing), wall time and peak RSS;
  3. the pipeline's own per-step timings (from --json);
  4. identify in this process (the CLI's main, imported before) and the rosbags read as a
     program of its own: the ratios like for like (issue 35's bars, both in-process: 0.5 for
     the Orthoglide, 0.6 for a 6-DOF arm; issue 24's were 1 and 1.5, program / in-process).

Latest figures (2 cores shared with another load): rosbags 1.7-2.0 s; identify 0.57-0.83 s
end to end, ratio 0.34-0.48 (0.65-0.68 before the closed-form regressor and the block-wise
FIR decimation); regressor+decimation 0.23-0.41 s (0.76-0.82 s before); peak RSS 127 MiB.
2 x 10 min: identify 5.0 s, 402 MiB (12.3 s, 403 MiB before). bench/live_identification.py
gives the live figures on the same bags (--keep DIR). Issue 35's like-for-like figures
(bench/busy_machine.py, README "On a busy machine"), 2026-12-04: UR5 in-process 0.55-0.58
(0.65-0.77 the same day before on the same machine; 0.85-0.92 before W's smooth columns at the
decimated rows), Orthoglide 0.39-0.45.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

from orthoglide_ident.ros import processes as children  # children end with this process

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))

from _figures import Figures, add_json_option  # noqa: E402
from identify_data import record  # noqa: E402

from orthoglide_ident import bags  # noqa: E402
from orthoglide_ident.model.registry import load_robot  # noqa: E402

ORTHOGLIDE = load_robot("orthoglide")  # the robot these records are of
EMITS_JSON = True  # --json PATH: the figures for bench/write_benchmarks.py
BEFORE = {  # the figures before, by robot (docs/benchmarks.md's table as it was)
    "": "0.65–0.83, 1.1–2.4 s",
    "ur5": "2026-12-02, quiet: identify 2.1–2.4 s end to end vs rosbags 1.6–2.5 s, ratio "
           "0.83–1.47; regressor + decimation 0.9–1.0 s, solve 0.21–0.31 s, start-up 0.54–0.65 s; "
           "295–301 MiB; the Orthoglide 0.53–0.66",
}


# the same read as a program of its own (what a user runs: interpreter and imports included)
ROSBAGS_PROGRAM = (
    "import sys\nfrom pathlib import Path\nfrom rosbags.highlevel import AnyReader\n"
    "with AnyReader([Path(p) for p in sys.argv[1:]]) as reader:\n"
    "    for conn, _, raw in reader.messages():\n"
    "        reader.deserialize(raw, conn.msgtype)\n")


def rosbags_read_subprocess(paths: list[Path]) -> float:
    """Wall time of :data:`ROSBAGS_PROGRAM` on ``paths`` run as a subprocess (s)."""
    t0 = time.perf_counter()
    children.run([sys.executable, "-c", ROSBAGS_PROGRAM, *map(str, paths)], check=True)
    return time.perf_counter() - t0


def identify_in_process(argv: list[str]) -> float:
    """Wall time of the CLI's ``main(argv)`` in this process (s): no interpreter start or
    imports (call once before, to import), the robot model loaded again (its cache cleared)."""
    import contextlib
    import io

    from orthoglide_ident.cli import main as cli_main
    from orthoglide_ident.model import registry

    registry._load.cache_clear()
    t0 = time.perf_counter()
    with contextlib.redirect_stdout(io.StringIO()):
        rc = cli_main(argv)
    if rc != 0:
        raise RuntimeError(f"identify {' '.join(argv)} exited {rc}")
    return time.perf_counter() - t0


def rosbags_read(paths: list[Path]) -> tuple[float, int]:
    from rosbags.highlevel import AnyReader

    t0 = time.perf_counter()
    n = 0
    with AnyReader(paths) as reader:
        for conn, _, raw in reader.messages():
            reader.deserialize(raw, conn.msgtype)  # deserialize_cdr + message class
            n += 1
    return time.perf_counter() - t0, n


def arm_bags(d: Path, robot: str, seconds: float) -> tuple[list[Path], str]:
    """An unloaded and a 2 kg loaded bag of the simulated arm (reused when already in ``d``)."""
    from orthoglide_sim.arm_or_chain.bags import write_record
    from orthoglide_sim.arms.record import simulate_arm

    paths = []
    for name, payload, trajectory, seed in (("unloaded", None, "exciting1", 0),
                                            ("loaded_2kg", "2.0", "exciting2", 1)):
        if not (d / name).exists():
            rec = simulate_arm(seconds, robot, payload=payload, trajectory=trajectory, seed=seed)
            write_record(d / name, rec)
        paths.append(d / name)
    return paths, f"simulated {robot} on MuJoCo"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--seconds", type=float, default=60.0, help="length of each bag (s)")
    ap.add_argument("--keep", help="write the bags here and keep them (default: a temp dir); "
                    "bags already there are reused")
    ap.add_argument("--bags", nargs=2, help="use these two bags (unloaded, loaded) instead")
    ap.add_argument("--robot", default="", help="a simulated arm (e.g. ur5) instead of the "
                    "Orthoglide; passed to identify --robot")
    add_json_option(ap)
    args = ap.parse_args()

    tmp = tempfile.TemporaryDirectory()
    d = Path(args.keep or tmp.name)
    d.mkdir(parents=True, exist_ok=True)
    if args.bags:
        paths = [Path(p) for p in args.bags]
        source = "given bags"
    elif args.robot:
        paths, source = arm_bags(d, args.robot, args.seconds)
    else:
        t0 = time.perf_counter()
        paths = []
        source = "bags kept from an earlier run"
        for name, m, seed in (("unloaded", 0.0, 1), ("loaded", 1.983, 2)):
            if (d / name).exists():  # --keep DIR from an earlier run: reuse
                paths.append(d / name)
                continue
            rec, truth = record(args.seconds, m, seed)
            paths.append(bags.write_bag(d / name, rec.stamps_q_ns, rec.q, rec.v_tau,
                                        rec.condition, m, joint_names=ORTHOGLIDE.joint_names))
            source = truth["source"]
        print(f"wrote 2 x {args.seconds:g} s bags ({source}) in {time.perf_counter() - t0:.1f} s",
              file=sys.stderr)

    t_rosbags, n_msgs = rosbags_read(paths)

    js = d / "result.json"
    env = dict(os.environ, PYTHONPATH=os.environ.get("PYTHONPATH") or str(ROOT))
    # The CLI reports its own peak RSS (VmHWM, reset at exec): RUSAGE_CHILDREN would count the
    # forked copy of this (large, bag-writing) process before exec.
    code = ("import sys\nfrom orthoglide_ident.cli import main\nrc = main(sys.argv[1:])\n"
            "hwm = [l for l in open('/proc/self/status') if l.startswith('VmHWM')][0]\n"
            "sys.stderr.write('PEAK ' + hwm.split()[1] + '\\n')\nsys.exit(rc)")
    cmd = [sys.executable, "-P", "-c", code, "identify", *map(str, paths), "--json", str(js), "-q"]
    if args.robot:
        cmd += ["--robot", args.robot]
    t0 = time.perf_counter()
    # -P: `python -c` would put the working directory first on sys.path; PYTHONPATH decides
    proc = children.run(cmd, env=env, capture_output=True, text=True, cwd=ROOT)
    t_cli = time.perf_counter() - t0
    peak = [ln for ln in proc.stderr.splitlines() if ln.startswith("PEAK ")]
    rss_mb = int(peak[-1].split()[1]) / 1024 if peak else float("nan")
    if proc.returncode != 0:
        print(proc.stderr, file=sys.stderr)
        print(f"identify failed with exit code {proc.returncode}")
        return 1
    doc = json.loads(js.read_text())
    steps = doc["diagnostics"]["timings_s"]

    print(f"\nidentify speed — 2 x {args.seconds:g} s at 1 kHz ({n_msgs} messages; {source})")
    print(f"{'step':<34}{'time (s)':>10}")
    figs = Figures(before=BEFORE.get(args.robot, ""))
    table = figs.table(f"identify speed — 2 x {args.seconds:g} s at 1 kHz ({n_msgs} messages; "
                       f"{source})", ["step", ("time", "s")])
    print(f"{'rosbags AnyReader+deserialize_cdr':<34}{t_rosbags:>10.2f}")
    print(f"{'orthoglide-ident identify (total)':<34}{t_cli:>10.2f}")
    table.row("rosbags AnyReader+deserialize_cdr", f"{t_rosbags:.2f}")
    table.row("orthoglide-ident identify (total)", f"{t_cli:.2f}")
    for k in ("model", "read", "segments", "filtering", "regressor+decimation", "solve",
              "essential"):
        if k in steps:
            aim = "  (aim ≤ 0.5 s for 2 x 60 s)" if k == "regressor+decimation" else ""
            print(f"{'  ' + k:<34}{steps[k]:>10.2f}{aim}")
            table.row(f"{k}{aim}", f"{steps[k]:.2f}")
    startup = t_cli - steps.get("total", 0.0)
    print(f"{'  start-up (imports) and output':<34}{startup:>10.2f}")
    table.row("start-up (imports) and output", f"{startup:.2f}")
    argv = ["identify", *map(str, paths), "-q"] + (["--robot", args.robot] if args.robot else [])
    identify_in_process(argv)  # imports
    t_in = identify_in_process(argv)
    t_rosbags_p = rosbags_read_subprocess(paths)
    bar = "0.6 (6-DOF arm)" if args.robot else "0.5"
    print(f"{'identify in this process':<34}{t_in:>10.2f}")
    print(f"{'rosbags read as a program':<34}{t_rosbags_p:>10.2f}")
    table.row("identify in this process", f"{t_in:.2f}")
    table.row("rosbags read as a program", f"{t_rosbags_p:.2f}")
    g = [x["value"] for x in doc["drive_gains"]]
    for line in (
        f"ratio identify / rosbags read, both in-process: {t_in / t_rosbags:.2f}  (bar: <= {bar}, "
        "issue 35)",
        f"ratio identify / rosbags read, both programs: {t_cli / t_rosbags_p:.2f}; identify "
        f"program / in-process read: {t_cli / t_rosbags:.2f}",
        f"peak RSS of identify: {rss_mb:.0f} MiB  (bar: < 1024 MiB)",
        f"gains ({doc['units']['drive_gains']}): " + ", ".join(f"{v:.4g}" for v in g),
    ):
        print(line)
        figs.note(line)
    figs.write(args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
