"""The Orthoglide node set: driver (simulated robot, optional), recorder, identification, ctc,
and the Foxglove viewer (optional).

    ros2 launch orthoglide_ident orthoglide.launch.py [use_sim:=true|false] [namespace:=robot2]
        [payload:=none] [trajectory:=exciting] [controller:=pid] [output_dir:=bags] [viewer:=false]
        [respawn:=true]

Each node reads its YAML file from share/orthoglide_ident/config/ (the files of config/ in the
source tree); the launch arguments override a few values. Every topic and service name is
relative, so namespace:=robot2 moves the whole graph to /robot2/orthoglide/... . With
use_sim:=false the driver is not started: the robot controller publishes orthoglide/joint_states,
orthoglide/current_reference and orthoglide/setpoints, and takes orthoglide/feedforward.
A recorder, identification or ctc node that exits (a node that cannot go on exits with code 1,
see orthoglide_ident/ros/spin.py) is started again after RESPAWN_DELAY_S unless respawn:=false;
a restarted recorder reindexes the bag it left open.

``NODES`` is plain data, so this file also loads where launch_ros is not installed (the tests read
it); ``generate_launch_description`` imports launch and launch_ros when ros2 launch calls it.
"""
from __future__ import annotations

PACKAGE = "orthoglide_ident"

# executable, node name, YAML file in share/orthoglide_ident/config, launch arguments passed as
# parameters, the launch argument that decides whether it runs (None: always), and whether it is
# started again when it exits (the simulated robot is not: it stands in for a robot controller,
# which has its own supervision; the viewer is a view, started again by hand)
NODES = (
    {
        "executable": "driver",
        "name": "orthoglide_driver",
        "config": "driver.yaml",
        "arguments": ("payload", "trajectory", "controller"),
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
        "arguments": ("bag_dir",),
        "when": None,
        "respawn": True,
    },
    {
        "executable": "ctc",
        "name": "orthoglide_ctc",
        "config": "ctc.yaml",
        "arguments": (),
        "when": None,
        "respawn": True,
    },
    {
        "executable": "viewer",
        "name": "orthoglide_viewer",
        "config": "viewer.yaml",
        "arguments": (),
        "when": "viewer",
        "respawn": False,
    },
)
RESPAWN_DELAY_S = 2.0

ARGUMENTS = {
    "use_sim": ("true", "start the simulated robot and its controller (orthoglide_sim driver)"),
    "namespace": ("", "namespace of the whole graph (empty: /orthoglide/... at the root)"),
    "payload": ("none", "driver: payload on the platform (none, 1.983, 1.136 or kg)"),
    "trajectory": ("exciting", "driver: reference (exciting, exciting2, test1, test2)"),
    "controller": ("pid", "driver: pid, pid_ff, ctc or external"),
    "output_dir": ("bags", "recorder: folder for the bags"),
    "bag_dir": ("bags", "identification: where bags are found when a request names none"),
    "viewer": ("false", "serve the topics to Foxglove (ws://127.0.0.1:8765, config/viewer.yaml)"),
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
    nodes = [
        Node(
            package=PACKAGE,
            executable=n["executable"],
            name=n["name"],
            output="screen",
            parameters=[
                PathJoinSubstitution([config, n["config"]]),
                {a: LaunchConfiguration(a) for a in n["arguments"]},
            ],
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
