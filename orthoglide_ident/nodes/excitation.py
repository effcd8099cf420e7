"""Excitation node: runs exciting-trajectory runs on the robot through its
joint_trajectory_controller and records them, on a service call (what `orthoglide-ident excite
run` does from a terminal; the steps are orthoglide_ident.excite.runner)."""
from __future__ import annotations

import sys
import threading
import time
from typing import Any

from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.node import Node
from std_srvs.srv import Trigger

from orthoglide_ident.errors import OrthoglideError
from orthoglide_ident.excite import plan
from orthoglide_ident.excite.runner import ExcitationRunner, RunOptions
from orthoglide_ident.excite.trajectory import load_trajectory
from orthoglide_ident.model.registry import load_robot
from orthoglide_ident.ros.params import Param, declare, usage
from orthoglide_ident.ros.spin import spin
from orthoglide_msgs.srv import RunExcitation

DOC = """\
Runs one run (unloaded or loaded) of an exciting-trajectory file (excite design) on the robot:
checks
it against the robot's limits, moves to its start pose slowly, starts the recorder with the run's
tag,
sends it to <controller>/follow_joint_trajectory, follows its feedback and the live identification,
and stops the recorder -- with the reason when the goal did not succeed (the bag is kept, tagged
orthoglide.incomplete).

Services (relative names):
  orthoglide/excitation/run     orthoglide_msgs/srv/RunExcitation  trajectory (file), condition,
                                payload_mass (0: the file's), name -> success, message, bag_path;
                                answers when the run has ended (one run at a time)
  orthoglide/excitation/cancel  std_srvs/srv/Trigger: cancel the running run (its bag is tagged
                                incomplete: "cancel requested")"""

PARAMETERS = (
    Param(
        "robot",
        "",
        "the robot (URDF or robot YAML) the runs are checked against; empty: each file's robot",
    ),
    Param(
        "controller",
        "joint_trajectory_controller",
        "the JTC: its action is <controller>/follow_joint_trajectory",
    ),
    Param(
        "joint_states",
        "joint_states",
        "where the robot's position is read before the move to the start pose",
    ),
    Param("rate", plan.SAMPLE_RATE_HZ, "Hz: points per second sent to the JTC"),
    Param(
        "path_tolerance",
        0.0,
        "rad (m): abort when a joint leaves the path by more; 0: the controller's",
    ),
    Param("goal_time", 1.0, "s: time after the end allowed to settle"),
    Param(
        "recorder",
        "orthoglide_recorder",
        "the recorder node's name (for the payload's frame, CoM, inertia)",
    ),
)


class ExcitationNode(Node):
    """The two services around an ExcitationRunner; a run executes in the service's thread."""

    def __init__(self) -> None:
        super().__init__("orthoglide_excitation")
        self.p = declare(self, PARAMETERS)
        self.busy = threading.Lock()
        self.cancel = threading.Event()
        p = self.p
        options = RunOptions(
            p["controller"],
            p["joint_states"],
            p["rate"],
            p["path_tolerance"],
            p["goal_time"],
            p["recorder"],
        )
        # a step waits by sleeping: this node's executor threads run the callbacks meanwhile
        self.runner = ExcitationRunner(
            self, time.sleep, self.get_logger().info, options, self.cancel.is_set
        )
        group = ReentrantCallbackGroup()  # a run waits in its callback while the others are served
        self.create_service(
            RunExcitation, "orthoglide/excitation/run", self.on_run, callback_group=group
        )
        self.create_service(
            Trigger, "orthoglide/excitation/cancel", self.on_cancel, callback_group=group
        )
        self.get_logger().info(f"ready: {self.resolve_service_name('orthoglide/excitation/run')} "
                               f"(controller {self.p['controller']})")

    def on_run(self, req: Any, res: Any) -> Any:
        if not self.busy.acquire(blocking=False):
            res.success, res.message = False, "a run is already going on: cancel it or wait"
            return res
        try:
            self.cancel.clear()
            traj = load_trajectory(req.trajectory)
            robot = load_robot(self.p["robot"] or traj.robot)
            result = self.runner.run(
                traj, req.trajectory, robot, req.condition, req.payload_mass or None, req.name
            )
            res.success, res.message, res.bag_path = result.success, result.message, result.bag_path
        except OrthoglideError as exc:
            res.success, res.message = False, " ".join(str(exc).split())
        finally:
            self.busy.release()
        if res.success:
            self.get_logger().info(res.message)
        else:  # one severity per call site (rclpy refuses a call site that changes it)
            self.get_logger().error(res.message)
        return res

    def on_cancel(self, req: Any, res: Any) -> Any:
        running = self.busy.locked()
        if running:
            self.cancel.set()
        res.success, res.message = running, "cancelling the run" if running else "no run to cancel"
        return res


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv if argv is None else argv
    if "-h" in argv or "--help" in argv:
        print(
            usage(
                "usage: ros2 run orthoglide_ident excitation [--ros-args -p NAME:=VALUE ...]",
                DOC,
                PARAMETERS,
            )
        )
        return 0
    return spin(ExcitationNode, argv, "excitation", threads=4)


if __name__ == "__main__":
    sys.exit(main())
