"""One excitation run on the robot, over ROS 2: the steps ``excite run`` and the excitation node
share (the plan and its checks are ``excite.plan``; the goals ``excite.action_client``).

    runner = ExcitationRunner(node, spin, say, RunOptions(controller="joint_trajectory_controller"))
    traj = load_trajectory("traj.yaml"); robot = load_robot(args.robot or traj.robot)  # at the edge
    result = runner.run(traj, "traj.yaml", robot, "loaded", payload_mass=None)     # RunResult

``spin(timeout)`` lets the node's callbacks run while a step waits: ``rclpy.spin_once`` from a
terminal, a sleep in a node whose executor serves them from other threads. ``say`` takes the
progress lines. Steps: check the run against the robot; read where the robot is; move to the
start pose (a goal of its own, slow); start the recorder with the run's tag; send the run and
follow its feedback and the live identification; stop the recorder — with the reason when the
goal did not succeed (Ctrl-C, a cancel request, an abort, a tolerance violation): the bag is kept
and tagged ``orthoglide.incomplete``.
"""
from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from orthoglide_ident.errors import ConfigError, OrthoglideError
from orthoglide_ident.excite import plan
from orthoglide_ident.excite.action_client import goal_message, send_goal, wait_for
from orthoglide_ident.excite.trajectory import ExcitationTrajectory
from orthoglide_ident.model.robot import RobotModel

PROGRESS_PERIOD_S = 2.0  # a progress line this often
JOINT_STATES_TIMEOUT_S = 30.0  # a node just started may take seconds to discover the robot
SERVICE_TIMEOUT_S = 30.0


class RunError(OrthoglideError):
    """A step of the run could not be done (no robot state, no recorder, a failed approach)."""


@dataclass(frozen=True)
class RunOptions:
    """How the run talks to the robot: the JTC's name, the joint states' topic, points per
    second, path tolerance (rad or m; 0: the controller's), time to settle at the end (s), the
    recorder node's name (for the payload's shape), whether to record."""

    controller: str = "joint_trajectory_controller"
    joint_states: str = "joint_states"
    rate_hz: float = plan.SAMPLE_RATE_HZ
    path_tolerance: float = 0.0
    goal_time: float = 1.0
    recorder: str = "orthoglide_recorder"
    record: bool = True

    @property
    def action(self) -> str:
        return f"{self.controller}/follow_joint_trajectory"


@dataclass(frozen=True)
class RunResult:
    success: bool
    message: str
    bag_path: str = ""


class ExcitationRunner:
    """The steps of one run on ``node`` (see the module docstring)."""

    def __init__(self, node: Any, spin: Callable[[float], None], say: Callable[[str], None],
                 options: RunOptions, should_cancel: Callable[[], bool] | None = None) -> None:
        self.node, self.spin, self.say, self.o = node, spin, say, options
        self.should_cancel = should_cancel
        self._clients: dict[str, Any] = {}  # service clients, kept (a node runs many runs)
        self._live_sub: Any = None
        self._live_to: _Progress | None = None
        self._states_sub: Any = None  # joint states, kept as _live_sub is
        self._states: list = []

    def run(self, traj: ExcitationTrajectory, trajectory: str, robot: RobotModel, condition: str,
            payload_mass: float | None = None, name: str = "") -> RunResult:
        """Check, approach, record, run, stop ``traj`` (read from the file ``trajectory``, named
        in messages) on ``robot`` (resolved at the edge: the command, the node's parameter).
        ConfigError/RunError before the recording starts."""
        plan.check_run(traj, condition, robot, trajectory)
        tag = plan.payload_tag(traj, condition, payload_mass, trajectory)
        points = plan.excitation_points(traj, condition, self.o.rate_hz)
        self._approach(points, robot, condition)
        progress = _Progress(self.say, condition, points.duration, points.joint_names)
        self._follow_live(progress)
        bag = self._start_recording(tag, name) if self.o.record else ""
        try:
            self.say(
                f"running {condition}: {points.duration:.1f} s, {len(points.times)} points to "
                f"{self.o.action}"
            )
            out = send_goal(
                self.node,
                self.o.action,
                goal_message(points, self.o.path_tolerance, goal_time=self.o.goal_time),
                points.duration,
                progress.feedback,
                self.spin,
                should_cancel=self.should_cancel,
            )
        except BaseException as exc:  # the recording must not go on without its run
            if self.o.record:
                self._stop_recording(
                    f"{condition} run failed: {type(exc).__name__}: {exc}".strip(": ")
                )
            raise
        finally:
            self._follow_live(None)
        if progress.live:
            self.say(progress.live)
        reason = "" if out.ok else f"{condition} run {out.status}: {out.reason}"
        self.say(f"{condition} run complete" if out.ok else reason)
        stopped = self._stop_recording(reason) if self.o.record else "not recorded (record off)"
        return RunResult(out.ok, stopped if out.ok else f"{reason}; {stopped}", bag)

    # ---- steps ------------------------------------------------------------------------------
    def _approach(self, points: plan.Points, robot: Any, condition: str) -> None:
        q_now = self.current_position(points.joint_names)
        approach = plan.approach_points(
            q_now, points.q[0], plan.approach_speed(robot), points.joint_names, self.o.rate_hz
        )
        self.say(f"moving to the start pose of the {condition} run ({approach.duration:.1f} s)")
        out = send_goal(
            self.node,
            self.o.action,
            goal_message(approach, goal_time=self.o.goal_time),
            approach.duration,
            _Progress(self.say, "approach", approach.duration, points.joint_names).feedback,
            self.spin,
            should_cancel=self.should_cancel,
        )
        if not out.ok:
            raise RunError(
                f"the move to the start pose did not complete ({out.status}: {out.reason}); "
                "nothing was recorded"
            )

    def current_position(self, joints: tuple[str, ...]) -> np.ndarray:
        from sensor_msgs.msg import JointState

        # one subscription, kept: destroying one while another thread's executor waits on the
        # node kills that executor (InvalidHandle), and with it every callback of the node
        if self._states_sub is None:
            self._states_sub = self.node.create_subscription(
                JointState, self.o.joint_states, self._on_states, 10)
        self._states.clear()  # a fresh message only
        t_end = time.monotonic() + JOINT_STATES_TIMEOUT_S
        while not self._states and time.monotonic() < t_end:
            self.spin(0.05)
        got = list(self._states)
        topic = self.o.joint_states
        if not got:
            raise RunError(
                f"no message on {topic} within {JOINT_STATES_TIMEOUT_S:g} s: is the robot running?"
            )
        names = list(got[-1].name)
        missing = [j for j in joints if j not in names]
        if missing:
            raise ConfigError(
                f"the trajectory's joints {missing} are not on {topic} (it has "
                f"{', '.join(names)}): "
                ""
                ""
                ""
                ""
                "a trajectory for another robot?"
            )
        return np.array([got[-1].position[names.index(j)] for j in joints])

    def _on_states(self, msg: Any) -> None:
        self._states[:] = [msg]  # the newest only

    def _follow_live(self, progress: _Progress | None) -> None:
        """The live identification's lines go to ``progress`` (None: nowhere); one subscription,
        kept (destroying one under a node's waiting executor races)."""
        from orthoglide_msgs.msg import LiveIdentification

        self._live_to = progress
        if self._live_sub is None:
            self._live_sub = self.node.create_subscription(
                LiveIdentification, "orthoglide/identification/live",
                lambda m: self._live_to is not None and self._live_to.on_live(m), 10)

    def call(self, srv_type: Any, service: str, **fields: Any) -> Any:
        """Call ``service``; RunError when it is not there or does not answer."""
        client = self._clients.get(service) or self._clients.setdefault(
            service, self.node.create_client(srv_type, service))
        t_end = time.monotonic() + SERVICE_TIMEOUT_S
        while not client.service_is_ready() and time.monotonic() < t_end:
            self.spin(0.05)
        if not client.service_is_ready():
            raise RunError(f"no service {client.srv_name}: is the recorder running?")
        res = wait_for(client.call_async(srv_type.Request(**fields)), self.spin, SERVICE_TIMEOUT_S)
        if res is None:
            raise RunError(f"{client.srv_name} did not answer within {SERVICE_TIMEOUT_S:g} s")
        return res

    def _start_recording(self, tag: plan.PayloadTag, name: str) -> str:
        from orthoglide_msgs.srv import StartRecording

        if tag.condition == "loaded":
            self._set_payload_shape(tag)
        res = self.call(StartRecording, "orthoglide/recorder/start", condition=tag.condition,
                        payload_mass=float(tag.mass), name=name)
        if not res.success:
            raise RunError(f"the recorder did not start: {res.message}")
        self.say(res.message)
        return res.bag_path

    def _set_payload_shape(self, tag: plan.PayloadTag) -> None:
        """The recorder's payload_frame/com/inertia parameters: the tag's, or none (a mass only)."""
        from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
        from rcl_interfaces.srv import SetParameters

        S, A = ParameterType.PARAMETER_STRING, ParameterType.PARAMETER_DOUBLE_ARRAY
        params = [
            Parameter(
                name="payload_frame", value=ParameterValue(type=S, string_value=tag.frame or "")
            )
        ]
        for key, values, n in (("payload_com", tag.com, 3), ("payload_inertia", tag.inertia, 6)):
            params.append(Parameter(name=key, value=ParameterValue(
                type=A, double_array_value=list(values) if values else [0.0] * n)))
        res = self.call(SetParameters, f"{self.o.recorder}/set_parameters", parameters=params)
        refused = [f"{p.name}: {r.reason}" for p, r in zip(params, res.results) if not r.successful]
        if refused:
            raise RunError(f"the recorder refused the payload's {'; '.join(refused)}")

    def _stop_recording(self, incomplete: str) -> str:
        from std_srvs.srv import Trigger

        from orthoglide_msgs.srv import StopRecording

        res = (
            self.call(
                StopRecording, "orthoglide/recorder/stop_incomplete", incomplete_reason=incomplete
            )
            if incomplete
            else self.call(Trigger, "orthoglide/recorder/stop")
        )
        if not res.success:
            raise RunError(f"the recorder's stop failed: {res.message}")
        return res.message


class _Progress:
    """Feedback and live-identification lines, at most every PROGRESS_PERIOD_S."""

    def __init__(
        self, say: Callable[[str], None], what: str, duration: float, joints: tuple[str, ...]
    ) -> None:
        self.say, self.what, self.duration, self.joints = say, what, duration, joints
        self.next_line, self.live = 0.0, ""

    def feedback(self, fb: Any) -> None:
        if time.monotonic() < self.next_line:
            return
        self.next_line = time.monotonic() + PROGRESS_PERIOD_S
        t = fb.desired.time_from_start.sec + 1e-9 * fb.desired.time_from_start.nanosec
        line = plan.progress_line(t, self.duration, np.array(fb.error.positions), self.joints)
        self.say(f"{self.what} {line}" + (f"\n  {self.live}" if self.live else ""))

    def on_live(self, m: Any) -> None:
        from orthoglide_ident.ros_client import live_line

        self.live = live_line(m)
