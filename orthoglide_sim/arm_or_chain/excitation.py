"""Design a robot's exciting trajectories, serial arm or closed chain (the optimiser:
arms/excitation.py, paper Sect. 3.2): the regressor the design runs on is the robot's.

    python -m orthoglide_sim.arm_or_chain.excitation --robot ur5       # data/ur5_exciting{1,2}.json
    python -m orthoglide_sim.arm_or_chain.excitation --robot five_bar  # five_bar_exciting{1,2}.json

The search (best of ``--restarts`` random shapes, then a seeded (1+1) evolution strategy on
log cond(W)) is repeatable on one machine for a given ``--seed``.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from orthoglide_ident.errors import ConfigError, OrthoglideError
from orthoglide_sim.arms.description import ArmDescription, load_arm
from orthoglide_sim.arms.excitation import HARMONICS, PERIOD, Regressor, design_path, optimise
from orthoglide_sim.arms.limits import MotionLimits, motion_limits
from orthoglide_sim.arms.pinocchio_truth import ArmRegressor
from orthoglide_sim.chains.description import is_closed_chain, load_chain
from orthoglide_sim.common.trajectories import DATA_DIR, FourierTrajectory


def design_regressor(robot: str) -> tuple[ArmDescription, Regressor]:
    """The robot's description and the regressor its trajectories are designed on: a serial
    arm's URDF regressor (pinocchio_arm), a closed chain's the product's general model (its
    base columns, rows of the actuated joints through the loops)."""
    if is_closed_chain(robot):
        from orthoglide_ident.model.robots import load_robot

        return load_chain(robot), load_robot(robot).regressor
    arm = load_arm(robot)
    return arm, ArmRegressor(arm).base


def _write(
    path: Path,
    arm: ArmDescription,
    traj: FourierTrajectory,
    cond: float,
    limits: MotionLimits,
    seed: int,
) -> None:
    doc = traj.to_dict() | {
        "robot": arm.name,
        "joint_names": list(arm.joint_names),
        "criterion": "cond",
        "condition_number": cond,
        "seed": seed,
        "limits": {
            k: getattr(limits, k).tolist() for k in ("centre", "half", "velocity", "acceleration")
        },
    }
    path.write_text(json.dumps(doc, indent=1) + "\n")
    print(f"{path}: cond(W) {cond:.1f}, period {traj.period:g} s, {traj.a.shape[1]} harmonics")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m orthoglide_sim.arm_or_chain.excitation",
                                 description="Design a robot's exciting trajectories (cond(W)).")
    ap.add_argument(
        "--robot", default="ur5", help="bundled robot name, robot YAML or URDF (default ur5)"
    )
    ap.add_argument("--harmonics", type=int, default=HARMONICS)
    ap.add_argument("--period", type=float, default=PERIOD, help="s (default 5)")
    ap.add_argument("--restarts", type=int, default=20)
    ap.add_argument("--steps", type=int, default=600, help="evolution-strategy steps (default 600)")
    ap.add_argument("--seed", type=int, default=0, help="exciting1 uses it, exciting2 seed + 1")
    ap.add_argument("--out-dir", type=Path, default=DATA_DIR)
    args = ap.parse_args(argv)
    try:
        if args.harmonics < 1 or not args.period > 0:
            raise ConfigError("--harmonics must be >= 1 and --period positive")
        arm, regressor = design_regressor(args.robot)
        limits = motion_limits(arm)
        for k in (1, 2):
            traj, cond = optimise(regressor, limits, args.harmonics, args.period, args.seed + k - 1,
                                  args.restarts, args.steps, verbose=True)
            _write(
                design_path(arm.name, k, args.out_dir), arm, traj, cond, limits, args.seed + k - 1
            )
    except OrthoglideError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
