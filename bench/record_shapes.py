"""Every record shape of issue 43 in one table: TLS and IV side by side, the lag read both ways.

    PYTHONPATH=.:tests .venv/bin/python bench/record_shapes.py [--quick] [--markdown] [--cache DIR]

Rows (the generators of bench/logger_sampling.py, bench/tls_vs_iv.py, bench/partial_answers.py,
imported, not copied):

- UR5 (MuJoCo plant under its PID), unloaded + 2 kg: its 1 kHz log; ~83 Hz (every 10/12/14th
  tick) and ~250 Hz (every 3/4/5th) point-sampled from that 1 kHz loop, the loop's current as
  it is ("raw") and low-passed below the log's Nyquist frequency ("smooth"); a controller at
  the log rate on a 10/12 ms clock (91 Hz, held);
- the example-robot-data Panda (7 axes), 1 kHz, at 0.5/1/2/5 % current noise, a payload known
  by its mass only: tests/panda_arm.py's (the fingers fixed in the URDF, 1 kg, noise a share of
  each joint's rms current) and tests/locked_panda.py's (the URDF as it comes, the fingers
  locked by the robot file's locked_joints, 2 kg, noise a share of the rms over the joints);
- the UR10 (32.7 kg) with a 2.8 kg payload of unknown CoM, 90.9 Hz on a 10/12 ms clock, q printed
  to 1e-4 rad (one unloaded/loaded pair).

Each shape is identified as ``orthoglide-ident identify`` does (default options: current
sampling auto) by TLS and by IV. Per gain: error in % and in its σ, or ``-`` and a footnote
when not determined (why). Then the identified current-loop lag (ms, min..max over the joints)
with the records read held and read sampled ("-": no lag identified, e.g. uneven steps).
``--quick``: shorter records (UR5 20 s, Panda 10 s, UR10 20 s); default 60 / 40 / 60 s.
"""
from __future__ import annotations

import argparse
import dataclasses
import logging
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

import locked_panda as L  # noqa: E402
import numpy as np  # noqa: E402
import panda_arm as P  # noqa: E402
from logger_sampling import simulated, smooth, to_record  # noqa: E402
from tls_vs_iv import NOISE_LEVELS  # noqa: E402

from orthoglide_ident.errors import OrthoglideError  # noqa: E402
from orthoglide_ident.identify import IdentifyOptions, identify_records  # noqa: E402
from orthoglide_ident.model.registry import load_robot  # noqa: E402
from orthoglide_sim.arms.big_arm import (  # noqa: E402
    UR10_FILE,
    big_arm_truth,
    pair_records,
    simulate_pair,
)
from orthoglide_sim.arms.log import KEEP_3_4_5, KEEP_10_12_14, point_sampled  # noqa: E402

Z_HONEST = 3.0  # a determined gain beyond this many σ of the truth: flagged "!"
MAIN_AXES = 3  # the first joints of each arm: "main axes", within 1 %


def ur5_shapes(seconds: float, cache: Path | None):
    """(name, records, truth gains) of the UR5 shapes."""
    k1, held = simulated("1k", seconds, cache), simulated("91", seconds, cache)
    rec = lambda name, rs: [to_record(r, f"{name} {i}") for i, r in enumerate(rs)]  # noqa: E731
    pt = lambda keep, hz, f: [point_sampled(f(r, hz), keep, 0.0) for r in k1]  # noqa: E731
    raw = lambda r, hz: r  # noqa: E731
    g = k1[0].truth.drive_array("g_tau")
    return [("UR5 1 kHz", rec("1k", k1), g),
            ("UR5 ~83 Hz pt, raw", rec("83", pt(KEEP_10_12_14, 83.3, raw)), g),
            ("UR5 ~83 Hz pt, smooth", rec("83s", pt(KEEP_10_12_14, 83.3, smooth)), g),
            ("UR5 ~250 Hz pt, raw", rec("250", pt(KEEP_3_4_5, 250.0, raw)), g),
            ("UR5 ~250 Hz pt, smooth", rec("250s", pt(KEEP_3_4_5, 250.0, smooth)), g),
            ("UR5 91 Hz held", rec("91", held), g)]


def locked_panda_shapes(seconds: float):
    """The Panda as it comes (full URDF, bench/locked_panda.py's generator: 2 kg at the TCP),
    its fingers locked by the robot file, the payload told by its mass only; the current
    noise a share of the rms current over the joints of the noise-free records."""
    clean = [dataclasses.replace(r, payload=None) for r in L.records(seconds, 0.0)]  # mass only
    rms = float(np.sqrt(np.mean(np.concatenate([r.v_tau for r in clean]) ** 2)))
    rng = np.random.default_rng(0)
    return [(f"Panda locked {100 * n:g} % noise",
             [dataclasses.replace(r, v_tau=r.v_tau + n * rms * rng.standard_normal(r.v_tau.shape))
              for r in clean], L.TRUE_GAINS) for n in NOISE_LEVELS]


def other_shapes(panda_s: float, ur10_s: float):
    out = [(f"Panda {100 * n:g} % noise", P.records(panda_s, n, 0), P.GAINS)
           for n in NOISE_LEVELS]
    truth = big_arm_truth()
    pair = pair_records(simulate_pair(0, ur10_s, truth=truth))
    return out + [("UR10 + 2.8 kg, 91 Hz", pair, truth.drive_array("g_tau"))]


def solve(recs, model, method: str, **kw):
    try:
        return identify_records(recs, model=model, method=method, options=IdentifyOptions.of(**kw))
    except OrthoglideError as exc:
        return str(exc)


def cells(res, truth, notes: list[str]) -> list[str]:
    """Per gain 'error % / z σ' (! beyond Z_HONEST) or '- [n]' with footnote n."""
    if isinstance(res, str):
        notes.append(res[:160])
        return [f"refused [{len(notes)}]"] + [""] * (len(truth) - 1)
    out = []
    for g, t in zip(res.drive_gains, truth):
        if not g.determined:
            why = g.reason[:120]
            if why not in notes:
                notes.append(why)
            out.append(f"- [{notes.index(why) + 1}]")
            continue
        e = g.value / t - 1
        z = abs(e) / g.rel_std
        out.append(f"{100 * e:+.2f}/{z:.1f}" + ("!" if z > Z_HONEST else ""))
    return out


def lag(recs, model, sampling: str) -> str:
    res = solve(recs, model, "tls", current_sampling=sampling, cross_check="none")
    if isinstance(res, str) or not res.current_lag:
        return "-"
    taus = [x.tau_ms for x in res.current_lag]
    return f"{min(taus):+.2f}..{max(taus):+.2f}"


def verdict(rows: list) -> list[str]:
    """Every determined gain within Z_HONEST σ? the main axes within 1 %?"""
    beyond, off = [], []
    for name, method, res, truth in rows:
        if isinstance(res, str):
            continue
        for k, (g, t) in enumerate(zip(res.drive_gains, truth)):
            e = g.value / t - 1
            if g.determined and abs(e) > Z_HONEST * g.rel_std:
                beyond.append(f"{name} {method} {g.name} {100 * e:+.2f} % "
                              f"{abs(e) / g.rel_std:.1f} σ")
            if g.determined and k < MAIN_AXES and abs(e) > 0.01:
                off.append(f"{name} {method} {g.name} {100 * e:+.2f} %")
    return [f"determined gains beyond {Z_HONEST:g} σ: " + ("; ".join(beyond) or "none"),
            f"main axes (joints 1-{MAIN_AXES}) beyond 1 %: " + ("; ".join(off) or "none")]


def table(rows: list, lags: dict, markdown: bool) -> list[str]:
    notes: list[str] = []
    n = max(len(t) for *_, t in rows)
    head = ["shape", "method"] + [f"g{k + 1}" for k in range(n)] + ["lag held", "lag sampled"]
    body = []
    for name, method, res, truth in rows:
        c = cells(res, truth, notes) + [""] * (n - len(truth))
        lh, ls = lags[name] if method == "TLS" else ("", "")
        body.append([name if method == "TLS" else "", method] + c + [lh, ls])
    if markdown:
        out = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
        out += ["| " + " | ".join(r) + " |" for r in body]
    else:
        w = [max(len(r[i]) for r in [head] + body) for i in range(len(head))]
        out = ["  ".join(x.ljust(w[i]) for i, x in enumerate(r)) for r in [head] + body]
    return out + [""] + [f"[{i + 1}] {x}" for i, x in enumerate(notes)]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="shorter records")
    ap.add_argument("--markdown", action="store_true", help="a markdown table")
    ap.add_argument("--cache", type=Path, default=None, help="keep the UR5 simulations here")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.ERROR, stream=sys.stderr)
    ur5_s, panda_s, ur10_s = (20.0, 10.0, 20.0) if args.quick else (60.0, 40.0, 60.0)
    if args.cache is not None:
        args.cache.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    ur5, panda, ur10 = load_robot("ur5"), load_robot(str(P.URDF)), load_robot(str(UR10_FILE))
    shapes = [(s, ur5) for s in ur5_shapes(ur5_s, args.cache)]
    shapes += [(s, ur10 if s[0].startswith("UR10") else panda)
               for s in other_shapes(panda_s, ur10_s)]
    folder = tempfile.TemporaryDirectory()
    locked = load_robot(L.robot_file(Path(folder.name)))
    shapes += [(s, locked) for s in locked_panda_shapes(panda_s)]
    rows, lags = [], {}
    for (name, recs, truth), model in shapes:
        for method, label in (("tls", "TLS"), ("iv", "IV")):
            rows.append((name, label, solve(recs, model, method), truth))
        lags[name] = (lag(recs, model, "held"), lag(recs, model, "sampled"))
        print(f"# {name}: {time.perf_counter() - t0:.0f} s", file=sys.stderr, flush=True)
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                            text=True, cwd=Path(__file__).parent).stdout.strip()
    print(f"record shapes ({'quick: ' if args.quick else ''}UR5 2 x {ur5_s:g} s, Panda "
          f"{panda_s:g} + {panda_s:g} s, UR10 {ur10_s:g} + {ur10_s:g} s), "
          f"{time.strftime('%Y-%m-%d')}, commit {commit}; per gain error % / |error| in σ "
          f"(! beyond {Z_HONEST:g} σ), "
          "- not determined [why]; lag ms min..max over the joints")
    print("\n".join(table(rows, lags, args.markdown)))
    print("\n".join(verdict(rows)))
    print(f"({time.perf_counter() - t0:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
