"""Tracking errors of PID, PID + velocity feed-forward and CTC on the test trajectories (paper Table 4).

    .venv/bin/python bench/ctc_tracking.py [--duration S] [--runs N] [--bags UNLOADED LOADED]

The simulated Orthoglide carries the 1.983 kg payload and tracks "test1" and "test2" (Fig. 6-like)
under five control laws with the same linear part (triple pole at 100 rad/s, see
orthoglide_ident.control):
  simple PID, PID with velocity feed-forward            (the simulator's "pid", "pid_ff");
  CTC, manuf. gains    model identified by WLS with g_tau = 2001 N/A, commands / 2001 (paper case 3);
  CTC, identif. gains  model and gains identified by IDIM-TLS (the product's result);
  CTC, gains +25 %     model identified by WLS with g_tau = 1.25 * 2001, commands / that (paper case 4);
  CTC, true model      the plant's own parameters and gains (the floor set by the encoder, the
                       noise and the linear part, for reference);
  CTC, TLS model/1.25g the TLS model with its gains multiplied by 1.25 afterwards (harsher: the
                       feed-forward itself is 20 % short).
The payload mass in every CTC model is the nominal 1.983 kg (as in the paper). The error is the
true actuator position minus the reference, in µm, rms and max per joint, averaged over ``--runs``
runs with different current-noise seeds (the paper ran each trajectory twice).
Parameters come from the sample bags (bags/unloaded + bags/loaded) unless --bags names others.
"""
from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from orthoglide_ident.control import CTC, G_TAU_MANUFACTURER, CTCParameters
from orthoglide_ident.identify.pipeline import identify
from orthoglide_sim.record import simulate, simulate_external
from orthoglide_sim.trajectories import get_trajectory

PAYLOAD = "1.983"


def true_model(m7: float) -> CTCParameters:
    """Base parameters of the plant's true standard parameters, with its true drive gains."""
    from orthoglide_ident.model.base import base_model
    from orthoglide_sim.true_parameters import load_parameters

    tp, bm = load_parameters(), base_model()
    return CTCParameters.from_values(bm.names, bm.base_values(tp.standard_vector()), tp.g_tau, m7)


def errors_um(rec) -> tuple[np.ndarray, np.ndarray]:
    e = (rec.q_true - rec.q_ref) * 1e6
    return np.abs(e).max(axis=0), np.sqrt(np.mean(e**2, axis=0))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=0.0,
                    help="s per run (default: one period of the trajectory)")
    ap.add_argument("--runs", type=int, default=2, help="runs per case, different noise seeds (default 2)")
    ap.add_argument("--bags", nargs=2, default=["bags/unloaded", "bags/loaded"], metavar=("UNLOADED", "LOADED"))
    args = ap.parse_args(argv)

    t0 = time.perf_counter()
    tls = identify(args.bags)
    wls_m = identify(args.bags, method="wls", gains=[G_TAU_MANUFACTURER] * 3)
    wls_e = identify(args.bags, method="wls", gains=[1.25 * G_TAU_MANUFACTURER] * 3)
    m7 = float(PAYLOAD)
    ctc_params = {
        "CTC, manuf. gains": CTCParameters.from_result(wls_m, payload_mass=m7),
        "CTC, identif. gains": CTCParameters.from_result(tls, payload_mass=m7),
        "CTC, gains +25 %": CTCParameters.from_result(wls_e, payload_mass=m7),
        "CTC, true model": true_model(m7),
        "CTC, TLS model/1.25g": CTCParameters.from_result(
            tls, payload_mass=m7, drive_gains=[1.25 * g.value for g in tls.drive_gains]),
    }
    print(f"identified from {', '.join(args.bags)} in {time.perf_counter() - t0:.1f} s: "
          f"TLS g_tau = {', '.join(f'{g.value:.1f}' for g in tls.drive_gains)} N/A; WLS payload estimates "
          f"{wls_m.payload_mass.value:.3f} kg (2001 N/A), {wls_e.payload_mass.value:.3f} kg (1.25 x 2001)")

    cases = ["simple PID", "PID + vel. ff"] + list(ctc_params)
    rows: dict[tuple[str, str], tuple[np.ndarray, np.ndarray]] = {}
    for traj_name in ("test1", "test2"):
        traj = get_trajectory(traj_name)
        duration = args.duration or traj.period
        for case in cases:
            maxs, rmss = [], []
            for seed in range(args.runs):
                if case == "simple PID" or case == "PID + vel. ff":
                    rec = simulate(duration, PAYLOAD, traj_name, "pid" if case == "simple PID" else "pid_ff", seed)
                else:
                    ctc = CTC(ctc_params[case], traj.evaluate)
                    rec = simulate_external(duration, ctc.command, PAYLOAD, traj_name, seed)
                mx, rms = errors_um(rec)
                maxs.append(mx)
                rmss.append(rms)
            rows[traj_name, case] = (np.mean(maxs, axis=0), np.mean(rmss, axis=0))

    w = max(len(c) for c in cases)
    print(f"\nTracking errors, payload {PAYLOAD} kg, mean of {args.runs} run(s) "
          f"({f'{args.duration} s' if args.duration else 'one period'} each), true position - reference (µm)")
    print(f"{'control strategy':<{w}}  {'maximal error':^26}  {'rms':^26}")
    print(f"{'':<{w}}  {'joint 1':>8}{'joint 2':>9}{'joint 3':>9}  {'joint 1':>8}{'joint 2':>9}{'joint 3':>9}")
    for traj_name in ("test1", "test2"):
        print(f"{traj_name}")
        for case in cases:
            mx, rms = rows[traj_name, case]
            print(f"{case:<{w}}  " + "".join(f"{v:9.1f}" for v in mx) + " " + "".join(f"{v:9.1f}" for v in rms))
    print("\nrms(simple PID) / rms(CTC, identif. gains): per joint, and over all three joints "
          "(bar: >= 20; the paper's Table 4 gives 29x, 29x, 8.4x on trajectory 1, 38-43x on trajectory 2)")
    ok = True
    for traj_name in ("test1", "test2"):
        pid, ctc = rows[traj_name, "simple PID"][1], rows[traj_name, "CTC, identif. gains"][1]
        pooled = np.sqrt(np.mean(pid**2)) / np.sqrt(np.mean(ctc**2))
        ok &= bool(pooled >= 20)
        print(f"  {traj_name}: " + ", ".join(f"{r:.0f}x" for r in pid / ctc) + f"; all joints {pooled:.0f}x")
    print(f"bar (all joints) {'met' if ok else 'NOT met'}; total {time.perf_counter() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
