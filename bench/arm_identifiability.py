"""Do the simulated UR5's records carry its drive gains? A plain IDIM-TLS on them (paper eqs.
(33)-(36)) with the simulator's own regressor (orthoglide_sim.arms.pinocchio_truth), not the
product's
pipeline: a check of the plant and its records, figures for the identification to compare with.

    .venv/bin/python bench/arm_identifiability.py [--seconds 60]

Records: unloaded on exciting1, 2 kg on exciting2, 0.5 % current noise, 2^19-count encoders.
Processing: zero-phase 4th-order Butterworth low-pass of q and v_tau (parallel filtering), central
differences, states at mid-tick (v_tau[k] acts over [t_k, t_k+1)), every 10th sample, rows per
joint / (g_j σ_j), the payload's torques (known mass, CoM, inertia) as the known column, scale
from it. Samples within ``margin`` of any joint's velocity reversal (|q̇| < 0.03 rad/s) are left
out: the filter smears the friction's jump over tens of ms around each.
"""
from __future__ import annotations

import argparse

import numpy as np
from _figures import Figures, add_json_option
from scipy.ndimage import minimum_filter1d
from scipy.signal import butter, filtfilt

from orthoglide_sim.arms.description import load_arm
from orthoglide_sim.arms.pinocchio_truth import ArmRegressor, TruthDynamics
from orthoglide_sim.arms.record import ArmRecord, simulate_arm
from orthoglide_sim.arms.truth import default_truth

TICK = 1.0e-3  # s
CUTOFF = 25.0  # Hz, low-pass of q and v_tau
DECIMATE = 10
EDGE = 200  # ticks dropped at each end (filter start-up)
REVERSAL_SPEED = 0.03  # rad/s
EMITS_JSON = True  # --json PATH: the figures for bench/write_benchmarks.py


def tls_rows(rec: ArmRecord, reg: ArmRegressor, margin_ticks: int, source: str = "q") -> np.ndarray:
    """[W, -V, τ_payload] of one record, rows joint by joint / (g_j σ_j)."""
    truth = rec.truth
    b, a = butter(4, CUTOFF / (0.5 / TICK))
    q = filtfilt(b, a, getattr(rec, source), axis=0)
    qd = np.gradient(q, TICK, axis=0)
    qdd = np.gradient(qd, TICK, axis=0)
    mid = lambda x: 0.5 * (x[:-1] + x[1:])  # noqa: E731  (the zero-order hold's half tick)
    q, qd, qdd, v = mid(q), mid(qd), mid(qdd), filtfilt(b, a, rec.v_tau[:-1], axis=0)
    away = np.abs(rec.qd_true) > REVERSAL_SPEED
    away = minimum_filter1d(away.astype(np.uint8), 2 * margin_ticks + 1, axis=0).astype(bool)[:-1]
    keep = np.zeros(len(q), bool)
    keep[EDGE:-EDGE:DECIMATE] = True
    keep &= away.all(axis=1)
    q, qd, qdd, v = q[keep], qd[keep], qdd[keep], v[keep]
    m, n = q.shape
    V = np.zeros((n * m, n))
    for j in range(n):
        V[j * m:(j + 1) * m, j] = v[:, j]
    known = np.zeros(n * m)
    if rec.payload is not None:
        known = (TruthDynamics(truth, rec.payload).torques(q, qd, qdd)
                 - TruthDynamics(truth).torques(q, qd, qdd)).T.ravel()
    sigma = np.repeat(np.maximum(rec.current_noise_std, 1e-4) * truth.drive_array("g_tau"), m)
    return np.hstack([reg.base(q, qd, qdd), -V, known[:, None]]) / sigma[:, None]


def gains(
    records: list[ArmRecord], reg: ArmRegressor, margin_ticks: int, source: str = "q"
) -> np.ndarray:
    """g_tau by TLS: the right singular vector of the smallest singular value, scaled so that the
    payload's known column has coefficient 1 (eq. 36)."""
    A = np.vstack([tls_rows(r, reg, margin_ticks, source) for r in records])
    x = np.linalg.svd(A, full_matrices=False)[2][-1]
    n = records[0].truth.arm.n
    return (x / x[-1])[-n - 1:-1]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=60.0, help="per record (default 60)")
    add_json_option(ap)
    args = ap.parse_args()
    truth = default_truth(load_arm("ur5"))
    reg = ArmRegressor(truth.arm)
    g_true = truth.drive_array("g_tau")
    print(
        f"UR5, {args.seconds:g} s unloaded + {args.seconds:g} s with 2 kg; gain error (%) per joint"
    )
    figs = Figures(before="new")
    table = figs.table(f"gain error, UR5, {args.seconds:g} s unloaded + {args.seconds:g} s with "
                       f"2 kg (the simulator's own regressor, {CUTOFF:g} Hz filter)",
                       ["case", *(f"{j} [%]" for j in truth.arm.joint_names)])
    print(
        f"  {'nominal gains':<36}"
        + " ".join(f"{v:7.3f}" for v in 100 * (truth.arm.nominal_gains / g_true - 1))
    )
    table.row("nominal gains", *(f"{v:.3f}" for v in 100 * (truth.arm.nominal_gains / g_true - 1)))
    for noise in (False, True):
        recs = [
            simulate_arm(args.seconds, payload=p, trajectory=t, seed=s, truth=truth, noise=noise)
            for p, t, s in ((None, "exciting1", 0), ("2.0", "exciting2", 1))
        ]
        for margin in (8, 40):
            g = gains(recs, reg, margin)
            label = f"{'noisy' if noise else 'noise-free'}, reversals ±{margin} ms"
            print(f"  {label:<36}" + " ".join(f"{v:7.3f}" for v in 100 * (g / g_true - 1)))
            table.row(label, *(f"{v:.3f}" for v in 100 * (g / g_true - 1)))
    figs.write(args.json)


if __name__ == "__main__":
    main()
