"""Simulated UR5 (MuJoCo plant, 1 kHz PID): speed, tracking, excitation.

    .venv/bin/python bench/arm_simulator.py [--seconds 10]

Prints the simulation speed (x real time, one run each of the unloaded and the 2 kg record),
the tracking rms per joint, the currents and their noise, cond(W) of the designed trajectories
against random Fourier series scaled to the same limits, and the drive gains' σ that the
linearised IDIM-TLS (eqs. 35-36) predicts from 60 s unloaded + 60 s with the 2 kg payload at the
simulator's current noise (white, rows weighted per joint, every 1 kHz sample): a bound on what
the identification can reach on these records, not the identification itself.
"""
from __future__ import annotations

import argparse
import time

import numpy as np
from _figures import Figures, add_json_option

from orthoglide_sim.arms import excitation as ax
from orthoglide_sim.arms.description import load_arm
from orthoglide_sim.arms.limits import motion_limits
from orthoglide_sim.arms.pinocchio_truth import ArmRegressor, TruthDynamics
from orthoglide_sim.arms.record import simulate_arm
from orthoglide_sim.arms.truth import default_truth

RECORD_S = 60.0  # s per record the σ is predicted for
N_PERIOD = 500  # samples per period for the σ
EMITS_JSON = True  # --json PATH: the figures for bench/write_benchmarks.py
BEFORE = ("new; the last hand-written run, quiet: 10.4x / 11.1x real time (unloaded "
          "/ 2 kg), tracking rms 0.02–0.13 mrad, max 0.65 mrad; cond(W) 494 / 569 vs random "
          "median 1461; σ 0.004–0.015 %")
FIGS = Figures(before=BEFORE)


def _row(label: str, values, fmt: str = "{:8.3f}") -> str:
    return f"  {label:<28}" + " ".join(fmt.format(v) for v in values)


def speed_and_tracking(truth, seconds: float) -> dict:
    """Simulate both records; print their figures; return the noise σ per record."""
    noise = {}
    table = FIGS.table(f"{seconds:g} s records, per joint", ["figure", *truth.arm.joint_names])
    for payload, traj in ((None, "exciting1"), ("2.0", "exciting2")):
        t0 = time.perf_counter()
        rec = simulate_arm(seconds, payload=payload, trajectory=traj, seed=0, truth=truth)
        wall = time.perf_counter() - t0
        name = f"{traj}, {rec.payload_mass:g} kg"
        line = (f"{name}: {seconds:g} s simulated in {wall:.2f} s = {seconds / wall:.1f}x real "
                f"time, {rec.saturated_ticks} saturated ticks")
        print(line)
        FIGS.note(line)
        for label, x in (("tracking rms (mrad)", 1e3 * rec.tracking_rms),
                         ("tracking max (mrad)", 1e3 * np.abs(rec.q_true - rec.q_ref).max(0)),
                         ("v_tau rms (A)", np.sqrt(np.mean(rec.v_tau**2, axis=0))),
                         ("current noise σ (mA)", 1e3 * rec.current_noise_std)):
            print(_row(label, x))
            table.row(f"{name}: {label}", *(f"{v:.3f}" for v in x))
        noise[payload] = rec.current_noise_std
    return noise


def excitation(arm, reg: ArmRegressor) -> None:
    lim = motion_limits(arm)
    random = np.array(
        [ax.condition_number(ax.random_trajectory(lim, s), reg.base) for s in range(20)]
    )
    print(f"cond(W), {len(reg.base_columns)} base columns, {ax.SAMPLES} samples per period:")
    designed = []
    for name in ("exciting1", "exciting2"):
        designed.append((name, ax.condition_number(ax.designed_trajectory(arm, name), reg.base)))
        print(f"  {name:<28}{designed[-1][1]:8.1f}")
    line = (f"median {np.median(random):.1f}, best {random.min():.1f}, worst "
            f"{random.max():.1f}")
    print(f"  {'random Fourier (20 seeds)':<28}{line}")
    FIGS.note(f"cond(W) {', '.join(f'{n} {c:.1f}' for n, c in designed)}; random Fourier (20 "
              f"seeds) {line}")


def _tls_rows(truth, reg, traj_name: str, payload, sigma: np.ndarray) -> np.ndarray:
    """[W, -V, W_payload] of one period, each joint's rows / (g_j σ_j), weighted for the
    RECORD_S of 1 kHz samples they stand for; V: the currents, joint j in column j."""
    traj = ax.designed_trajectory(truth.arm, traj_name)
    t = np.linspace(0.0, traj.period, N_PERIOD, endpoint=False)
    q, qd, qdd = traj.evaluate(t)
    g = truth.drive_array("g_tau")
    tau = TruthDynamics(truth, payload).torques(q, qd, qdd, friction=True)
    known = tau - TruthDynamics(truth).torques(q, qd, qdd, friction=True)  # the payload's torques
    n = truth.arm.n
    V = np.zeros((n * N_PERIOD, n))
    for j in range(n):
        V[j * N_PERIOD:(j + 1) * N_PERIOD, j] = tau[:, j] / g[j]
    w = np.repeat(1.0 / (g * sigma), N_PERIOD)[:, None] * np.sqrt(RECORD_S * 1000.0 / N_PERIOD)
    return np.hstack([reg.base(q, qd, qdd), -V, known.T.reshape(-1, 1)]) * w


def predicted_gain_std(truth, reg, noise: dict) -> np.ndarray:
    """Relative σ (%) of the gains: eq. (35) linearised, unknowns [χ, g], payload column known."""
    A = np.vstack([_tls_rows(truth, reg, "exciting1", None, noise[None]),
                   _tls_rows(truth, reg, "exciting2", truth.payload("2.0"), noise["2.0"])])
    M = A[:, :-1]  # the payload's column is the right-hand side, known exactly
    cov = np.linalg.inv(M.T @ M)
    n = truth.arm.n
    return 100.0 * np.sqrt(np.diag(cov)[-n:]) / truth.drive_array("g_tau")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=10.0, help="simulated seconds per record")
    add_json_option(ap)
    args = ap.parse_args()
    arm = load_arm("ur5")
    truth = default_truth(arm)
    print(f"UR5 on MuJoCo, RK4 4 x 0.25 ms per 1 kHz tick; joints {', '.join(arm.joint_names)}")
    noise = speed_and_tracking(truth, args.seconds)
    reg = ArmRegressor(arm)
    excitation(arm, reg)
    sigma = predicted_gain_std(truth, reg, noise)
    print(
        f"predicted gain σ, {RECORD_S:g} s unloaded + {RECORD_S:g} s with 2 kg, 0.5 % current "
        "noise:"
    )
    print(_row("σ(g_tau) (%)", sigma))
    FIGS.table(f"predicted gain σ, {RECORD_S:g} s unloaded + {RECORD_S:g} s with 2 kg, 0.5 % "
               "current noise", ["", *arm.joint_names]).row(
        "σ(g_tau) [%]", *(f"{v:.3f}" for v in sigma))
    FIGS.write(args.json)


if __name__ == "__main__":
    main()
