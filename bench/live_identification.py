"""Live identification at 1 kHz: CPU per second of data, lag, convergence, equality with offline.

    PYTHONPATH=. .venv/bin/python bench/live_identification.py [--seconds 60] [--keep DIR]
        [--bags UNLOADED LOADED] [--split 2] [--realtime] [--png FILE]

An unloaded and a loaded (1.983 kg) run of --seconds each at 1 kHz (the simulator's, written as
bags in --keep DIR and reused; or --bags), each cut into --split recordings played alternately
(unloaded, loaded, unloaded, ...), are fed to LiveIdentification as a ROS node would: both topics
in batches of 1, 10 and 100 ms, current_reference 3 ticks behind joint_states, estimate() once
per second of data. As fast as possible (CPU time measured; --realtime paces the 10 ms feed at
1 kHz instead). Prints, per batch size, the CPU % of one core at 1 kHz and the lag (s of received
data not yet folded in, including each recording's first ~6 s held for the current-loop lag's
instrument) p50/max; the convergence of the gains against the plant's truth (printed and saved
as a PNG); live result() against identify_records on the same recordings (in σ with the lag
columns, relative with lag_model: off, the same equations); and the
offline `identify` of the two bags next to rosbags merely deserialising them (same run).
BLAS runs on one thread (OPENBLAS_NUM_THREADS=1 unless set): the figures are for one core.
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))

from _figures import Figures, add_json_option  # noqa: E402
from identify_data import record  # noqa: E402
from identify_speed import rosbags_read  # noqa: E402

from orthoglide_ident import bags  # noqa: E402
from orthoglide_ident.identify import (  # noqa: E402
    IdentifyOptions,  # noqa: E402
    LiveIdentification,  # noqa: E402
    Record,
    identify,
    identify_records,
    read_record,
)
from orthoglide_ident.model.registry import load_robot  # noqa: E402

ORTHOGLIDE = load_robot("orthoglide")  # the robot these records are of
EMITS_JSON = True  # --json PATH: the figures for bench/write_benchmarks.py
FIGS = Figures(before="nothing live")

# N/A, the plant's drive gains (docs/design/simulator.md)
G_TRUE = np.array([2170.0, 2100.0, 2070.0])


def get_bags(args, tmp: str) -> tuple[list[Path], str]:
    """The two bags: given, kept from an earlier run, or simulated now (into ``tmp``)."""
    if args.bags:
        return [Path(p) for p in args.bags], "given bags"
    d = Path(args.keep or tmp)
    d.mkdir(parents=True, exist_ok=True)
    paths, source = [], "bags kept from an earlier run"
    for name, m, seed in (("unloaded", 0.0, 1), ("loaded", 1.983, 2)):
        if not (d / name).exists():
            t0 = time.perf_counter()
            rec, truth = record(args.seconds, m, seed)
            bags.write_bag(d / name, rec.stamps_q_ns, rec.q, rec.v_tau, rec.condition, m,
                           joint_names=ORTHOGLIDE.joint_names)
            source = truth["source"]
            print(f"wrote {d / name} ({source}) in {time.perf_counter() - t0:.1f} s",
                  file=sys.stderr)
        paths.append(d / name)
    return paths, source


def split(records: list[Record], parts: int) -> list[Record]:
    """Each record cut into ``parts`` recordings, played unloaded, loaded, unloaded, ..."""
    out = []
    for k in range(parts):
        for r in records:
            n = len(r.stamps_q_ns)
            a, b = k * n // parts, (k + 1) * n // parts
            out.append(Record.from_arrays(f"{Path(r.source).name}-{k + 1}", r.stamps_q_ns[a:b],
                                          r.q[a:b], r.v_tau[a:b], r.condition, r.payload_mass,
                                          joint_names=ORTHOGLIDE.joint_names))
    return out


def play(live: LiveIdentification, recs: list[Record], batch: int, lag_ticks: int = 3,
         realtime: bool = False) -> tuple[float, float, list[dict]]:
    """Feed the recordings; CPU s, data s, and one estimate per second of data."""
    trace, t_data, cpu = [], 0.0, 0.0
    for rec in recs:
        n = len(rec.stamps_q_ns)
        live.start_recording(rec.source, rec.condition, rec.payload_mass)
        c0, w0 = time.process_time(), time.perf_counter()
        for a in range(0, n + lag_ticks, batch):
            if a < n:
                live.add_joint_states(rec.stamps_q_ns[a:a + batch], rec.names_q, rec.q[a:a + batch])
            b = a - lag_ticks
            if b + batch > 0 and b < n:
                b = max(b, 0)
                live.add_current_reference(rec.stamps_v_ns[b:a - lag_ticks + batch], rec.names_v,
                                           rec.v_tau[b:a - lag_ticks + batch])
            if (a // batch) % max(1, 1000 // batch) == 0 and a:  # a 1 Hz timer
                est = live.estimate()
                trace.append(dict(t=t_data + a * 1e-3, lag=est.lag_s, gains=est.gains,
                                  rel=est.gains_rel_std, status=est.status,
                                  su=est.seconds_unloaded, sl=est.seconds_loaded))
            if realtime:
                ahead = (a + batch) * 1e-3 - (time.perf_counter() - w0)
                if ahead > 0:
                    time.sleep(ahead)
        live.stop_recording()
        cpu += time.process_time() - c0
        t_data += n * 1e-3
    return cpu, t_data, trace


def in_sigma(live: list, offline: list) -> float:
    """Largest |live - offline| of estimates, in the offline σ."""
    return max(abs(a.value - b.value) / (b.rel_std * abs(b.value)) for a, b in zip(live, offline))


def convergence_table(trace: list[dict]) -> list[dict]:
    rows = [r for r in trace if len(r["gains"])]
    print(f"\nconvergence (batches of 10 ms): gain error vs the plant's truth "
          f"{', '.join(f'{g:g}' for g in G_TRUE)} N/A")
    print(f"{'data s':>7} {'unl. s':>7} {'load. s':>7} {'q11 err%':>9} {'q12 err%':>9} "
          f"{'q13 err%':>9} {'max %σ':>7}  status")
    last = -1e9
    for r in rows:
        if r["t"] - last >= 10 or r is rows[-1]:
            err = 100 * (np.array(r["gains"]) / G_TRUE - 1)
            print(f"{r['t']:7.0f} {r['su']:7.1f} {r['sl']:7.1f} {err[0]:+9.3f} {err[1]:+9.3f} "
                  f"{err[2]:+9.3f} {100 * max(r['rel']):7.3f}  {r['status']}")
            last = r["t"]
    return rows


def plot(rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = np.array([r["t"] for r in rows])
    err = 100 * (np.array([r["gains"] for r in rows]) / G_TRUE - 1)
    sig = 100 * np.array([r["rel"] for r in rows])
    fig, ax = plt.subplots(figsize=(8, 4.5))
    for j, name in enumerate(("q11", "q12", "q13")):
        line, = ax.plot(t, err[:, j], label=f"g_tau {name}")
        ax.fill_between(t, err[:, j] - 2 * sig[:, j], err[:, j] + 2 * sig[:, j],
                        color=line.get_color(), alpha=0.15)
    ax.axhline(0, color="k", lw=0.6)
    ax.set_ylim(-2, 2)
    ax.set_xlabel("seconds of data recorded (unloaded and loaded recordings alternate)")
    ax.set_ylabel("gain error vs plant truth (%), band ±2σ")
    ax.set_title("Live IDIM-TLS: drive gains while recording")
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--seconds", type=float, default=60.0, help="length of each run (s)")
    ap.add_argument("--keep", help="write the bags here and reuse them")
    ap.add_argument("--bags", nargs=2, help="use these two bags (unloaded, loaded)")
    ap.add_argument("--split", type=int, default=2, help="recordings per run")
    ap.add_argument("--realtime", action="store_true", help="pace the 10 ms feed at 1 kHz")
    ap.add_argument("--png", default=str(Path(tempfile.gettempdir()) / "live_identification.png"),
                    help="convergence plot (PNG)")
    add_json_option(ap)
    args = ap.parse_args()

    with tempfile.TemporaryDirectory(prefix="live-bench-") as tmp:
        paths, source = get_bags(args, tmp)
        rc = run(args, paths, source)
    FIGS.write(args.json)
    return rc


def run(args, paths: list[Path], source: str) -> int:
    records = [read_record(p, model=ORTHOGLIDE) for p in paths]
    recs = split(records, args.split)
    secs = sum(len(r.stamps_q_ns) for r in records) * 1e-3
    print(f"\nlive identification — {secs:.0f} s at 1 kHz in {len(recs)} recordings ({source})")
    print(f"{'batch':>8} {'CPU s':>7} {'% of a core':>12} {'lag p50 s':>10} {'lag max s':>10}")
    table = FIGS.table(f"live identification — {secs:.0f} s at 1 kHz in {len(recs)} recordings "
                       f"({source})", ["batch", ("CPU", "s"), ("CPU", "% of a core"),
                                       ("lag p50", "s"), ("lag max", "s")])
    trace10, live10 = [], None
    for batch in (1, 10, 100):
        live = LiveIdentification(model=ORTHOGLIDE)
        cpu, t_data, trace = play(live, recs, batch, realtime=args.realtime and batch == 10)
        lags = np.array([r["lag"] for r in trace])
        print(f"{batch:>6}ms {cpu:7.2f} {100 * cpu / t_data:11.2f}% {np.median(lags):10.2f} "
              f"{lags.max():10.2f}")
        table.row(f"{batch} ms", f"{cpu:.2f}", f"{100 * cpu / t_data:.2f}",
                  f"{np.median(lags):.2f}", f"{lags.max():.2f}")
        if batch == 10:
            trace10, live10 = trace, live
    rows = convergence_table(trace10)
    if rows:
        plot(rows, Path(args.png))
        print(f"convergence plot: {args.png}")

    res, off = live10.result(), identify_records(recs,
                                                 model=ORTHOGLIDE)  # lag_model: auto, the default
    line = (f"live result() vs identify_records on the same recordings (lag_model: auto, the "
            f"live lag instrument from the previous periods only): max difference "
            f"{in_sigma(res.drive_gains, off.drive_gains):.2f} σ on the gains, "
            f"{in_sigma(res.parameters, off.parameters):.2f} σ on the base parameters; "
            "current-loop lag live " + ", ".join(f"{a.tau_ms:.3f}" for a in res.current_lag)
            + " ms, offline " + ", ".join(f"{b.tau_ms:.3f}" for b in off.current_lag) + " ms")
    print(f"\n{line}")
    FIGS.note(line)
    paper = IdentifyOptions.of(lag_model="off")
    live = LiveIdentification(paper, model=ORTHOGLIDE)
    play(live, recs, 100)
    res, off = live.result(), identify_records(recs, options=paper, model=ORTHOGLIDE)
    dg = max(abs(a.value / b.value - 1) for a, b in zip(res.drive_gains, off.drive_gains))
    dp = max(abs(a.value / b.value - 1) for a, b in zip(res.parameters, off.parameters))
    line = (f"the same equations (lag_model: off): max relative difference {dg:.1e} on the "
            f"gains, {dp:.1e} on the base parameters")
    print(line)
    FIGS.note(line)

    t_ros, n_msgs = rosbags_read(paths)
    t0 = time.perf_counter()
    offline = identify(paths, model=ORTHOGLIDE)
    t_id = time.perf_counter() - t0
    steps = offline.diagnostics.timings_s
    line = (f"offline, same run: identify {t_id:.2f} s in-process (regressor+decimation "
            f"{steps['regressor+decimation']:.2f} s) vs rosbags deserialising the {n_msgs} "
            f"messages {t_ros:.2f} s: ratio {t_id / t_ros:.2f}")
    print(f"\n{line}")
    FIGS.note(line)
    print("gains (N/A): " + ", ".join(f"{g.value:.1f}" for g in offline.drive_gains))
    return 0


if __name__ == "__main__":
    sys.exit(main())
