"""The ros2_control stand-in as a node: `ros2 run orthoglide_ident driver -p robot:=...` chooses it,
it publishes what joint_state_broadcaster publishes with the broadcaster's QoS, robot_description,
and takes a payload while it runs."""
from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

LAUNCHER = Path(sys.prefix) / "lib" / "orthoglide_ident" / "driver"
NAME = "ros2_control_standin"


def _run(*args: str, env=None) -> subprocess.CompletedProcess:
    return subprocess.run(
        [str(LAUNCHER), *args], capture_output=True, text=True, timeout=120, env=env
    )


def test_robot_parameter_chooses_the_stand_in_or_the_orthoglide(ros_env, tmp_path):
    standin = _run("--ros-args", "-p", "robot:=ur5", "--help", env=ros_env)
    assert standin.returncode == 0 and "joint_state_broadcaster" in standin.stdout
    assert "drop_rate" in standin.stdout and "extra_joints" in standin.stdout
    for args in (("--help",), ("--ros-args", "-p", "robot:=orthoglide", "--help")):
        out = _run(*args, env=ros_env)
        assert out.returncode == 0 and "The simulated Orthoglide" in out.stdout, out.stdout[:300]
    params = tmp_path / "p.yaml"  # a parameter file chooses it too (ros2 launch passes one)
    params.write_text(f"{NAME}:\n  ros__parameters:\n    robot: ur5\n")
    out = _run(
        "--ros-args", "--params-file", str(params), "-r", f"__node:={NAME}", "--help", env=ros_env
    )
    assert "joint_state_broadcaster" in out.stdout


def test_bad_robot_or_parameter_is_a_one_line_reason(ros_env):
    for args, reason in (
        (("-p", "robot:=no_such_robot"), "robot 'no_such_robot': no such file"),
        (("-p", "robot:=ur5", "-p", "payload:=heavy"), "payload 'heavy'"),
        (("-p", "robot:=ur5", "-p", "drop_rate:=1.5"), "drop_rate must be in [0, 1)"),
    ):
        out = _run("--ros-args", *args, env=ros_env)
        assert out.returncode == 2, out.stderr
        assert reason in out.stderr and "Traceback" not in out.stderr, out.stderr


def _stamp(m) -> int:
    return m.header.stamp.sec * 10**9 + m.header.stamp.nanosec


def test_publishes_the_broadcasters_topics_with_its_qos(tmp_path):
    from rclpy.qos import (
        DurabilityPolicy,
        QoSProfile,
        ReliabilityPolicy,
        qos_profile_system_default,
    )
    from sensor_msgs.msg import JointState
    from std_msgs.msg import String

    from control_msgs.msg import DynamicJointState
    from orthoglide_ident.model.registry import ROBOTS_DIR
    from orthoglide_sim.demos.graph import Graph

    got: dict[str, list] = {"js": [], "djs": [], "desc": []}
    stream = QoSProfile(depth=5000, reliability=ReliabilityPolicy.RELIABLE)
    latched = QoSProfile(
        depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL
    )
    with Graph(tmp_path / "logs") as g:
        g.node.create_subscription(JointState, "joint_states", got["js"].append, stream)
        g.node.create_subscription(
            DynamicJointState, "dynamic_joint_states", got["djs"].append, stream
        )
        g.node.create_subscription(String, "robot_description", got["desc"].append, latched)
        _reference = g.node.create_publisher(
            JointState, "qos_reference", qos_profile_system_default
        )
        g.start(NAME, "driver", {"robot": "ur5_mount", "drop_rate": 0.01, "rt_priority": 0})
        g.wait_for_messages(JointState, "joint_states", 200, timeout=60)
        offered = [i.qos_profile for i in g.node.get_publishers_info_by_topic("/joint_states")]
        mine = g.node.get_publishers_info_by_topic("/qos_reference")[0].qos_profile
        with pytest.raises(Exception, match="refused payload"):
            g.set_params(NAME, payload="heavy")
        g.set_params(NAME, payload=2.5)  # mounted while it runs
        time.sleep(0.5)
        g.stop(NAME)
        log = (tmp_path / "logs" / f"{NAME}.log").read_text()
        time.sleep(0.3)
    # rclcpp::SystemDefaultsQoS(), as the broadcaster's: the rmw's defaults (Fast DDS: reliable,
    # transient local, keep last 1); one publisher per topic
    assert (
        len(offered) == 1
        and offered[0].reliability == mine.reliability == ReliabilityPolicy.RELIABLE
    )
    assert offered[0].durability == mine.durability
    assert got["desc"] and got["desc"][0].data == (ROBOTS_DIR / "ur5_mount.urdf").read_text()
    js, djs = got["js"], got["djs"]
    names = tuple(js[0].name)
    assert "gripper_finger_joint" in names[1:-1] and names[:2] != (
        "shoulder_pan_joint",
        "shoulder_lift_joint",
    )
    assert all(tuple(m.name) == names for m in js) and all(
        tuple(m.joint_names) == names for m in djs
    )
    g_slot = names.index("gripper_finger_joint")
    assert all(np.isnan(m.effort[g_slot]) for m in js[:50])
    assert [list(iv.interface_names) for iv in djs[0].interface_values].count(
        ["position", "velocity"]
    ) == 1
    # one update, one stamp: where both came, both carry the same values
    by_stamp = {_stamp(m): m for m in djs}
    both = [m for m in js if _stamp(m) in by_stamp]
    assert len(both) > 100
    for m in both[:100]:
        iv = by_stamp[_stamp(m)].interface_values
        for slot in range(len(names)):
            if slot != g_slot:
                assert list(iv[slot].values) == [m.position[slot], m.velocity[slot], m.effort[slot]]
    steps = np.diff([_stamp(m) for m in js])
    assert set(np.unique(steps % 1_000_000)) == {0}  # a 1 kHz grid, gaps where ticks dropped
    assert "payload set to 2.5" in log and "dropped" in log
    # counted (what was published before this subscription matched is not here: the exact
    # count against the bag is tests/test_ros2_control_graph.py's)
    assert int(log.rsplit("dropped ", 1)[1].split()[0]) > 0
