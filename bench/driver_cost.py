"""Where the simulated Orthoglide driver's CPU goes, tick by tick, with the node set running.

    PYTHONPATH=. .venv/bin/python bench/driver_cost.py [--seconds 10] [--plant reduced|tree]
                                                      [--payload 1.983] [--controller pid] [--hog N]

Starts the recorder, the live identification and the ctc as `make demo` does (they subscribe to
the driver's topics, so its publishing does the DDS work it does in the demo), then the driver in a
child process of this script, instrumented: the CPU time of its tick-loop thread
(time.thread_time_ns) spent in each part of a tick is summed over the run and printed per tick:

  plant       DriverSession.advance (the plant integrated over the tick, the current noise), in
              blocks of ticks computed ahead of their deadlines (orthoglide_sim.common.ticks_ahead)
  controller  DriverSession.measure + control (encoder, PID, setpoint, limit)
  publish     JointState and CurrentReference built and published at every tick, the JointSetpoints
              of the ticks computed ahead (ticks_ahead: up to 10 at a time)
  wait        tick_clock.sleep_until's spin to the deadline (the loop's own busy wait)
  rest        the rest of the tick loop (locks, stamps, counters, /diagnostics once a second)
  threads     every other thread of the process (executor, inputs' batch taker, DDS)
and the whole process's CPU over the run in % of one core, in that run and in a run without the
timers before it (the figure `make demo` prints as "CPU while recording: driver ..."; the timers'
clock reads cost CPU of their own). Each is measured quiet, then with ``--hog N`` busy processes
beside it (default one per core minus one), side by side. Timing figures depend on what else the
machine runs: the load average is printed with them.
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _figures import Figures, add_json_option

PARTS = ("plant", "controller", "publish", "wait", "rest", "threads")
EMITS_JSON = True  # --json PATH: the figures for bench/write_benchmarks.py
BEFORE = "73–81 % of a core (before the reduced plant and the ticks computed ahead)"


def _timed(fn, totals: dict, key: str):
    def wrapper(*args, **kwargs):
        t = time.thread_time_ns()
        try:
            return fn(*args, **kwargs)
        finally:
            totals[key] = totals.get(key, 0) + time.thread_time_ns() - t
    return wrapper


def child(out: str, ros_args: list[str], plain: bool) -> int:
    """The driver node with its tick loop's parts timed (``plain``: not timed, its CPU only); the
    sums written to ``out`` (JSON)."""
    from orthoglide_sim.nodes import driver as driver_node
    from orthoglide_sim.orthoglide import session

    totals: dict[str, int] = {}
    for name, key in (
        ()
        if plain
        else (("advance", "plant"), ("measure", "controller"), ("control", "controller"))
    ):
        setattr(
            session.DriverSession, name, _timed(getattr(session.DriverSession, name), totals, key)
        )
    for name in () if plain else ("_publish_js", "_publish_setpoint", "_tick"):
        setattr(driver_node.Driver, name, _timed(getattr(driver_node.Driver, name), totals, name))
    if not plain:
        driver_node.sleep_until = _timed(driver_node.sleep_until, totals, "wait")
    init, loop = driver_node.Driver.__init__, driver_node.Driver.main_loop

    def patched_init(self):
        init(self)
        if not plain:
            self.pub_cr.publish = _timed(self.pub_cr.publish, totals, "_publish_cr")

    def patched_loop(self, stop):
        t0, c0, r0 = (
            time.monotonic_ns(),
            time.thread_time_ns(),
            resource.getrusage(resource.RUSAGE_SELF),
        )
        loop(self, stop)
        t1, c1, r1 = (
            time.monotonic_ns(),
            time.thread_time_ns(),
            resource.getrusage(resource.RUSAGE_SELF),
        )
        cpu = (r1.ru_utime + r1.ru_stime - r0.ru_utime - r0.ru_stime) * 1e9
        Path(out).write_text(
            json.dumps(
                {
                    "ticks": self.session.k,
                    "wall_ns": t1 - t0,
                    "loop_ns": c1 - c0,
                    "process_ns": cpu,
                    "late": self.late,
                    **totals,
                }
            )
        )

    driver_node.Driver.__init__, driver_node.Driver.main_loop = patched_init, patched_loop
    return driver_node.main([sys.argv[0], "--ros-args", *ros_args])


def split(r: dict) -> dict[str, float]:
    """Per-tick CPU (us) of each part, from the child's sums."""
    n = max(r["ticks"], 1)
    publish = r.get("_publish_js", 0) + r.get("_publish_setpoint", 0) + r.get("_publish_cr", 0)
    inside = r.get("plant", 0) + r.get("controller", 0) + publish
    parts = {"plant": r.get("plant", 0), "controller": r.get("controller", 0), "publish": publish,
             "wait": r.get("wait", 0), "rest": r["loop_ns"] - inside - r.get("wait", 0),
             "threads": r["process_ns"] - r["loop_ns"]}
    return {k: v / n / 1e3 for k, v in parts.items()}


def measure(seconds: float, params: list[str]) -> tuple[dict, dict]:
    """The driver's timed and untimed runs beside the recorder, identification and ctc."""
    from orthoglide_ident._install_ament import ROOT
    from orthoglide_sim.demos.graph import Graph

    config = ROOT / "config"
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        with Graph(out / "logs") as g:
            g.start("orthoglide_recorder", "recorder", {"output_dir": str(out / "bags")},
                    params_file=config / "recorder.yaml")
            g.start("orthoglide_identification", "identification", {"bag_dir": str(out / "bags")},
                    params_file=config / "identification.yaml")
            g.start("orthoglide_ctc", "ctc", params_file=config / "ctc.yaml")
            time.sleep(3.0)  # the subscribers are up before the first tick
            runs = {}
            for mode in ("plain", "timed"):
                path = out / f"{mode}.json"
                cmd = [sys.executable, __file__, "--child", str(path)] + (
                    ["--plain"] if mode == "plain" else []
                )
                for p in params:
                    cmd += ["-p", p]
                proc = subprocess.run(
                    cmd,
                    stdout=subprocess.DEVNULL,
                    stderr=subprocess.PIPE,
                    text=True,
                    timeout=seconds + 120,
                    env=dict(os.environ, PYTHONPATH=str(ROOT)),
                )
                if not path.exists():
                    raise RuntimeError(
                        f"the driver did not finish: {proc.stderr.strip().splitlines()[-3:]}"
                    )
                runs[mode] = json.loads(path.read_text())
    return runs["timed"], runs["plain"]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=10.0, help="s of real-time ticks (default 10)")
    ap.add_argument(
        "--plant", default=None, help="the driver's plant parameter (default: the driver's own)"
    )
    ap.add_argument("--payload", default="1.983")
    ap.add_argument("--controller", default="pid")
    ap.add_argument(
        "--hog",
        type=int,
        default=max((os.cpu_count() or 2) - 1, 1),
        help="busy processes beside the second run (default: one per core minus one; "
        "0: quiet only)",
    )
    ap.add_argument("--child", default=None, help=argparse.SUPPRESS)
    ap.add_argument("--plain", action="store_true", help=argparse.SUPPRESS)
    add_json_option(ap)
    args, rest = ap.parse_known_args(argv)
    if args.child:
        return child(args.child, rest, args.plain)
    from busy_machine import cpu_hog  # bench/ is on the path: this script's folder

    params = [
        f"duration:={args.seconds}",
        f"payload:={args.payload}",
        f"controller:={args.controller}",
        "trajectory:=exciting",
    ] + ([f"plant:={args.plant}"] if args.plant else [])
    columns = {}
    for hog in sorted({0, args.hog}):
        with cpu_hog(hog):
            try:
                columns["quiet" if not hog else f"hog {hog}"] = measure(args.seconds, params) + (
                    os.getloadavg()[0],
                )
            except RuntimeError as e:
                print(f"driver_cost: {e}", file=sys.stderr)
                return 1
    print(
        f"driver at 1 kHz for {args.seconds:g} s ({args.controller}, payload {args.payload}, plant "
        f"{args.plant or 'default'}) with recorder, identification, ctc running; CPU per tick (us):"
    )
    print(f"  {'':<11}" + "".join(f"{name:>16}" for name in columns))
    figs = Figures(before=BEFORE)
    table = figs.table(f"driver at 1 kHz for {args.seconds:g} s ({args.controller}, payload "
                       f"{args.payload}, plant {args.plant or 'default'}) with recorder, "
                       "identification, ctc running", ["CPU per tick [µs]", *columns])
    splits = {name: split(r) for name, (r, _, _) in columns.items()}
    for k in PARTS + ("total",):
        cells = [sum(sp.values()) if k == "total" else sp[k] for sp in splits.values()]
        print(f"  {k:<11}" + "".join(f"{c:16.1f}" for c in cells))
        table.row(k, *(f"{c:.1f}" for c in cells))
    rows = {"process CPU, % of a core (timed)": lambda r, p: 100 * r["process_ns"] / r["wall_ns"],
            "process CPU, % of a core (untimed)": lambda r, p: 100 * p["process_ns"] / p["wall_ns"],
            "late ticks (untimed run)": lambda r, p: p["late"]}
    for label, f in rows.items():
        print(f"  {label:<36}" + "".join(f"{f(r, p):8.0f}" for r, p, _ in columns.values()))
        table.row(label, *(f"{f(r, p):.0f}" for r, p, _ in columns.values()))
    line = ("load average: "
            + ", ".join(f"{name} {load:.1f}" for name, (_, _, load) in columns.items())
            + "; bar (issue 35): the untimed run <= 25 % of a core, also beside the hog")
    print(f"  {line}")
    figs.note(line)
    figs.write(args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
