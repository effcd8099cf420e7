"""Records of the coupled-wrist UR5 (issue 33) for the identification: unloaded and loaded.

    PYTHONPATH=. .venv/bin/python bench/coupled_wrist_records.py --out DIR [--seconds 60] [--seed 0]
        [--chain coupled|simple]

The MuJoCo plant of orthoglide_sim.coupled.plant (six motors behind N, gears of both signs,
motor 6 turning with q5 + q6; rotor inertia, viscous and Coulomb friction on each motor's own
velocity; per-motor current → torque gains) under a 1 kHz PID per motor: --seconds unloaded on
exciting1 and --seconds with arm_truth's 2 kg payload (CoM and inertia in the tag: a known
payload) on exciting2. Writes

    DIR/joint/unloaded, DIR/joint/loaded_2kg        /joint_states positions joint-side (q_j)
    DIR/actuator/unloaded, DIR/actuator/loaded_2kg  the same runs, positions motor-side (q_m)
    DIR/joint_torque/...                            positions joint-side, efforts the joint
                                                    torques Nᵀ g_nominal v (N·m, tagged torque)
    DIR/ur5_coupled_wrist.yaml, DIR/ur5_coupled_wrist_actuator.yaml, DIR/ur5.urdf
                                                    robot files with the transmission key
    DIR/truth.json                                  per-motor gains, Ia, fv, fs, offsets, N

(efforts: each motor's current reference, A, under the name of its row's joint). ``--chain
simple``: the same motors one per joint behind diag(32, -32, 45, -48, 45, -32) (ros2_control
SimpleTransmissions with negative reductions), the robot as DIR/ur5_simple_transmission.urdf
(the ``<ros2_control>`` block) and .yaml instead of the transmission key. Prints, per
run, the tracking, the saturation, the current noise as a joint torque, and the plant's checks:
motor velocities against N q̇ and the torque balance against Pinocchio's RNEA (coupled_check).
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from orthoglide_ident.errors import OrthoglideError
from orthoglide_sim.arms.transmission_urdf import write_simple_transmission_robot
from orthoglide_sim.coupled.check import torque_balance
from orthoglide_sim.coupled.record import simulate_coupled, write_coupled_bag, write_robot_files
from orthoglide_sim.coupled.truth import (
    default_coupled_truth,
    simple_transmission_truth,
    truth_summary,
)

RUNS = (("unloaded", None, "exciting1", 0), ("loaded_2kg", "2.0", "exciting2", 1))
# folder, position side, effort side (actuator: each motor's current, A; joint: Nᵀ g_nominal v, N·m)
LAYOUTS = (("joint", "joint", "actuator"), ("actuator", "actuator", "actuator"),
           ("joint_torque", "joint", "joint"))
SLIDING = 0.5  # rad/s at the motor: outside the soft Coulomb friction's band (tests/sim)


def _fmt(v, scale=1.0, digits=3) -> str:
    return "[" + ", ".join(f"{scale * x:.{digits}f}" for x in v) + "]"


def one_run(
    out: Path, name: str, payload, trajectory: str, seed: int, seconds: float, truth
) -> None:
    t0 = time.perf_counter()
    rec = simulate_coupled(seconds, payload=payload, trajectory=trajectory, seed=seed, truth=truth)
    sim_s = time.perf_counter() - t0
    for folder, position_side, effort_side in LAYOUTS:
        path = write_coupled_bag(out / folder / name, rec, position_side, effort_side)
        print(
            f"wrote {path}: {seconds:g} s at 1 kHz, {rec.payload_mass:g} kg, {trajectory}, seed "
            f"{seed}, "
            f"positions {position_side}-side, efforts {effort_side}-side"
        )
    N = truth.reduction
    g = truth.motor_array("gain")
    noise_tau = np.sqrt((N.T ** 2) @ (g * rec.current_noise_std) ** 2)  # σ of Nᵀ g ε per joint
    vel_err = np.abs(rec.qd_motor_true - rec.qd_true @ N.T).max() / np.abs(rec.qd_motor_true).max()
    bal = torque_balance(rec, step=max(1, rec.q_true.shape[0] // 2000))
    worst, share = bal.sliding_error(SLIDING)
    band = np.mean(np.abs(rec.qd_motor_true) < SLIDING, axis=0)
    print(
        f"  simulated in {sim_s:.1f} s (busy machine: indicative); tracking rms "
        f"{_fmt(rec.tracking_rms, 1e3)} mrad; "
        f"{rec.saturated_ticks} saturated ticks"
    )
    print(f"  motor current rms {_fmt(np.sqrt(np.mean(rec.v_tau ** 2, axis=0)))} A, noise σ "
          f"{_fmt(rec.current_noise_std, 1e3)} mA = {_fmt(noise_tau)} N·m at the joints")
    print(
        f"  checks: max |q̇_m - N q̇| / max |q̇_m| = {vel_err:.1e}; torque balance vs Pinocchio RNEA "
        f"{worst:.1e} (relative, {100 * share:.0f} % of sampled ticks with every |q̇_m| > {SLIDING} "
        "rad/s); "
        f"share of ticks in each motor's friction band {_fmt(100 * band, digits=1)} %"
    )


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, required=True, help="output folder")
    ap.add_argument("--seconds", type=float, default=60.0, help="seconds per record (default 60)")
    ap.add_argument("--seed", type=int, default=0, help="current-noise seed of the first record")
    ap.add_argument("--chain", choices=("coupled", "simple"), default="coupled",
                    help="coupled wrist (default) or one SimpleTransmission per joint")
    args = ap.parse_args(argv)
    truth = default_coupled_truth() if args.chain == "coupled" else simple_transmission_truth()
    try:
        args.out.mkdir(parents=True, exist_ok=True)
        for name, payload, trajectory, k in RUNS:
            one_run(args.out, name, payload, trajectory, args.seed + k, args.seconds, truth)
    except OrthoglideError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    write = write_robot_files if args.chain == "coupled" else write_simple_transmission_robot
    for path in write(args.out, truth):
        print(f"wrote {path}")
    summary = truth_summary(truth)
    (args.out / "truth.json").write_text(json.dumps(summary, indent=1, allow_nan=False) + "\n")
    print(f"wrote {args.out / 'truth.json'}")
    m = summary["motors"]
    for i, a in enumerate(summary["actuators"]):
        print(
            f"  motor {i + 1} ({a}): g {m['gain'][i]:.5f} N·m/A (nominal "
            f"{m['nominal_gain'][i]:.2f}), "
            f"Ia {m['inertia'][i]:.3e} kg·m², fv {m['viscous'][i]:.3e} N·m·s/rad, "
            f"fs {m['coulomb'][i]:.4f} N·m, off {m['offset'][i]:+.4f} N·m"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
