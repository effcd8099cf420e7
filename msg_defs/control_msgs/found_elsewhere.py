"""Exit 0 when this Python already has a working control_msgs that is not the one built from
msg_defs/control_msgs (e.g. a ROS 2 install's, built for this interpreter): `make setup` then
uses it and builds nothing. Exit 1 otherwise (none, a broken one, or ours: build it)."""

from __future__ import annotations

import importlib.metadata
import sys

OURS = "control-msgs-interfaces"  # the distribution name in pyproject.toml

try:
    from rclpy.serialization import serialize_message

    import control_msgs
    from control_msgs.action import FollowJointTrajectory
    from control_msgs.msg import DynamicJointState, InterfaceValue, JointTrajectoryControllerState

    # an older control_msgs without the action, or one without its type support, is not enough
    for msg_type in (
        DynamicJointState,
        InterfaceValue,
        JointTrajectoryControllerState,
        FollowJointTrajectory.Goal,
        FollowJointTrajectory.Result,
        FollowJointTrajectory.Feedback,
        FollowJointTrajectory.Impl.SendGoalService.Request,
    ):
        serialize_message(msg_type())  # loads the type support: the libraries are found
except Exception:  # not installed, or installed for another interpreter: build ours
    sys.exit(1)
try:
    importlib.metadata.distribution(OURS)
except importlib.metadata.PackageNotFoundError:
    print(f"setup: using the installed control_msgs ({control_msgs.__path__[0]})")
    sys.exit(0)
sys.exit(1)
