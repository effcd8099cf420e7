"""Records as real controllers log them: the simulated UR5 (MuJoCo) on an uneven clock.

    .venv/bin/python bench/real_records.py [--duration 60] [--fast-duration 20]

1. Unloaded + 2 kg records logged at ~91 Hz on a 10/12 ms alternating clock (the controller
   ticks there and holds its current between ticks), positions printed to 1e-4 rad, identified
   with the default options (no options file): each gain's error against the plant's truth, in
   % and in honest σ; the velocity on the stamps against the plant's (rms, relative), and what
   the median step as the period (before) gave.
2. One record at 5 kHz (plant step 0.1 ms) and the same decimated to 1 kHz (q every 5th sample,
   the current averaged over each 1 ms): base parameters and gains, their difference in σ.
"""
from __future__ import annotations

import argparse
import logging
import os
import sys
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402
from _figures import Figures, add_json_option  # noqa: E402

from orthoglide_ident.identify import (
    IdentifyOptions,  # noqa: E402
    Record,  # noqa: E402
    identify_records,  # noqa: E402
)
from orthoglide_ident.identify.observe.filtering import derivative_filter  # noqa: E402
from orthoglide_ident.identify.observe.time_base import states_on_stamps  # noqa: E402
from orthoglide_ident.model.registry import load_robot  # noqa: E402
from orthoglide_sim.arms.log import clock_10_12, clock_uniform, simulate_arm_log  # noqa: E402

EMITS_JSON = True  # --json PATH: the figures for bench/write_benchmarks.py
BEFORE = ("refused at 91 Hz (the 100 Hz cut-off above Nyquist); with an options file, velocities "
          "+10 % (the median step as the period); 5 kHz vs 1 kHz with the bridges' anchors in "
          "samples: up to 4.3 σ")


def to_record(rec, name: str) -> Record:
    cond = "unloaded" if rec.payload is None else "loaded"
    return Record.from_arrays(name, rec.stamps_ns, rec.q, rec.v_tau, cond, rec.payload_mass,
                              rec.joint_names, None if rec.payload is None else _payload(rec))


def _payload(rec):
    """The mounted payload as the bag's tag gives it (frame, centre of mass, inertia)."""
    from orthoglide_ident.model.robot import Payload

    tag = rec.payload.tag()
    return Payload(rec.payload_mass, tag["payload_frame"], tuple(tag["payload_com"]),
                   tuple(tag["payload_inertia"]))


def velocity_errors(rec) -> tuple[np.ndarray, np.ndarray]:
    """rms(q̂̇ - q̇) / rms(q̇) per joint at the stamps: on the stamps, and with the median step
    as the period (the pipeline before)."""
    opts = IdentifyOptions().at_rate(1e9 / np.mean(np.diff(rec.stamps_ns)))
    _, qd, _ = states_on_stamps(rec.q, rec.stamps_ns, opts.observe.filter_cutoff_hz,
                                zoh_shift=False)
    T_med = float(np.median(np.diff(rec.stamps_ns))) * 1e-9
    _, qd_med, _ = derivative_filter(rec.q, T_med, opts.observe.filter_cutoff_hz)
    sl = slice(100, -100)
    rms = np.sqrt(np.mean(rec.qd_true[sl] ** 2, axis=0))
    err = lambda x: np.sqrt(np.mean((x[sl] - rec.qd_true[sl]) ** 2, axis=0)) / rms  # noqa: E731
    return err(qd), err(qd_med)


def gains_table(res, truth_g: np.ndarray, names) -> list[str]:
    out = []
    for g, t, n in zip(res.drive_gains, truth_g, names):
        e = g.value / t - 1.0
        out.append(f"  {n:<22} {g.value:9.4f}  truth {t:9.4f}  {100 * e:+7.3f} %  "
                   f"{abs(e) / g.rel_std:5.2f} σ  (σ {100 * g.rel_std:.3f} %)")
    return out


def uneven_case(figs: Figures, duration: float, model) -> None:
    t0 = time.perf_counter()
    recs = [simulate_arm_log(duration, clock_10_12(duration), payload=p, trajectory=tr, seed=s)
            for p, tr, s in ((None, "exciting1", 0), ("2.0", "exciting2", 1))]
    print(f"\n1. UR5 {duration:g} s + {duration:g} s at 10/12 ms (mean 90.9 Hz), q printed to "
          f"1e-4 rad, default options (simulated in {time.perf_counter() - t0:.0f} s)")
    for r in recs:
        now, before = velocity_errors(r)
        line = (f"velocity rms error ({'loaded' if r.payload else 'unloaded'}): on the stamps "
                + " ".join(f"{100 * x:.3f}" for x in now) + " %; median step as the period "
                + " ".join(f"{100 * x:.2f}" for x in before) + " %")
        print(f"  {line}")
        figs.note(f"{duration:g} s at 10/12 ms, {line}")
    res = identify_records([to_record(r, f"uneven_{i}") for i, r in enumerate(recs)], model=model)
    truth = recs[0].truth.drive_array("g_tau")
    print("\n".join(gains_table(res, truth, model.joint_names)))
    table = figs.table(f"UR5 {duration:g} s + {duration:g} s at 10/12 ms (mean 90.9 Hz), q printed "
                       "to 1e-4 rad, default options", ["joint", "gain", "truth", ("error", "%"),
                                                        ("|error|", "σ"), ("σ", "%")])
    for g, t, n in zip(res.drive_gains, truth, model.joint_names):
        e = g.value / t - 1.0
        table.row(n, f"{g.value:.4f}", f"{t:.4f}", f"{100 * e:+.3f}", f"{abs(e) / g.rel_std:.2f}",
                  f"{100 * g.rel_std:.3f}")
    d = res.record_reports[0]
    line = (f"options at this rate: filter {d.filter_cutoff_hz:.4g} Hz, decimation by "
            f"{d.decimation} (cut-off {d.decimation_cutoff_hz:.4g} Hz)")
    print(f"  {line}")
    figs.note(f"{duration:g} s at 10/12 ms, {line}")


def decimate_to_1khz(rec):
    """q every 5th sample; the current averaged over each 1 ms (5 held values)."""
    import dataclasses

    n = (rec.q.shape[0] // 5) * 5
    v = rec.v_tau[:n].reshape(-1, 5, rec.v_tau.shape[1]).mean(axis=1)
    return dataclasses.replace(rec, stamps_ns=rec.stamps_ns[:n:5], q=rec.q[:n:5], v_tau=v,
                               qd_true=rec.qd_true[:n:5])


def fast_case(figs: Figures, duration: float, model) -> None:
    t0 = time.perf_counter()
    recs = [simulate_arm_log(duration, clock_uniform(duration, 5000.0), payload=p, trajectory=tr,
                             seed=s, print_resolution=0.0, timestep=1e-4)
            for p, tr, s in ((None, "exciting1", 0), ("2.0", "exciting2", 1))]
    print(f"\n2. UR5 {duration:g} s + {duration:g} s at 5 kHz vs the same decimated to 1 kHz "
          f"(simulated in {time.perf_counter() - t0:.0f} s)")
    a = identify_records([to_record(r, f"5k_{i}") for i, r in enumerate(recs)], model=model)
    b = identify_records([to_record(decimate_to_1khz(r), f"1k_{i}") for i, r in enumerate(recs)],
                         model=model)
    # differences in the larger of the two σ (the 1 kHz record's: its averaged current aliases
    # the 5 kHz PID's 0.5-2.5 kHz content)
    diffs = []
    for x, y in zip(
        list(a.drive_gains) + list(a.parameters), list(b.drive_gains) + list(b.parameters)
    ):
        s = max(abs(x.value * x.rel_std), abs(y.value * y.rel_std), 1e-300)
        diffs.append((abs(x.value - y.value) / s, x.name))
    truth = recs[0].truth.drive_array("g_tau")
    table = figs.table(f"UR5 {duration:g} s + {duration:g} s at 5 kHz vs the same decimated to "
                       "1 kHz: gain error ± σ", ["joint", ("5 kHz", "%"), ("1 kHz", "%"),
                                                 ("apart", "σ")])
    for x, y, t, (k, _), n in zip(a.drive_gains, b.drive_gains, truth, diffs, model.joint_names):
        print(
            f"  {n:<22} 5 kHz {100 * (x.value / t - 1):+7.3f} % ± {100 * x.rel_std:.3f} %   "
            f"1 kHz {100 * (y.value / t - 1):+7.3f} % ± {100 * y.rel_std:.3f} %   {k:.2f} σ apart"
        )
        table.row(n, f"{100 * (x.value / t - 1):+.3f} ± {100 * x.rel_std:.3f}",
                  f"{100 * (y.value / t - 1):+.3f} ± {100 * y.rel_std:.3f}", f"{k:.2f}")
    params = diffs[len(a.drive_gains):]
    worst = max(params)
    line = (f"gains: largest difference {max(diffs[:len(a.drive_gains)])[0]:.2f} σ; base "
            f"parameters: {sum(k <= 1 for k, _ in params)} of {len(params)} within 1 σ, largest "
            f"{worst[0]:.2f} σ ({worst[1]})")
    print(f"  {line}")
    figs.note(f"5 kHz vs 1 kHz, {line}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=60.0, help="s per uneven record (60)")
    ap.add_argument("--fast-duration", type=float, default=20.0, help="s per 5 kHz record (20)")
    ap.add_argument("--skip", choices=("uneven", "fast"), default=None)
    add_json_option(ap)
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.WARNING, stream=sys.stderr)
    model = load_robot("ur5")
    figs = Figures(before=BEFORE)
    if args.skip != "uneven":
        uneven_case(figs, args.duration, model)
    if args.skip != "fast":
        fast_case(figs, args.fast_duration, model)
    figs.write(args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
