"""``orthoglide-ident excite run``: run one exciting-trajectory run on the robot and record it.

    orthoglide-ident excite run traj.yaml --condition unloaded
    orthoglide-ident excite run traj.yaml --condition loaded [--payload-mass KG] [--controller NAME]

Steps (excite.runner; progress on stderr): check the run against the robot; read where
the robot is (``joint_states``); move to the run's start pose slowly (its own goal); start the
recorder with the run's tag; send the run to ``<controller>/follow_joint_trajectory``, showing
the feedback and the live identification (its estimate and "enough data" status); stop the
recorder when the goal succeeds. On Ctrl-C, an aborted goal or a tolerance violation, the goal
is cancelled and the recording stopped with the reason: the bag is kept, tagged
``orthoglide.incomplete`` (docs/design/bags.md), and the command exits 1.
"""
from __future__ import annotations

import argparse
import sys
from typing import Any

from orthoglide_ident import ros_client
from orthoglide_ident.excite import plan
from orthoglide_ident.model.registry import add_description_options, load_robot_from_args

EXIT_INCOMPLETE = 1


def add_run_command(excite_sub: Any) -> None:
    """``run`` under ``orthoglide-ident excite``."""
    p = excite_sub.add_parser(
        "run",
        help="run a trajectory file's run through the joint_trajectory_controller and record it "
             "(ROS 2)",
        description=__doc__.split("\n\n", 1)[1],
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "trajectory", metavar="TRAJ.yaml", help="the exciting-trajectory file (excite design)"
    )
    p.add_argument("--condition", required=True, choices=("unloaded", "loaded"), help="which run")
    p.add_argument("--payload-mass", type=float, default=None, metavar="KG",
                   help="loaded: the weighed payload (default: the file's loaded payload mass)")
    p.add_argument("--robot", default=None, metavar="FILE",
                   help="the robot (URDF, .urdf.xacro, MJCF or robot YAML; default: the file's "
                        "robot)")
    add_description_options(p)  # --xacro-arg, --package-dir: as identify and excite design
    p.add_argument(
        "--controller",
        default="joint_trajectory_controller",
        metavar="NAME",
        help="the joint_trajectory_controller: its action is NAME/follow_joint_trajectory",
    )
    p.add_argument("--joint-states", default="joint_states", metavar="TOPIC",
                   help="where the robot's position is read before the move to the start pose")
    p.add_argument("--rate", type=float, default=plan.SAMPLE_RATE_HZ, metavar="HZ",
                   help=f"points per second sent (default {plan.SAMPLE_RATE_HZ:g})")
    p.add_argument(
        "--path-tolerance",
        type=float,
        default=0.0,
        metavar="RAD",
        help="abort when a joint leaves the path by more (rad or m; default 0: the controller's)",
    )
    p.add_argument("--goal-time", type=float, default=1.0, metavar="S",
                   help="time after the end allowed to settle (default 1 s)")
    p.add_argument("--name", default="", help="bag folder name (default <condition>_<date>_<time>)")
    p.add_argument(
        "--no-record", action="store_true", help="run without recording (a dry run on the robot)"
    )
    ros_client.add_namespace(p)
    p.set_defaults(excite_handler=run_command)


def _say(text: str) -> None:
    print(f"excite run: {text}", file=sys.stderr, flush=True)


def run_robot(args: argparse.Namespace, traj):
    """The run's robot, resolved at the command's edge: ``--robot`` (else the trajectory file's)
    with ``--xacro-arg`` and ``--package-dir`` (flags.py's grammar, model/registry.py)."""
    return load_robot_from_args(args, args.robot or traj.robot)


def run_command(args: argparse.Namespace) -> int:
    from orthoglide_ident.excite.runner import ExcitationRunner, RunOptions
    from orthoglide_ident.excite.trajectory import load_trajectory

    traj = load_trajectory(args.trajectory)
    robot = run_robot(args, traj)
    options = RunOptions(
        args.controller,
        args.joint_states,
        args.rate,
        args.path_tolerance,
        args.goal_time,
        record=not args.no_record,
    )
    with ros_client.Client(args.namespace) as c:
        runner = ExcitationRunner(
            c.node, lambda t: c.rclpy.spin_once(c.node, timeout_sec=t), _say, options
        )
        result = runner.run(
            traj, args.trajectory, robot, args.condition, args.payload_mass, args.name
        )
    print(result.message)
    return 0 if result.success else EXIT_INCOMPLETE
