"""``orthoglide-ident excite run``: run one exciting-trajectory run on the robot and record it.

    orthoglide-ident excite run traj.yaml --condition unloaded
    orthoglide-ident excite run traj.yaml --condition loaded [--payload-mass KG] [--controller NAME]

Steps (progress on stderr): check the run against the robot (excite.run.check_run); read where
the robot is (``joint_states``); move to the run's start pose slowly (its own goal); start the
recorder with the run's tag; send the run to ``<controller>/follow_joint_trajectory``, showing
the feedback and the live identification (its estimate and "enough data" status); stop the
recorder when the goal succeeds. On Ctrl-C, an aborted goal or a tolerance violation, the goal
is cancelled and the recording stopped with the reason: the bag is kept, tagged
``orthoglide.incomplete`` (docs/bags.md), and the command exits 1.
"""
from __future__ import annotations

import argparse
import sys
import time
from typing import Any

import numpy as np

from orthoglide_ident import ros_client
from orthoglide_ident.errors import ConfigError
from orthoglide_ident.excite import run as plan

PROGRESS_PERIOD_S = 2.0  # a progress line this often
JOINT_STATES_TIMEOUT_S = 10.0
EXIT_INCOMPLETE = 1


def add_run_command(excite_sub: Any) -> None:
    """``run`` under ``orthoglide-ident excite``."""
    p = excite_sub.add_parser(
        "run", help="run a trajectory file's run through the joint_trajectory_controller and record it (ROS 2)",
        description=__doc__.split("\n\n", 1)[1], formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("trajectory", metavar="TRAJ.yaml", help="the exciting-trajectory file (excite design)")
    p.add_argument("--condition", required=True, choices=("unloaded", "loaded"), help="which run")
    p.add_argument("--payload-mass", type=float, default=None, metavar="KG",
                   help="loaded: the weighed payload (default: the file's loaded payload mass)")
    p.add_argument("--robot", default=None, metavar="FILE",
                   help="the robot (URDF or robot YAML; default: the file's robot)")
    p.add_argument("--controller", default="joint_trajectory_controller", metavar="NAME",
                   help="the joint_trajectory_controller: its action is NAME/follow_joint_trajectory")
    p.add_argument("--joint-states", default="joint_states", metavar="TOPIC",
                   help="where the robot's position is read before the move to the start pose")
    p.add_argument("--rate", type=float, default=plan.SAMPLE_RATE_HZ, metavar="HZ",
                   help=f"points per second sent (default {plan.SAMPLE_RATE_HZ:g})")
    p.add_argument("--path-tolerance", type=float, default=0.0, metavar="RAD",
                   help="abort when a joint leaves the path by more (rad or m; default 0: the controller's)")
    p.add_argument("--goal-time", type=float, default=1.0, metavar="S",
                   help="time after the end allowed to settle (default 1 s)")
    p.add_argument("--name", default="", help="bag folder name (default <condition>_<date>_<time>)")
    p.add_argument("--no-record", action="store_true", help="run without recording (a dry run on the robot)")
    ros_client.add_namespace(p)
    p.set_defaults(excite_handler=run_command)


def _say(text: str) -> None:
    print(f"excite run: {text}", file=sys.stderr, flush=True)


def _current_position(c: Any, topic: str, joints: tuple[str, ...]) -> np.ndarray:
    from sensor_msgs.msg import JointState

    got: list = []
    sub = c.node.create_subscription(JointState, topic, got.append, 10)
    t_end = time.monotonic() + JOINT_STATES_TIMEOUT_S
    while not got and time.monotonic() < t_end:
        c.rclpy.spin_once(c.node, timeout_sec=0.1)
    c.node.destroy_subscription(sub)
    if not got:
        raise ConfigError(f"no message on {topic} within {JOINT_STATES_TIMEOUT_S:g} s: is the robot running?")
    msg = got[-1]
    missing = [j for j in joints if j not in msg.name]
    if missing:
        raise ConfigError(f"the trajectory's joints {missing} are not on {topic} (it has "
                          f"{', '.join(msg.name)}): a trajectory for another robot?")
    return np.array([msg.position[list(msg.name).index(j)] for j in joints])


class _Progress:
    """Feedback and live-identification lines on stderr, at most every PROGRESS_PERIOD_S."""

    def __init__(self, what: str, duration: float, joints: tuple[str, ...]) -> None:
        self.what, self.duration, self.joints = what, duration, joints
        self.next_line, self.live = 0.0, ""

    def feedback(self, fb: Any) -> None:
        if time.monotonic() < self.next_line:
            return
        self.next_line = time.monotonic() + PROGRESS_PERIOD_S
        t = fb.desired.time_from_start.sec + 1e-9 * fb.desired.time_from_start.nanosec
        _say(f"{self.what} {plan.progress_line(t, self.duration, np.array(fb.error.positions), self.joints)}"
             + (f"\n  {self.live}" if self.live else ""))

    def on_live(self, m: Any) -> None:
        self.live = ros_client.live_line(m)


def run_command(args: argparse.Namespace) -> int:
    from orthoglide_ident.excite.trajectory import load_trajectory
    from orthoglide_ident.model.robots import load_robot

    traj = load_trajectory(args.trajectory)
    robot = load_robot(args.robot or traj.robot)
    plan.check_run(traj, args.condition, robot, args.trajectory)
    tag = plan.payload_tag(traj, args.condition, args.payload_mass, args.trajectory)
    points = plan.excitation_points(traj, args.condition, args.rate)
    with ros_client.Client(args.namespace) as c:
        return _run(c, args, traj, robot, tag, points)


def _run(c: Any, args: argparse.Namespace, traj: Any, robot: Any, tag: plan.PayloadTag,
         points: plan.Points) -> int:
    from orthoglide_msgs.msg import LiveIdentification

    from orthoglide_ident.excite.action_client import goal_message, send_goal

    action = f"{args.controller}/follow_joint_trajectory"
    q_now = _current_position(c, args.joint_states, tuple(traj.joints))
    approach = plan.approach_points(q_now, points.q[0], plan.approach_speed(robot), points.joint_names, args.rate)
    _say(f"moving to the start pose of the {args.condition} run ({approach.duration:.1f} s)")
    out = send_goal(c.node, action, goal_message(approach, goal_time=args.goal_time), approach.duration,
                    _Progress("approach", approach.duration, points.joint_names).feedback)
    if not out.ok:
        raise ConfigError(f"the move to the start pose did not complete ({out.status}: {out.reason}); "
                          "nothing was recorded")
    progress = _Progress(args.condition, points.duration, points.joint_names)
    c.node.create_subscription(LiveIdentification, "orthoglide/identification/live", progress.on_live, 10)
    if not args.no_record:
        _say(_start_recording(c, args, tag))
    _say(f"running {args.condition}: {points.duration:.1f} s, {len(points.times)} points to {action}")
    out = send_goal(c.node, action, goal_message(points, args.path_tolerance, goal_time=args.goal_time),
                    points.duration, progress.feedback)
    if progress.live:
        _say(progress.live)
    if out.ok:
        _say(f"{args.condition} run complete")
        if not args.no_record:
            print(_stop_recording(c, ""))
        return 0
    _say(f"{args.condition} run {out.status}: {out.reason}")
    if not args.no_record:
        print(_stop_recording(c, f"{args.condition} run {out.status}: {out.reason}"))
    return EXIT_INCOMPLETE


def _start_recording(c: Any, args: argparse.Namespace, tag: plan.PayloadTag) -> str:
    from orthoglide_msgs.srv import StartRecording

    shape = argparse.Namespace(payload_frame=tag.frame, recorder=getattr(args, "recorder", "orthoglide_recorder"),
                               payload_com=",".join(map(repr, tag.com)) if tag.com else None,
                               payload_inertia=",".join(map(repr, tag.inertia)) if tag.inertia else None)
    if tag.condition == "loaded":
        ros_client.set_payload_shape(c, shape)
    res = c.call(StartRecording, "orthoglide/recorder/start", condition=tag.condition,
                 payload_mass=float(tag.mass), name=args.name)
    if not res.success:
        raise ros_client.ServiceError(f"the recorder did not start: {res.message}")
    return res.message


def _stop_recording(c: Any, incomplete: str) -> str:
    """Stop the recorder; tagged incomplete with the reason when one is given."""
    from std_srvs.srv import Trigger

    from orthoglide_msgs.srv import StopRecording

    res = (c.call(StopRecording, "orthoglide/recorder/stop_incomplete", incomplete_reason=incomplete)
           if incomplete else c.call(Trigger, "orthoglide/recorder/stop"))
    if not res.success:
        raise ros_client.ServiceError(f"the recorder's stop failed: {res.message}")
    return res.message
