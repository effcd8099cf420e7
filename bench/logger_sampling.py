"""A logger slower than its controller: the current held over the step or sampled at the stamp.

    .venv/bin/python bench/logger_sampling.py [--duration 60] [--fast-duration 40] [--cache DIR]

UR5 (MuJoCo plant under its PID), an unloaded and a 2 kg record (exciting1 seed 0, exciting2
seed 1), identified with current_sampling held, sampled and auto. Record shapes:

- ``1 kHz``: the 1 kHz loop's own log (its current held over each 1 ms tick);
- ``~83 Hz pt`` / ``~250 Hz pt``: the same loop logged every 10/12/14 or 3/4/5 ticks, each kept
  sample the loop's own q and current at that tick (orthoglide_sim.arms.log.point_sampled);
- ``..., smooth``: the same with the loop's current low-passed at 0.35 x the log rate before
  it is logged
  (a drive whose current reference has no content the log aliases): the timing alone;
- ``1 kHz pt of 10 kHz``: a 10 kHz loop logged every 10th tick (plant step 0.1 ms; smooth too);
- ``91 Hz held``: a controller at the log rate on a 10/12 ms clock (bench/real_records.py).

Per gain: error in % and in honest σ, ``*`` when marked not determined (the reason below the
row); the identified current-loop lag (ms) when the record allows one.
"""
from __future__ import annotations

import argparse
import dataclasses
import logging
import os
import pickle
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from orthoglide_ident.errors import OrthoglideError  # noqa: E402
from orthoglide_ident.identify import IdentifyOptions, identify_records  # noqa: E402
from orthoglide_ident.identify.observe.filtering import zero_phase_butterworth  # noqa: E402
from orthoglide_ident.model.registry import load_robot  # noqa: E402
from orthoglide_sim.arms.log import (  # noqa: E402
    KEEP_3_4_5,
    KEEP_10_12_14,
    clock_10_12,
    clock_uniform,
    point_sampled,
    simulate_arm_log,
)

sys.path.insert(0, str(Path(__file__).parent))
from real_records import to_record  # noqa: E402

RUNS = ((None, "exciting1", 0), ("2.0", "exciting2", 1))  # payload, trajectory, seed
SMOOTH = 0.35  # the smooth variants' current low-pass, a fraction of the log's rate (< Nyquist)


def simulated(kind: str, duration: float, cache: Path | None) -> list:
    """The two records of a controller ``kind`` ("1k", "10k", "91"), cached as pickles."""
    out = []
    for p, tr, s in RUNS:
        f = None if cache is None else cache / f"ur5_{kind}_{duration:g}_{s}.pkl"
        if f is not None and f.exists():
            out.append(pickle.loads(f.read_bytes()))
            continue
        if kind == "91":
            rec = simulate_arm_log(duration, clock_10_12(duration), payload=p, trajectory=tr,
                                   seed=s)
        else:
            rate, step = (1000.0, 2.5e-4) if kind == "1k" else (10000.0, 1e-4)
            rec = simulate_arm_log(duration, clock_uniform(duration, rate), payload=p,
                                   trajectory=tr, seed=s, print_resolution=0.0, timestep=step)
        if f is not None:
            f.write_bytes(pickle.dumps(rec))
        out.append(rec)
    return out


def smooth(rec, log_hz: float):
    """The loop's current without content above SMOOTH x ``log_hz`` (zero-phase, below the
    log's Nyquist frequency): nothing for the log to alias."""
    T = float(np.mean(np.diff(rec.stamps_ns))) * 1e-9
    return dataclasses.replace(rec, v_tau=zero_phase_butterworth(rec.v_tau, T, SMOOTH * log_hz, 4))


def shapes(duration: float, fast: float, cache: Path | None) -> list[tuple[str, list]]:
    k1 = simulated("1k", duration, cache)
    k10 = simulated("10k", fast, cache)
    held = simulated("91", duration, cache)
    return [("1 kHz", k1),
            ("~83 Hz pt", [point_sampled(r, KEEP_10_12_14, 0.0) for r in k1]),
            ("~250 Hz pt", [point_sampled(r, KEEP_3_4_5, 0.0) for r in k1]),
            ("~83 Hz pt, smooth", [point_sampled(smooth(r, 83.3), KEEP_10_12_14, 0.0) for r in k1]),
            ("~250 Hz pt, smooth", [point_sampled(smooth(r, 250.0), KEEP_3_4_5, 0.0) for r in k1]),
            ("1 kHz pt of 10 kHz", [point_sampled(r, 10, 0.0) for r in k10]),
            ("1 kHz pt of 10 kHz, smooth",
             [point_sampled(smooth(r, 1000.0), 10, 0.0) for r in k10]),
            ("91 Hz held", held)]


def row(name: str, mode: str, recs: list, model, loop_hz: float = 0.0) -> list[str]:
    t0 = time.perf_counter()
    try:
        res = identify_records([to_record(r, f"{name} {i}") for i, r in enumerate(recs)],
                               model=model, options=IdentifyOptions.of(current_sampling=mode,
                                                                       current_loop_hz=loop_hz))
    except OrthoglideError as exc:
        text = str(exc)
        text = text if len(text) < 240 else f"{text[:110]} … {text[-120:]}"
        return [f"{name:<27} {mode:<7} refused: {text}"]
    truth = recs[0].truth.drive_array("g_tau")
    cells, why = [], []
    for g, t in zip(res.drive_gains, truth):
        if not getattr(g, "determined", True) or not np.isfinite(g.value):
            cells.append(f"{'*':>14}")
            why.append(f"{g.name}: {getattr(g, 'reason', '')[:90]}")
            continue
        e = g.value / t - 1.0
        cells.append(f"{100 * e:+7.3f}%{abs(e) / g.rel_std:5.1f}σ")
    lag = ",".join(f"{x.tau_ms:+.2f}" for x in res.current_lag) or "-"
    chosen = "/".join(sorted({b.current_sampling for b in res.record_reports}))
    mode = mode + (f" {loop_hz / 1e3:g}k" if loop_hz else "")
    out = [f"{name:<27} {mode:<7}→{chosen:<7} " + " ".join(cells)
           + f"  lag {lag} ms  ({time.perf_counter() - t0:.0f} s)"]
    out += [f"{'':<37}{w}" for w in why]
    out += [f"{'':<37}note: {w[:150]}" for w in res.warnings if "current" in w and "sampl" in w]
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=60.0, help="s per 1 kHz / 91 Hz record")
    ap.add_argument("--fast-duration", type=float, default=40.0, help="s per 10 kHz record")
    ap.add_argument("--cache", type=Path, default=None, help="keep the simulations here")
    ap.add_argument("--only", default="", help="shapes whose name contains this")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.ERROR, stream=sys.stderr)
    if args.cache is not None:
        args.cache.mkdir(parents=True, exist_ok=True)
    model = load_robot("ur5")
    names = model.joint_names
    print(f"UR5, 2 x {args.duration:g} s (10 kHz loop: {args.fast_duration:g} s); gains: "
          + ", ".join(names) + "; error % and |error| in honest σ; * not determined")
    for name, recs in shapes(args.duration, args.fast_duration, args.cache):
        if args.only and args.only not in name:
            continue
        step = float(np.mean(np.diff(recs[0].stamps_ns))) * 1e-6
        print(f"\n{name} (mean step {step:.3g} ms)", flush=True)
        for mode in ("held", "sampled", "auto"):
            print("\n".join(row(name, mode, recs, model)), flush=True)
        if "pt" in name:  # the loop's rate known: its own half tick
            loop = 1e4 if "10 kHz" in name else 1e3
            print("\n".join(row(name, "sampled", recs, model, loop)), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
