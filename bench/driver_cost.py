"""Where the simulated Orthoglide driver's CPU goes, tick by tick, with the node set running.

    PYTHONPATH=. .venv/bin/python bench/driver_cost.py [--seconds 10] [--plant reduced|pinocchio]
                                                      [--payload 1.983] [--controller pid]

Starts the recorder, the live identification and the ctc as `make demo` does (they subscribe to
the driver's topics, so its publishing does the DDS work it does in the demo), then the driver in a
child process of this script, instrumented: the CPU time of its tick-loop thread
(time.thread_time_ns) spent in each part of a tick is summed over the run and printed per tick:

  plant       DriverSession.advance (the plant integrated over the tick, the current noise)
  controller  DriverSession.measure + control (encoder, PID, setpoint, limit)
  publish     JointState, CurrentReference and JointSetpoint built and published (3 per tick)
  wait        tick_clock.sleep_until's spin to the deadline (the loop's own busy wait)
  rest        the rest of the tick loop (locks, stamps, counters, /diagnostics once a second)
  threads     every other thread of the process (executor, inputs' batch taker, DDS)
and the whole process's CPU over the run in % of one core, in that run and in a run without the
timers before it (the figure `make demo` prints as "CPU while recording: driver ..."; the timers'
clock reads cost CPU of their own). Timing figures depend on what else the machine runs.
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

PARTS = ("plant", "controller", "publish", "wait", "rest", "threads")


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
    from orthoglide_sim import driver_node, session

    totals: dict[str, int] = {}
    for name, key in () if plain else (("advance", "plant"), ("measure", "controller"), ("control", "controller")):
        setattr(session.DriverSession, name, _timed(getattr(session.DriverSession, name), totals, key))
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
        t0, c0, r0 = time.monotonic_ns(), time.thread_time_ns(), resource.getrusage(resource.RUSAGE_SELF)
        loop(self, stop)
        t1, c1, r1 = time.monotonic_ns(), time.thread_time_ns(), resource.getrusage(resource.RUSAGE_SELF)
        cpu = (r1.ru_utime + r1.ru_stime - r0.ru_utime - r0.ru_stime) * 1e9
        Path(out).write_text(json.dumps({"ticks": self.session.k, "wall_ns": t1 - t0, "loop_ns": c1 - c0,
                                         "process_ns": cpu, "late": self.late, **totals}))

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


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=10.0, help="s of real-time ticks (default 10)")
    ap.add_argument("--plant", default=None, help="the driver's plant parameter (default: the driver's own)")
    ap.add_argument("--payload", default="1.983")
    ap.add_argument("--controller", default="pid")
    ap.add_argument("--child", default=None, help=argparse.SUPPRESS)
    ap.add_argument("--plain", action="store_true", help=argparse.SUPPRESS)
    args, rest = ap.parse_known_args(argv)
    if args.child:
        return child(args.child, rest, args.plain)
    from orthoglide_ident._install_ament import ROOT
    from orthoglide_sim.graph import Graph

    config = ROOT / "config"
    with tempfile.TemporaryDirectory() as tmp:
        out, result = Path(tmp), Path(tmp) / "split.json"
        with Graph(out / "logs") as g:
            g.start("orthoglide_recorder", "recorder", {"output_dir": str(out / "bags")},
                    params_file=config / "recorder.yaml")
            g.start("orthoglide_identification", "identification", {"bag_dir": str(out / "bags")},
                    params_file=config / "identification.yaml")
            g.start("orthoglide_ctc", "ctc", params_file=config / "ctc.yaml")
            time.sleep(3.0)  # the subscribers are up before the first tick
            params = [f"duration:={args.seconds}", f"payload:={args.payload}", f"controller:={args.controller}",
                      "trajectory:=exciting"] + ([f"plant:={args.plant}"] if args.plant else [])
            runs = {}
            for mode, path in (("plain", out / "plain.json"), ("timed", result)):
                cmd = [sys.executable, __file__, "--child", str(path)] + (["--plain"] if mode == "plain" else [])
                for p in params:
                    cmd += ["-p", p]
                proc = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                                      timeout=args.seconds + 120, env=dict(os.environ, PYTHONPATH=str(ROOT)))
                if not path.exists():
                    print(f"driver_cost: the driver did not finish: {proc.stderr.strip().splitlines()[-3:]}",
                          file=sys.stderr)
                    return 1
                runs[mode] = json.loads(path.read_text())
        r, plain = runs["timed"], runs["plain"]
    per_tick = split(r)
    total = sum(per_tick.values())
    print(f"driver, {r['ticks']} ticks at 1 kHz ({args.controller}, payload {args.payload}, plant "
          f"{args.plant or 'default'}), {r['late']} late; CPU per tick (us) with recorder, "
          f"identification, ctc running; load average {os.getloadavg()[0]:.1f}:")
    for k in PARTS:
        print(f"  {k:<11} {per_tick[k]:7.1f}  ({100 * per_tick[k] / total:4.1f} %)")
    print(f"  {'total':<11} {total:7.1f}; process CPU {100 * r['process_ns'] / r['wall_ns']:.0f} % of one core "
          f"(timed), {100 * plain['process_ns'] / plain['wall_ns']:.0f} % in a run without the timers")
    return 0


if __name__ == "__main__":
    sys.exit(main())
