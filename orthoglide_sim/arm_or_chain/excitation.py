"""Design a robot's stored exciting trajectories, serial arm or closed chain, with the product's
designer (``orthoglide_ident.excite.design``, paper Sect. 3.2) inside the box its plant runs in
(arms/limits.py); common/designs.py writes the unloaded run as exciting1, the loaded one as
exciting2.

    python -m orthoglide_sim.arm_or_chain.excitation --robot ur5       # data/ur5_exciting{1,2}.json
    python -m orthoglide_sim.arm_or_chain.excitation --robot five_bar  # five_bar_exciting{1,2}.json

The same as ``orthoglide-ident excite design --robot ur5 --joint-limits BOX.yaml`` (a file of the
box), in the files the simulator's records read. Repeatable on one machine for a given ``--seed``.
"""
from __future__ import annotations

import argparse
import sys

from orthoglide_ident.errors import OrthoglideError
from orthoglide_ident.excite.prediction import DEFAULT_CURRENT_NOISE
from orthoglide_ident.model.robot import Payload
from orthoglide_sim.arm_or_chain.session import robot_truth
from orthoglide_sim.arms.description import ArmDescription, load_arm
from orthoglide_sim.arms.excitation import HARMONICS, PERIOD
from orthoglide_sim.arms.limits import motion_limits
from orthoglide_sim.chains.description import is_closed_chain, load_chain
from orthoglide_sim.common.designs import add_design_arguments, box_limits, design_and_write
from orthoglide_sim.common.trajectories import DATA_DIR

PERIODS = 12  # a 60 s record


def description(robot: str) -> ArmDescription:
    """The simulator's description of ``robot`` (a closed chain's or a serial arm's)."""
    return load_chain(robot) if is_closed_chain(robot) else load_arm(robot)


def loaded_payload(robot: str) -> Payload:
    """The payload of the robot's loaded record (the heaviest of its truth, bags.runs_for) as
    its bag tags it: mass, frame, centre of mass and inertia."""
    heavy = max(robot_truth(robot).payloads.values(), key=lambda p: p.mass)
    tag = heavy.tag()
    return Payload(heavy.mass, tag["payload_frame"], tag["payload_com"], tag["payload_inertia"])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m orthoglide_sim.arm_or_chain.excitation",
                                 description="Design a robot's stored exciting trajectories "
                                             "(the product's designer, in the simulator's box).")
    ap.add_argument(
        "--robot", default="ur5", help="bundled robot name, robot YAML or URDF (default ur5)"
    )
    ap.add_argument("--collision", choices=("mesh", "primitives", "skip"), default="mesh")
    add_design_arguments(ap, PERIOD, HARMONICS, PERIODS, None, DATA_DIR,
                         DEFAULT_CURRENT_NOISE)
    args = ap.parse_args(argv)
    try:
        from orthoglide_ident.model.registry import load_robot

        arm = description(args.robot)
        box = motion_limits(arm)
        robot = load_robot(args.robot)
        limits = box_limits(robot, box.centre - box.half, box.centre + box.half, box.velocity,
                            box.acceleration)
        design_and_write(robot, limits, args, prefix=f"{arm.name}_", collision=args.collision,
                         payload=loaded_payload(args.robot))
    except OrthoglideError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
