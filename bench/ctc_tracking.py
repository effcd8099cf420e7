"""Tracking errors of PID, PID + velocity feed-forward and CTC on the test trajectories (paper
Table 4).

    .venv/bin/python bench/ctc_tracking.py [--duration S] [--runs N] [--bags UNLOADED LOADED]
    [--ros]

The simulated Orthoglide carries the 1.983 kg payload and tracks "test1" and "test2" (Fig. 6-like)
under five control laws with the same linear part (the driver's PID, triple pole at 100 rad/s):
  simple PID, PID with velocity feed-forward            (the driver's "pid", "pid_ff");
  CTC, manuf. gains    model identified by WLS with g_tau = 2001 N/A (paper case 3);
  CTC, identif. gains  model and gains identified by IDIM-TLS (the product's result);
  CTC, gains +25 %     model identified by WLS with g_tau = 1.25 * 2001 (paper case 4);
  CTC, true model      the plant's own parameters and gains (the floor set by the encoder, the
                       noise and the linear part, for reference).
Every CTC is the split law the node set runs: the driver's "pid_ff" plus the model feed-forward
current of each tick (orthoglide_ident.control.feedforward_currents), here without transport
(in-process). The payload mass in every CTC model is the nominal 1.983 kg (as in the paper). The
error is the true actuator position minus the reference, in um, rms and max per joint, averaged
over ``--runs`` noise seeds. Also the feed-forward's compute time per tick (the ctc node's batches
of 10 setpoints). ``--ros`` then runs the same table through the live node set
(orthoglide_sim.demos.node_set:
driver in real time, ctc node, DDS) and prints both side by side.
"""
from __future__ import annotations

import argparse
import sys
import time

import numpy as np
from _figures import Figures, add_json_option

from orthoglide_ident.control import CTCParameters, feedforward_currents
from orthoglide_ident.identify import identify
from orthoglide_ident.model.orthoglide.geometry import G_TAU_MANUFACTURER
from orthoglide_ident.model.registry import load_robot
from orthoglide_sim.common.trajectories import get_trajectory
from orthoglide_sim.orthoglide.record import simulate

ORTHOGLIDE = load_robot("orthoglide")  # the robot these records are of

PAYLOAD = "1.983"
EMITS_JSON = True  # --json PATH: the figures for bench/write_benchmarks.py
FIGS = Figures()


def true_model(m7: float) -> CTCParameters:
    """Base parameters of the plant's true standard parameters, with its true drive gains."""
    from orthoglide_ident.model.orthoglide.base import base_model
    from orthoglide_sim.orthoglide.truth import load_parameters

    tp, bm = load_parameters(), base_model()
    return CTCParameters.from_values(bm.names, bm.base_values(tp.standard_vector()), tp.g_tau, m7,
                                     model=ORTHOGLIDE)


def models(bags: list[str]) -> dict[str, CTCParameters]:
    m7 = float(PAYLOAD)
    tls = identify(bags, model=ORTHOGLIDE)
    wls_m = identify(bags, method="wls", gains=[G_TAU_MANUFACTURER] * 3, model=ORTHOGLIDE)
    wls_e = identify(bags, method="wls", gains=[1.25 * G_TAU_MANUFACTURER] * 3, model=ORTHOGLIDE)
    return {"CTC, manuf. gains": CTCParameters.from_result(wls_m, payload_mass=m7,
                                                           model=ORTHOGLIDE),
            "CTC, identif. gains": CTCParameters.from_result(tls, payload_mass=m7,
                                                             model=ORTHOGLIDE),
            "CTC, gains +25 %": CTCParameters.from_result(wls_e, payload_mass=m7, model=ORTHOGLIDE),
            "CTC, true model": true_model(m7)}


def run(
    traj_name: str, case: str, model: CTCParameters | None, duration: float, seed: int
) -> np.ndarray:
    """(N, 3) true position - reference, m."""
    if model is None:
        rec = simulate(
            duration, PAYLOAD, traj_name, "pid" if case == "simple PID" else "pid_ff", seed
        )
    else:
        ref = get_trajectory(traj_name).evaluate(np.arange(round(duration * 1000) + 1) * 1e-3)
        rec = simulate(
            duration, PAYLOAD, traj_name, "ctc", seed, feedforward=feedforward_currents(*ref, model)
        )
    return rec.q_true - rec.q_ref


def feedforward_cost(model: CTCParameters, batch: int = 10, n: int = 300) -> np.ndarray:
    """ms per tick of the model feed-forward computed in batches, as the ctc node does."""
    ref = get_trajectory("test2").evaluate(np.arange(batch + 1) * 1e-3)
    out = []
    for _ in range(n):
        t = time.perf_counter()
        feedforward_currents(*ref, model)
        out.append((time.perf_counter() - t) / batch * 1e3)
    return np.array(out)


def print_table(rows: dict, cases: list[str], title: str) -> None:
    w = max(len(c) for c in cases)
    print(f"\n{title}")
    print(f"{'control strategy':<{w}}  {'maximal error':^26}  {'rms':^26}")
    print(
        f"{'':<{w}}  {'joint 1':>8}{'joint 2':>9}{'joint 3':>9}  "
        f"{'joint 1':>8}{'joint 2':>9}{'joint 3':>9}"
    )
    table = FIGS.table(title, ["trajectory", "control strategy",
                               *(f"max error, joint {j} [µm]" for j in (1, 2, 3)),
                               *(f"rms, joint {j} [µm]" for j in (1, 2, 3))])
    for traj_name in ("test1", "test2"):
        print(traj_name)
        for case in cases:
            if (traj_name, case) in rows:
                mx, rms = rows[traj_name, case]
                print(
                    f"{case:<{w}}  "
                    + "".join(f"{v:9.1f}" for v in mx)
                    + " "
                    + "".join(f"{v:9.1f}" for v in rms)
                )
                table.row(traj_name, case, *(f"{v:.1f}" for v in (*mx, *rms)))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--duration", type=float, default=4.0, help="s per run (default 4: about two periods)"
    )
    ap.add_argument(
        "--runs", type=int, default=2, help="runs per case, different noise seeds (default 2)"
    )
    ap.add_argument(
        "--bags", nargs=2, default=["bags/unloaded", "bags/loaded"], metavar=("UNLOADED", "LOADED")
    )
    ap.add_argument(
        "--ros", action="store_true", help="also run the table through the live node set"
    )
    add_json_option(ap)
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    ctc = models(args.bags)
    cases = ["simple PID", "PID + vel. ff"] + list(ctc)
    rows = {}
    for traj_name in ("test1", "test2"):
        for case in cases:
            errs = [
                run(traj_name, case, ctc.get(case), args.duration, seed) * 1e6
                for seed in range(args.runs)
            ]
            rows[traj_name, case] = (
                np.mean([np.abs(e).max(axis=0) for e in errs], axis=0),
                np.mean([np.sqrt(np.mean(e**2, axis=0)) for e in errs], axis=0),
            )
    print_table(
        rows,
        cases,
        f"In-process, payload {PAYLOAD} kg, mean of {args.runs} run(s) of {args.duration} s "
        f"(true position - reference, um)",
    )
    for traj_name in ("test1", "test2"):
        pid, c = rows[traj_name, "simple PID"][1], rows[traj_name, "CTC, identif. gains"][1]
        line = (f"{traj_name}: rms PID / CTC identified " + ", ".join(f"{r:.0f}x" for r in pid / c)
                + " (paper Table 4: 29x, 29x, 8.4x on trajectory 1, 38-43x on trajectory 2)")
        print(f"  {line}")
        FIGS.note(line)
    cost = feedforward_cost(ctc["CTC, identif. gains"])
    line = (f"feed-forward compute per tick (batches of 10): p50 {np.percentile(cost, 50):.3f} "
            f"ms, p99 {np.percentile(cost, 99):.3f} ms")
    print(line)
    FIGS.note(line)
    if args.ros:
        ros_table(args.bags, args.duration, rows)
    print(f"total {time.perf_counter() - t0:.0f} s")
    FIGS.write(args.json)
    return 0


def ros_table(bags: list[str], duration: float, inproc: dict) -> None:
    """The same strategies through the live node set (driver real time, ctc node, DDS)."""
    import tempfile
    from pathlib import Path

    from orthoglide_sim.demos import node_set as demo
    from orthoglide_sim.demos.graph import Graph

    out = Path(tempfile.mkdtemp(prefix="ctc_ros_"))
    with Graph(out / "logs") as g:
        demo.start_graph(g, out)
        g.set_params("orthoglide_driver", payload=PAYLOAD)
        rows = demo.table4_over_ros(g, [str(Path(b).resolve()) for b in bags], duration)
        log = g.log_tail("orthoglide_driver", 3)
    ros = {
        k: (np.abs(e).max(axis=0) * 1e6, np.sqrt(np.mean(e**2, axis=0)) * 1e6)
        for k, e in rows.items()
    }
    print_table(ros, list(demo.TABLE4), "Over ROS 2 (encoder position - setpoint, um)")
    for traj_name in ("test1", "test2"):
        r, i = ros[traj_name, "CTC, identif. gains"][1], inproc[traj_name, "CTC, identif. gains"][1]
        line = f"{traj_name}: CTC identified over ROS / in-process " + ", ".join(
            f"{x:.2f}" for x in r / i)
        print(f"  {line}")
        FIGS.note(line)
    line = "driver: " + " | ".join(ln.split("]: ")[-1] for ln in log if "ticks" in ln)
    print(f"  {line}")
    FIGS.note(line)


if __name__ == "__main__":
    sys.exit(main())
