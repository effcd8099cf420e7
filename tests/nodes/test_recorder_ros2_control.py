"""The recorder on a ros2_control robot's topics (config/ros2_control.yaml): joint_states and
dynamic_joint_states recorded with the QoS the broadcaster offers, ticks counted on joint_states,
the ticks a topic dropped counted as missing."""
from __future__ import annotations

import time

import numpy as np
from rclpy.qos import QoSProfile, ReliabilityPolicy

TICKS, DROPPED_JS, DROPPED_DJS = 600, (100, 101, 350), (200,)


# reliable, the whole run kept unacknowledged: a recorder slow to take its first batch (opening
# its bag) under load must not lose a test's ticks to the publisher's short history
WHOLE_RUN = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)


def test_records_the_broadcasters_topics(tmp_path):
    from sensor_msgs.msg import JointState
    from std_srvs.srv import Trigger

    from control_msgs.msg import DynamicJointState
    from orthoglide_ident import bags
    from orthoglide_ident._install_ament import ROOT
    from orthoglide_msgs.srv import StartRecording
    from orthoglide_sim.arm_or_chain.session import ArmTick
    from orthoglide_sim.common.broadcaster import BroadcasterLayout
    from orthoglide_sim.demos.graph import Graph

    arm = (
        "shoulder_pan_joint",
        "shoulder_lift_joint",
        "elbow_joint",
        "wrist_1_joint",
        "wrist_2_joint",
        "wrist_3_joint",
    )
    layout = BroadcasterLayout.of(arm, ["gripper_finger_joint"], "shuffled", seed=0)
    t0 = 1_796_000_000 * 10**9
    with Graph(tmp_path / "logs") as g:
        js = g.node.create_publisher(JointState, "joint_states", WHOLE_RUN)
        djs = g.node.create_publisher(DynamicJointState, "dynamic_joint_states", WHOLE_RUN)
        g.start("orthoglide_recorder", "recorder", {"output_dir": str(tmp_path / "bags")},
                params_file=ROOT / "config" / "ros2_control.yaml")
        g.wait_for_match(js)  # the recorder's subscriptions, matched with these publishers
        g.wait_for_match(djs)
        res = g.call(
            StartRecording,
            "orthoglide/recorder/start",
            condition="unloaded",
            payload_mass=0.0,
            name="r",
        )
        assert res.success, res.message
        g.wait_for_status(lambda s: s.recording and s.bag_path == res.bag_path)
        for k in range(TICKS):
            x = np.full(6, 0.001 * k)
            a, b = layout.encode(t0 + k * 1_000_000, ArmTick(k, x, x, x))
            if k not in DROPPED_JS:
                js.publish(a)
            if k not in DROPPED_DJS:
                djs.publish(b)
            time.sleep(0.001)  # about 1 kHz, as the broadcaster publishes
        last = (
            (TICKS - 1) if TICKS - 1 not in DROPPED_JS else max(set(range(TICKS)) - set(DROPPED_JS))
        )
        g.wait_for_status(
            lambda s: s.last_tick.sec * 10**9 + s.last_tick.nanosec == t0 + last * 1_000_000
        )
        stop = g.call(Trigger, "orthoglide/recorder/stop")
    assert stop.success, stop.message
    # ticks written and missing are the joint_states' (the first JointState topic of `topics`)
    assert f"{TICKS - len(DROPPED_JS)} /joint_states" in stop.message, stop.message
    assert f"{len(DROPPED_JS)} missing on /joint_states" in stop.message
    assert f"{len(DROPPED_DJS)} missing on /dynamic_joint_states" in stop.message
    data = bags.read_bag(res.bag_path)
    assert data.sources.current.topic == "/dynamic_joint_states"
    got = (np.asarray(data.positions.stamps_ns) - t0) // 1_000_000
    assert sorted(set(range(TICKS)) - set(got.tolist())) == list(DROPPED_JS)
    assert "gripper_finger_joint" in data.positions.names
    info = {t.topic: t for t in bags.bag_info(res.bag_path).topics}
    assert info["/dynamic_joint_states"].msgtype == "control_msgs/msg/DynamicJointState"
