"""A ros2_control stand-in: a simulated serial arm publishing what joint_state_broadcaster
publishes.

    ros2 run orthoglide_ident driver --ros-args -p robot:=ur5      (robot empty: the Orthoglide's
    driver)
"""
from __future__ import annotations

import gc
import sys
import threading
import time

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy, qos_profile_system_default
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from std_srvs.srv import Trigger

from control_msgs.msg import DynamicJointState
from orthoglide_ident.ros.params import Param, declare, on_set, usage
from orthoglide_ident.ros.spin import spin
from orthoglide_sim.arm_or_chain.session import ArmSession
from orthoglide_sim.common.broadcaster import TOPICS, BroadcasterLayout, TickDropper
from orthoglide_sim.common.joint_trajectory import Tolerances
from orthoglide_sim.common.tick_clock import LATE_NS, TICK_NS, real_time_priority, sleep_until
from orthoglide_sim.nodes.trajectory_action import TrajectoryActionServer

DOC = """\
A ros2_control robot as the product sees it, simulated: a serial arm (robot: a bundled name, a robot
YAML or a URDF) on MuJoCo with its 1 kHz joint PID (orthoglide_sim.arms.simulator), whose every
update is published as joint_state_broadcaster (Jazzy) publishes it, with header.stamp = the
update's time on both:
  joint_states          sensor_msgs/JointState: position (rad), velocity (rad/s), effort = the drive
                        current (A), as map_interface_to_joint_state: {effort: current} maps it
  dynamic_joint_states  control_msgs/DynamicJointState: interfaces position, velocity, current
in the hardware's joint order (joint_order), with extra joints that have no current (extra_joints:
a gripper; effort NaN), and the broadcaster's QoS: rclcpp::SystemDefaultsQoS (on Fast DDS: reliable,
transient local, keep last 1). Like its realtime publisher, which drops a tick while its thread is
still sending the previous one, each topic drops a tick with probability drop_rate (seeded; the
counts are logged and on /diagnostics). robot_description (std_msgs/String, transient local) carries
the arm's URDF, as robot_state_publisher publishes it. Names are relative: -r __ns:=/arm moves them.
The current is the drive's current reference of the update (held over the next tick), reported with
the position read in the same drive cycle. Leaving the stop limits stops the simulated arm (error in
the log); call <node>/reset (std_srvs/Trigger) to put it back on its reference.
The arm's joint_trajectory_controller: <controller>/follow_joint_trajectory
(control_msgs/action/FollowJointTrajectory) runs a goal's points on the arm through its PID, with
feedback, the path and goal tolerances (abort with the reason) and cancel; a goal with other
joints, or while one runs, is rejected (orthoglide_sim.nodes.trajectory_action)."""

PARAMETERS = (
    Param(
        "robot",
        "ur5",
        "the arm: a bundled robot (ur5), a robot YAML or a URDF (serial arms only); "
        "empty or orthoglide: the Orthoglide's driver instead",
    ),
    Param(
        "payload",
        "none",
        "payload on the payload frame: none, 2.0 or 1.0 (the plant's payloads, kg; "
        "params_file adds others); set it while running to mount or remove one",
        dynamic=True,
        any_type=True,
    ),
    Param(
        "trajectory",
        "exciting1",
        "reference: exciting1, exciting2 (the arm's designed exciting "
        "trajectories), a .json Fourier file, or hold (at rest at the box centre until a "
        "follow_joint_trajectory goal moves it); a change blends in over 2 s",
        dynamic=True,
    ),
    Param(
        "controller",
        "joint_trajectory_controller",
        "the joint_trajectory_controller's name: its action "
        "is <controller>/follow_joint_trajectory (control_msgs/action/FollowJointTrajectory)",
    ),
    Param(
        "path_tolerance",
        0.0,
        "rad (m): default position tolerance along a goal's path, per joint; "
        "0: none (a goal's path_tolerance overrides it)",
    ),
    Param("goal_tolerance", 0.0, "rad (m): default position tolerance at a goal's end; 0: none"),
    Param(
        "goal_time",
        0.0,
        "s: a goal aborts when its end is not within tolerance this long after "
        "its last point's time; 0: waits (JTC's constraints.goal_time)",
    ),
    Param("duration", 0.0, "s to run, 0 = until shut down"),
    Param(
        "drop_rate",
        1.0e-4,
        "probability that a topic drops a tick (each topic on its own), as the "
        "broadcaster's realtime publisher does when busy; 0: never",
    ),
    Param(
        "joint_order",
        "shuffled",
        "hardware order: shuffled (by seed), urdf, or the names comma-separated",
    ),
    Param(
        "extra_joints",
        ["gripper_finger_joint"],
        "joints published beside the arm's, at rest, with "
        "position and velocity interfaces only (no current)",
    ),
    Param("seed", 0, "seed of the current noise, the drops and the shuffled order"),
    Param("noise", True, "current noise on/off"),
    Param("params_file", "", "YAML overriding the arm plant's truth (config/arm_plant.yaml)"),
    Param(
        "publish_description", True, "publish the arm's URDF on robot_description (transient local)"
    ),
    Param("rt_priority", 40, "SCHED_FIFO priority of the update loop (1-99), 0: normal scheduling"),
)
STATUS_PERIOD_TICKS = 10_000  # a log line
DIAGNOSTICS_PERIOD_TICKS = 1_000  # a /diagnostics message
LATCHED = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                     reliability=ReliabilityPolicy.RELIABLE)


def _usage() -> str:
    return usage(
        "usage: ros2 run orthoglide_ident driver --ros-args -p robot:=ur5 [-p NAME:=VALUE ...]",
        DOC,
        PARAMETERS,
    )


class Ros2ControlStandIn(Node):
    """Parameters, the broadcaster's topics and the update loop around an ArmSession."""

    def __init__(self) -> None:
        super().__init__("ros2_control_standin")
        v = declare(self, PARAMETERS)
        self.duration, self.rt_priority = v["duration"], v["rt_priority"]
        self.session = ArmSession(v["robot"], v["payload"], v["trajectory"], v["seed"], v["noise"],
                                  v["params_file"] or None)
        self.layout = BroadcasterLayout.of(
            self.session.joint_names, v["extra_joints"], v["joint_order"], v["seed"]
        )
        self.dropper = TickDropper(v["drop_rate"], v["seed"])
        self.lock = threading.Lock()
        self.finished = False
        self.late = 0
        # the broadcaster's QoS: rclcpp::SystemDefaultsQoS() is this rmw profile
        self.pubs = {
            "joint_states": self.create_publisher(
                JointState, "joint_states", qos_profile_system_default
            ),
            "dynamic_joint_states": self.create_publisher(
                DynamicJointState, "dynamic_joint_states", qos_profile_system_default
            ),
        }
        self.pub_diag = self.create_publisher(DiagnosticArray, "/diagnostics", 10)
        if v["publish_description"]:
            self.pub_desc = self.create_publisher(String, "robot_description", LATCHED)
            self.pub_desc.publish(String(data=self.session.truth.arm.urdf_text))
        self.create_service(Trigger, "~/reset", self._on_reset)
        n = len(self.session.joint_names)
        tol = Tolerances(*(np.full(n, float(v[k])) for k in ("path_tolerance", "goal_tolerance")),
                         np.zeros(n), float(v["goal_time"]))
        self.jtc = TrajectoryActionServer(self, self.session, self.lock, v["controller"], tol)
        on_set(self, PARAMETERS, self._apply)
        self.get_logger().info(
            f"{self.session.truth.arm.name}: joints {', '.join(self.layout.names)} (hardware "
            "order), "
            f"payload {v['payload']}, trajectory {v['trajectory']}, drop rate {v['drop_rate']:g}; "
            "publishing "
            f"{self.resolve_topic_name('joint_states')} and "
            f"{self.resolve_topic_name('dynamic_joint_states')}"
        )

    def _apply(self, changes) -> None:
        with self.lock:
            for name, value in changes.items():
                if name == "payload":  # an unknown one is refused with the reason (ConfigError)
                    self.session.set_payload(value)
                elif name == "trajectory":
                    self.session.set_trajectory(value, self.session.k + 1)
                self.get_logger().info(f"{name} set to {value}")

    def _on_reset(self, request, response):
        with self.lock:
            was = self.session.fault
            self.session.reset()
        response.success = True
        response.message = (
            f"arm back on its reference (was stopped: {was})" if was else "no fault to clear"
        )
        self.get_logger().info(response.message)
        return response

    # ---- the update loop (main thread) ----------------------------------------------------------
    def main_loop(self, stop: threading.Event) -> None:
        """One update per 1 ms deadline: step the arm, publish the broadcaster's two messages."""
        n_ticks = round(self.duration * 1000) if self.duration > 0 else None
        if self.rt_priority > 0:
            real_time_priority(self.rt_priority, self.get_logger(), "update loop")
        self.start_ns = time.time_ns() + 5 * TICK_NS
        self.t0 = time.monotonic_ns() + 5 * TICK_NS
        self.get_logger().info(f"update k is stamped {self.start_ns} + k * {TICK_NS} ns")
        gc.collect()
        gc.freeze()  # no collection pause of what exists now in the loop
        k = 0
        while not stop.is_set() and (n_ticks is None or k < n_ticks):
            sleep_until(self.t0 + k * TICK_NS)
            if not self._update(k):
                break
            k += 1
        self.finished = True
        self._log(f"{self.resolve_topic_name('joint_states')}: {self._status(k)}")

    def _update(self, k: int) -> bool:
        with self.lock:
            tick = self.session.tick()
        if tick is None:  # stopped (fault): the broadcaster goes on, the arm does not
            return True
        if time.monotonic_ns() - (self.t0 + k * TICK_NS) > LATE_NS:
            self.late += 1
        raw = self.layout.encode(self.start_ns + k * TICK_NS, tick)
        try:
            for topic, data, keep in zip(TOPICS, raw, self.dropper.keep()):
                if keep:
                    self.pubs[topic].publish(data)
        except Exception:
            if self.context.ok():
                raise
            return False  # Ctrl-C shut the context down between the check and the publish
        if self.session.fault:
            self.get_logger().error(f"stopped: {self.session.fault}; call {self.get_name()}/reset")
        if (k + 1) % STATUS_PERIOD_TICKS == 0:
            self.get_logger().info(self._status(k + 1))
        if (k + 1) % DIAGNOSTICS_PERIOD_TICKS == 0:
            self._publish_diagnostics(k + 1)
        return True

    def _status(self, ticks: int) -> str:
        d = self.dropper.dropped
        return (
            f"{ticks} updates, dropped {d['joint_states']} joint_states and "
            f"{d['dynamic_joint_states']} "
            f"dynamic_joint_states, {self.late} late (> 0.5 ms), {self.session.saturated} "
            "current-limited"
        )

    def _publish_diagnostics(self, ticks: int) -> None:
        d, s = self.dropper.dropped, self.session
        values = {"ticks": ticks, "late": self.late, "current_limited": s.saturated,
                  "dropped_joint_states": d["joint_states"],
                  "dropped_dynamic_joint_states": d["dynamic_joint_states"], "fault": s.fault or ""}
        status = DiagnosticStatus(
            level=DiagnosticStatus.ERROR if s.fault else DiagnosticStatus.OK,
            name=f"{self.get_fully_qualified_name()}: update loop",
            hardware_id="orthoglide_sim",
            message=s.fault or self._status(ticks),
            values=[KeyValue(key=k, value=str(v)) for k, v in values.items()],
        )
        msg = DiagnosticArray(status=[status])
        msg.header.stamp = self.get_clock().now().to_msg()
        try:
            self.pub_diag.publish(msg)
        except Exception:  # noqa: BLE001 - shutting down
            pass

    def _log(self, text: str) -> None:
        try:
            self.get_logger().info(text)
        except Exception:  # noqa: BLE001 - the context is gone at shutdown
            print(text, file=sys.stderr)


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv if argv is None else argv
    if "-h" in argv or "--help" in argv:
        print(_usage())
        return 0
    sys.setswitchinterval(2e-4)  # the update loop gets the GIL back within 0.2 ms of a callback
    return spin(Ros2ControlStandIn, argv, "driver", threads=3)  # a goal's execution waits in one


if __name__ == "__main__":
    sys.exit(main())
