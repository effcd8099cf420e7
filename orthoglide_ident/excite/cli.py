"""``orthoglide-ident excite design|check``: the exciting-trajectory commands.

    orthoglide-ident excite design --robot R --payload-mass KG --out traj.yaml [--samples F.csv]
                                   [--seed S] [--current-noise A | --noise-from RESULT.json] ...
    orthoglide-ident excite check traj.yaml --robot R

Each action is one entry of ACTIONS: (help, add its options, run it); ``add_excite_commands``
builds the ``excite`` subcommand from the table and ``run_excite`` dispatches on it, so another
action (``run``) is one more line there.
"""
from __future__ import annotations

import argparse
import json
import logging
import math
from collections.abc import Callable
from pathlib import Path

import numpy as np

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.excite.limits import COLLISION_MODES  # not collision.py: Pinocchio
from orthoglide_ident.flags import parse_vector
from orthoglide_ident.model.registry import add_description_options
from orthoglide_ident.model.robot import RobotModel

_log = logging.getLogger("orthoglide_ident")


def _floats(text: str, n: int | None, what: str) -> list[float]:
    return list(parse_vector(text, n, what))  # the one grammar of vector flags (flags.py)


def _add_robot_options(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--robot",
        required=True,
        metavar="FILE",
        help="the robot: a URDF, a robot YAML (docs/guide/robot_files.md: its `excitation` "
        "key holds acceleration limits, home pose, collision primitives) or a "
        "bundled name (ur5, five_bar)",
    )
    p.add_argument("--joint-limits", metavar="YAML",
                   help="a ros2_control joint_limits YAML (position, velocity, acceleration, "
                        "effort per joint); overrides the robot file and the URDF")
    p.add_argument("--collision", choices=COLLISION_MODES, default="mesh",
                   help="self-collision bodies: the URDF's <collision> elements and the robot "
                        "file's primitives (mesh, default), the primitives only, or skip the check")
    p.add_argument("--require-acceleration-limits", action="store_true",
                   help="refuse a joint without an acceleration limit instead of deriving one "
                        "from its effort limit and inertia at the home pose")
    p.add_argument("--package-dir", action="append", default=[], metavar="DIR",
                   help="where package:// collision meshes and a xacro's $(find pkg) are found "
                        "(repeatable; ROS_PACKAGE_PATH and the ament index are searched too)")
    add_description_options(p, package_dir=False)


def _add_design(p: argparse.ArgumentParser) -> None:
    _add_robot_options(p)
    p.add_argument(
        "--out", required=True, metavar="FILE", help="the trajectory file to write (YAML)"
    )
    p.add_argument("--payload-mass", type=float, required=True, metavar="KG",
                   help="the payload the user will mount for the loaded run, kg")
    p.add_argument("--payload-frame", default="", metavar="FRAME",
                   help="where it is fixed (default: the robot file's payload_frame)")
    p.add_argument("--payload-com", metavar="X,Y,Z", help="its centre of mass in that frame, m")
    p.add_argument("--payload-inertia", metavar="IXX,IXY,IXZ,IYY,IYZ,IZZ",
                   help="its inertia about the centre of mass, kg·m²")
    p.add_argument("--samples", metavar="FILE.csv",
                   help="also write both runs sampled at 1 kHz (run,t,<joint>.q,.qd,.qdd)")
    p.add_argument("--seed", type=int, default=0, help="the search's seed (default 0)")
    p.add_argument("--period", type=float, default=5.0, metavar="S", help="s (default 5)")
    p.add_argument("--periods", type=int, default=12, help="periods per run (default 12)")
    p.add_argument("--harmonics", type=int, default=5, help="per joint (default 5)")
    p.add_argument("--restarts", type=int, default=20, help="random shapes first (default 20)")
    p.add_argument("--steps", type=int, default=None,
                   help="random-walk steps after (default 400; 0 with --search gradient)")
    p.add_argument("--time-limit", type=float, metavar="S",
                   help="stop searching after S s and keep the best design so far")
    p.add_argument("--search", choices=("walk", "gradient"), default="gradient",
                   help="gradient: the best random shape polished by SLSQP with analytic "
                        "gradients; walk: random shapes then a random walk (default gradient)")
    p.add_argument("--pose", metavar="J=V,...",
                   help="start and end pose (joint=value, m or rad); default the robot file's "
                        "excitation.home, else the middle of each joint's range")
    noise = p.add_mutually_exclusive_group()
    noise.add_argument("--current-noise", metavar="A[,A...]",
                       help="current noise σ (A, one or per joint) the prediction is for "
                            "(default 0.02 A)")
    noise.add_argument("--noise-from", metavar="RESULT.json",
                       help="take it from a previous identification (identify --json): its "
                            "residual rms per joint divided by its gains")
    p.add_argument("--target-sigma", type=float, default=0.2, metavar="PCT",
                   help="the gains' σ (%%) to say the duration and payload for (default 0.2)")


def _add_check(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "trajectory", metavar="TRAJ.yaml", help="a trajectory file (excite design --out)"
    )
    _add_robot_options(p)


def _load(args: argparse.Namespace, robot: RobotModel, traj=None):
    """The robot's limits and collision model (the robot itself is resolved by the CLI's edge):
    a trajectory's own recorded limits (``limits.joints``, what it was designed for) unless
    ``--joint-limits`` gives others."""
    from orthoglide_ident.excite.collision import CollisionModel
    from orthoglide_ident.excite.limits import DERIVED_SOURCE, JointLimits, read_limits, start_pose

    recorded = (traj.extra.get("limits") or {}) if traj is not None else {}
    if recorded.get("joints") and not args.joint_limits:
        limits = JointLimits.from_dict(recorded, tuple(robot.joint_names), args.trajectory)
        _log.info("limits: those recorded in %s (--joint-limits FILE to check against others)",
                  args.trajectory)
        return limits, CollisionModel(robot, args.collision, args.package_dir)
    limits = read_limits(robot, args.joint_limits, not args.require_acceleration_limits)
    if limits.sources.get("acceleration") == DERIVED_SOURCE:
        _log.info("acceleration limits %s (%s): %s (--require-acceleration-limits refuses "
                  "instead)", DERIVED_SOURCE, "at " + ", ".join(f"{q:.3g}" for q in
                                                              start_pose(robot, limits.lower,
                                                                         limits.upper)),
                  ", ".join(f"{j} {a:.3g}" for j, a in zip(robot.joint_names,
                                                            limits.acceleration)))
    return limits, CollisionModel(robot, args.collision, args.package_dir)


def _noise(args: argparse.Namespace, robot) -> tuple[np.ndarray, str]:
    from orthoglide_ident.excite.prediction import DEFAULT_CURRENT_NOISE, noise_from_result

    n = robot.n_joints
    if args.noise_from:
        try:
            doc = json.loads(Path(args.noise_from).read_text())
        except (OSError, ValueError) as exc:
            raise ConfigError(f"--noise-from {args.noise_from}: cannot read it as JSON "
                              f"({getattr(exc, 'strerror', None) or exc})") from None
        return noise_from_result(doc, robot.joint_names, args.noise_from), \
            f"from {args.noise_from}"
    if args.current_noise:
        vals = _floats(args.current_noise, None, "--current-noise")
        if len(vals) not in (1, n) or min(vals) <= 0:
            raise ConfigError(f"--current-noise: one positive value or {n} (one per joint)")
        return np.broadcast_to(np.array(vals), (n,)).copy(), "stated (--current-noise)"
    return np.full(n, DEFAULT_CURRENT_NOISE), f"default {DEFAULT_CURRENT_NOISE} A (--current-noise)"


def _payload(args: argparse.Namespace):
    from orthoglide_ident.model.robot import Payload

    if not (math.isfinite(args.payload_mass) and args.payload_mass > 0):
        raise ConfigError(f"--payload-mass must be a positive mass in kg, not {args.payload_mass}")
    com = _floats(args.payload_com, 3, "--payload-com") if args.payload_com else (0.0,) * 3
    inertia = _floats(args.payload_inertia, 6, "--payload-inertia") if args.payload_inertia \
        else (0.0,) * 6
    return Payload(args.payload_mass, args.payload_frame, tuple(com), tuple(inertia))


def _pose(text: str | None) -> dict[str, float] | None:
    if not text:
        return None
    out = {}
    for item in text.split(","):
        name, sep, value = item.partition("=")
        try:
            out[name.strip()] = float(value)
        except ValueError:
            sep = ""
        if not sep:
            raise ConfigError(f"--pose: expected joint=value,..., not {text!r}")
    return out


def _design(args: argparse.Namespace, robot: RobotModel) -> int:
    from orthoglide_ident.excite.design import DesignOptions, design
    from orthoglide_ident.excite.samples import write_samples
    from orthoglide_ident.excite.summary import prediction_text, with_extras
    from orthoglide_ident.excite.trajectory import save_trajectory

    limits, collision = _load(args, robot)
    noise, source = _noise(args, robot)
    payload = _payload(args)
    robot.with_payload(payload)  # ConfigError now for a frame the robot lacks
    opt = DesignOptions(payload, noise, args.period, args.periods, args.harmonics, args.seed,
                        args.restarts, args.steps, target=args.target_sigma / 100.0,
                        pose=_pose(args.pose), time_limit_s=args.time_limit,
                        search=args.search)
    _log.info("designing for robot %s: %d joints, %d base parameters, %s collision pairs",
              robot.name, robot.n_joints, robot.n_b, collision.n_pairs if collision.mode != "skip"
              else "no")
    d = design(robot, limits, collision, opt)
    traj = with_extras(d, limits, collision, source)
    try:
        save_trajectory(traj, args.out)
    except OSError as exc:
        raise ConfigError(f"cannot write {args.out}: {exc.strerror or exc}") from None
    print(f"wrote {args.out}: {len(traj.joints)} joints, {opt.harmonics} harmonics, period "
          f"{opt.period_s:g} s × {opt.periods} = {traj.duration:g} s per run (designed in "
          f"{d.seconds:.1f} s)")
    print(d.check.to_text())
    print(prediction_text(traj.extra["prediction"]))
    if args.samples:
        rows = write_samples(traj, args.samples)
        print(f"wrote {args.samples}: {rows} samples at 1 kHz")
    return 0


def _check(args: argparse.Namespace, robot: RobotModel) -> int:
    from orthoglide_ident.excite.check import check_trajectory, verify_robot
    from orthoglide_ident.excite.constraints import Margins
    from orthoglide_ident.excite.trajectory import load_trajectory

    traj = load_trajectory(args.trajectory)
    verify_robot(traj, robot, args.trajectory)  # its recorded limits are per joint of its robot
    limits, collision = _load(args, robot, traj)
    margins = Margins.from_dict((traj.extra.get("margins") or {}).get("required"), args.trajectory)
    report = check_trajectory(traj, robot, limits, collision, margins, where=args.trajectory)
    print(f"{args.trajectory}: robot {robot.name}, {len(traj.runs)} runs of {traj.duration:g} s, "
          f"checked every 1 ms (collision: {collision.mode})")
    print(report.to_text())
    if not report.ok:
        raise ConfigError(f"{args.trajectory} breaks its limits: " + "; ".join(
            f"{s.kind} {s.value:.4g} < {s.required:.4g} at {s.where}" for s in report.failures()))
    return 0


Action = tuple[str, Callable[[argparse.ArgumentParser], None],
               Callable[[argparse.Namespace, RobotModel], int]]
ACTIONS: dict[str, Action] = {
    "design": ("design exciting trajectories (unloaded and loaded runs) for the robot, within "
               "its limits, and predict the σ they give", _add_design, _design),
    "check": ("re-verify a trajectory file against the robot's limits on a 1 ms grid",
              _add_check, _check),
}


def add_excite_commands(subparsers) -> argparse._SubParsersAction:
    """The ``excite`` subcommand and its actions (ACTIONS); returns its actions' subparsers,
    where the CLI adds ``run`` (excite/run_command.py: the ROS 2 side, kept out of this module)."""
    p = subparsers.add_parser(
        "excite", help="design, check and run exciting trajectories for the robot",
        description="Exciting trajectories (paper Sect. 3.2) for the robot of --robot: design "
                    "them within its limits (joints, torques, self-collision, a closed chain's "
                    "working mode) for the identification's σ, check a trajectory file, and run "
                    "it through the robot's joint_trajectory_controller while recording.")
    sub = p.add_subparsers(dest="excite_command", metavar="ACTION", required=True)
    for name, (text, add, _) in ACTIONS.items():
        add(sub.add_parser(name, help=text, description=text[0].upper() + text[1:] + "."))
    return sub


def run_excite(args: argparse.Namespace, robot: RobotModel) -> int:
    """Run the excite action of ``args`` on ``robot`` (resolved from ``--robot`` by the CLI)."""
    return ACTIONS[args.excite_command][2](args, robot)
