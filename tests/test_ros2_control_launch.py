"""launch/ros2_control.launch.py and config/ros2_control.yaml: installed, and every key is a
parameter the node it is for declares (so the file really sets it)."""
from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import yaml

from orthoglide_ident._install_ament import EXECUTABLES, ROOT, data_files


def _launch():
    spec = importlib.util.spec_from_file_location(
        "ros2_control_launch", ROOT / "launch" / "ros2_control.launch.py"
    )
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_launch_file_lists_the_nodes_with_installed_configs():
    launch = _launch()
    installed = dict(data_files())
    assert "launch/ros2_control.launch.py" in installed["share/orthoglide_ident/launch"]
    assert "config/ros2_control.yaml" in installed["share/orthoglide_ident/config"]
    assert (Path(sys.prefix) / "share/orthoglide_ident/launch/ros2_control.launch.py").is_file()
    for n in launch.NODES:
        assert n["executable"] in EXECUTABLES
        assert (
            n["config"] is None
            or f"config/{n['config']}" in installed["share/orthoglide_ident/config"]
        )
        assert set(n["arguments"]) <= set(launch.ARGUMENTS)
        assert n["when"] is None or n["when"] in launch.ARGUMENTS
    assert [n["name"] for n in launch.NODES if n["when"] is None] == ["orthoglide_recorder",
                                                                        "orthoglide_identification"]
    # a product node that exits is started again; the stand-in (a robot's controller), the viewer
    # and the excitation node (a run it was doing is not resumed) not
    assert [n["respawn"] for n in launch.NODES] == [False, True, True, True, False, False]
    assert "respawn" in launch.ARGUMENTS


def test_ros2_control_yaml_sets_declared_parameters_of_each_node():
    from orthoglide_ident.nodes import ctc, identification, recorder, viewer
    from orthoglide_sim.nodes import ros2_control as ros2_control_node

    data = yaml.safe_load((ROOT / "config" / "ros2_control.yaml").read_text())
    declared = {
        "orthoglide_recorder": recorder.PARAMETERS,
        "orthoglide_identification": identification.PARAMETERS,
        "orthoglide_ctc": ctc.PARAMETERS,
        "ros2_control_standin": ros2_control_node.PARAMETERS,
        "orthoglide_viewer": viewer.PARAMETERS,
    }
    launched = {n["name"] for n in _launch().NODES}
    assert set(data) <= set(declared) and set(data) <= launched
    for node, section in data.items():
        keys = set(section["ros__parameters"])
        assert keys <= {p.name for p in declared[node]}, (
            node,
            keys - {p.name for p in declared[node]},
        )
    topics = data["orthoglide_recorder"]["ros__parameters"]["topics"]
    # relative: the controller manager's namespace
    assert topics == ["joint_states", "dynamic_joint_states"]


def test_every_node_of_the_launch_accepts_its_parameter_files():
    """Each node's own YAML, then config/ros2_control.yaml, as ros2 launch passes them, make a
    node that starts: config/ctc.yaml's 3 current limits (the Orthoglide's) once made the ctc
    exit 2 for the 6-joint UR5, respawned forever."""
    from orthoglide_ident.model.registry import load_robot
    from orthoglide_ident.nodes.ctc import check_current_limit

    merged: dict = {}
    for name in ("ctc.yaml", "ros2_control.yaml"):
        data = yaml.safe_load((ROOT / "config" / name).read_text())
        for section in ("/**", "orthoglide_ctc"):
            merged.update((data.get(section) or {}).get("ros__parameters", {}))
    robot = load_robot(merged["robot"])
    check_current_limit(merged["current_limit"], robot)  # raises ConfigError with the reason
