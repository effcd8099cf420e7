"""The product next to a ros2_control robot: recorder and identification (and ctc, viewer) on the
topics joint_state_broadcaster publishes; the simulated robot (the ros2_control stand-in) optional.

    ros2 launch orthoglide_ident ros2_control.launch.py [use_sim:=true|false] [robot:=ur5_mount]
        [namespace:=] [output_dir:=bags] [ctc:=false] [viewer:=false] [excitation:=false]
        [respawn:=true]

Each node reads its own YAML from share/orthoglide_ident/config/ and then config/ros2_control.yaml
(the broadcaster's topics: joint_states + dynamic_joint_states, relative to the namespace, which is
the controller manager's). robot: the robot file of the identification and ctc (and of the
stand-in with use_sim:=true); robot:="" on a real robot: the URDF robot_state_publisher publishes
on robot_description. With use_sim:=false nothing simulated starts: the controller manager of the
robot publishes the topics.

``NODES`` is plain data, so this file also loads where launch_ros is not installed (the tests read
it); ``generate_launch_description`` imports launch and launch_ros when ros2 launch calls it.
"""
from __future__ import annotations

PACKAGE = "orthoglide_ident"
SHARED = "ros2_control.yaml"  # loaded after each node's own file

# executable, node name, its own YAML file, launch arguments passed as parameters, and the launch
# argument that decides whether it runs (None: always)
NODES = (
    {
        "executable": "driver",
        "name": "ros2_control_standin",
        "config": None,
        "arguments": ("robot",),
        "when": "use_sim",
        "respawn": False,
    },
    {
        "executable": "recorder",
        "name": "orthoglide_recorder",
        "config": "recorder.yaml",
        "arguments": ("output_dir",),
        "when": None,
        "respawn": True,
    },
    {
        "executable": "identification",
        "name": "orthoglide_identification",
        "config": "identification.yaml",
        "arguments": ("robot", "bag_dir"),
        "when": None,
        "respawn": True,
    },
    {
        "executable": "ctc",
        "name": "orthoglide_ctc",
        "config": "ctc.yaml",
        "arguments": ("robot",),
        "when": "ctc",
        "respawn": True,
    },
    {
        "executable": "viewer",
        "name": "orthoglide_viewer",
        "config": "viewer.yaml",
        "arguments": ("robot",),
        "when": "viewer",
        "respawn": False,
    },
    {
        "executable": "excitation",
        "name": "orthoglide_excitation",
        "config": None,
        "arguments": ("robot",),
        "when": "excitation",
        "respawn": False,
    },
)
# as orthoglide.launch.py: a node that exits is started again (not the stand-in)
RESPAWN_DELAY_S = 2.0

ARGUMENTS = {
    "use_sim": ("true", "start the simulated robot (the ros2_control stand-in, orthoglide_sim)"),
    "robot": (
        "ur5_mount",
        'robot file of every node (a bundled name, a robot YAML or a URDF); "": '
        "the identification reads robot_description (keep use_sim:=false then)",
    ),
    "namespace": ("", "the controller manager's namespace (empty: /joint_states at the root)"),
    "output_dir": ("bags", "recorder: folder for the bags"),
    "bag_dir": ("bags", "identification: where bags are found when a request names none"),
    "ctc": (
        "false",
        "start the ctc node: feed-forward to joint_trajectory_controller "
        "(config/ros2_control.yaml)",
    ),
    "viewer": ("false", "serve the topics to Foxglove (ws://127.0.0.1:8765, config/viewer.yaml)"),
    "excitation": (
        "false",
        "start the excitation node: orthoglide/excitation/run runs a trajectory file's run "
        "through <controller>/follow_joint_trajectory and records it (excite run as a service)",
    ),
    "respawn": ("true", "start the recorder, identification and ctc again when one exits"),
}


def generate_launch_description():
    from launch.actions import DeclareLaunchArgument, GroupAction
    from launch.conditions import IfCondition
    from launch.substitutions import LaunchConfiguration, PathJoinSubstitution
    from launch_ros.actions import Node, PushRosNamespace
    from launch_ros.substitutions import FindPackageShare

    from launch import LaunchDescription

    config = PathJoinSubstitution([FindPackageShare(PACKAGE), "config"])

    def files(n: dict) -> list:
        own = [PathJoinSubstitution([config, n["config"]])] if n["config"] else []
        return own + [PathJoinSubstitution([config, SHARED])]

    nodes = [
        Node(
            package=PACKAGE,
            executable=n["executable"],
            name=n["name"],
            output="screen",
            parameters=[*files(n), {a: LaunchConfiguration(a) for a in n["arguments"]}],
            condition=IfCondition(LaunchConfiguration(n["when"])) if n["when"] else None,
            respawn=LaunchConfiguration("respawn") if n["respawn"] else False,
            respawn_delay=RESPAWN_DELAY_S,
        )
        for n in NODES
    ]
    return LaunchDescription(
        [DeclareLaunchArgument(name, default_value=default, description=text)
         for name, (default, text) in ARGUMENTS.items()]
        + [GroupAction([PushRosNamespace(LaunchConfiguration("namespace")), *nodes])])
