"""A loaded recording of an arm's payload: its frame, centre of mass and inertia in the bag's tag
(the recorder's payload_* parameters, set by ``orthoglide-ident record start --payload-*``) and
on the recorder's status, where the live identification takes them from."""
from __future__ import annotations

import subprocess
import sys
import time

import numpy as np
from rclpy.qos import QoSProfile, ReliabilityPolicy

# reliable, the whole run kept unacknowledged: a recorder slow to take its first batch (opening
# its bag) under load must not lose a test's ticks to the publisher's short history
WHOLE_RUN = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)


def test_the_payload_shape_goes_into_the_tag_and_the_status(tmp_path, ros_env):
    from rclpy.qos import (
        DurabilityPolicy,
        QoSProfile,
        ReliabilityPolicy,
    )
    from sensor_msgs.msg import JointState
    from std_srvs.srv import Trigger

    from orthoglide_ident import bags
    from orthoglide_ident._install_ament import ROOT
    from orthoglide_ident.nodes.live_feed import status_payload
    from orthoglide_msgs.msg import RecorderStatus
    from orthoglide_sim.demos.graph import Graph

    names = ["j1", "j2"]
    t0 = 1_796_000_000 * 10**9
    with Graph(tmp_path / "logs") as g:
        js = g.node.create_publisher(JointState, "joint_states", WHOLE_RUN)
        # config/ros2_control.yaml names /dynamic_joint_states too: this robot publishes only
        # /joint_states (effort = the current), which must be recorded all the same
        g.start("orthoglide_recorder", "recorder", {"output_dir": str(tmp_path / "bags")},
                params_file=ROOT / "config" / "ros2_control.yaml")
        g.wait_for_subscriber("joint_states", "orthoglide_recorder")
        cli = [sys.executable, "-m", "orthoglide_ident.cli", "record", "start", "--condition",
               "loaded", "--payload-mass", "2", "--payload-frame", "tool0",
               "--payload-com", "0.03,-0.02,0.06", "--payload-inertia", "0.004,0,0,0.004,0,0.002",
               "--name", "shaped"]
        bad = subprocess.run(cli[:-6] + ["--payload-com", "1,2"], env=ros_env, capture_output=True,
                             text=True, timeout=120)
        assert bad.returncode == 2 and "--payload-com: expected 3 numbers" in bad.stderr
        ok = subprocess.run(cli, env=ros_env, capture_output=True, text=True, timeout=120)
        assert ok.returncode == 0, ok.stderr
        got: list = []
        latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                             reliability=ReliabilityPolicy.RELIABLE)
        g._listen(RecorderStatus, "orthoglide/recorder/status", latched, got.append,
                  lambda: any(m.recording for m in got), 30, lambda: "no recording status")
        status = next(m for m in got if m.recording)
        g.wait_for_match(js)  # the recorder's subscription, matched with this publisher
        for k in range(300):
            m = JointState(name=names, position=[0.001 * k, 0.0], effort=[0.1, 0.2])
            m.header.stamp.sec, m.header.stamp.nanosec = divmod(t0 + k * 1_000_000, 10**9)
            js.publish(m)
            time.sleep(0.001)
        g.wait_for_status(lambda s: s.ticks_written == 300)
        stop = g.call(Trigger, "orthoglide/recorder/stop")
    assert stop.success, stop.message
    payload = status_payload(status)
    assert payload.frame == "tool0" and payload.com == (0.03, -0.02, 0.06) and payload.mass == 2.0
    data = bags.read_bag(tmp_path / "bags" / "shaped")
    # every tick, though /dynamic_joint_states never came
    assert len(data.positions.stamps_ns) == 300
    tags = data.tags
    assert tags.payload_frame == "tool0"
    assert np.allclose(tags.payload_com, (0.03, -0.02, 0.06))
    assert np.allclose(tags.payload_inertia, (0.004, 0, 0, 0.004, 0, 0.002))


def test_a_start_s_payload_is_not_carried_over_and_a_frame_the_robot_lacks_is_refused(
        tmp_path, ros_env):
    """Issue 32: a refused start with an inertia, then a mass-only start: its tag is its mass
    only (nothing of the refused call's frame or inertia); a frame the
    robot (parameter robot) lacks is refused at start with its name."""
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    from std_srvs.srv import Trigger

    from orthoglide_ident.nodes.live_feed import status_payload
    from orthoglide_msgs.msg import RecorderStatus
    from orthoglide_sim.demos.graph import Graph

    def record_start(*extra: str) -> subprocess.CompletedProcess:
        return subprocess.run([sys.executable, "-m", "orthoglide_ident.cli", "record", "start",
                               "--condition", "loaded", "--payload-mass", "2", *extra],
                              env=ros_env, capture_output=True, text=True, timeout=120)

    with Graph(tmp_path / "logs") as g:
        g.start("orthoglide_recorder", "recorder", {"output_dir": str(tmp_path / "bags"),
                                                   "topics": ["joint_states"], "robot": "ur5"})
        g.wait_for_subscriber("joint_states", "orthoglide_recorder")
        refused = record_start("--payload-frame", "tool0",
                               "--payload-inertia=-0.004,0,0,0.004,0,0.002", "--name", "refused")
        assert refused.returncode == 2 and "\n" not in refused.stderr.strip()
        lacking = record_start("--payload-frame", "no_such_link", "--name", "lacking")
        assert lacking.returncode == 2 and "no_such_link" in lacking.stderr, lacking.stderr
        ok = record_start("--name", "mass_only")
        assert ok.returncode == 0, ok.stderr
        got: list = []
        latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                             reliability=ReliabilityPolicy.RELIABLE)
        g._listen(RecorderStatus, "orthoglide/recorder/status", latched, got.append,
                  lambda: any(m.recording for m in got), 30, lambda: "no recording status")
        status = next(m for m in got if m.recording)
        g.call(Trigger, "orthoglide/recorder/stop")
    assert status.bag_path.endswith("mass_only")
    shape = status_payload(status)  # its mass only (Sect. 4.3): nothing of the refused call's
    assert shape.known == "mass" and shape.frame == "" and not any(shape.inertia)
    assert status.payload_frame == "" and not list(status.payload_inertia)


def test_what_is_known_of_the_payload_is_tagged_per_start(tmp_path, ros_env):
    """``record start --payload-known point``: tagged orthoglide.payload_known point and on the
    status (the live identification reads it there); the next loaded start without the flag is
    tagged with its mass only (Sect. 4.3: CoM and inertia unknown), nothing carried over."""
    from rclpy.qos import (
        DurabilityPolicy,
        QoSProfile,
        ReliabilityPolicy,
    )
    from sensor_msgs.msg import JointState
    from std_srvs.srv import Trigger

    from orthoglide_ident import bags
    from orthoglide_ident._install_ament import ROOT
    from orthoglide_ident.nodes.live_feed import status_payload
    from orthoglide_msgs.msg import RecorderStatus
    from orthoglide_sim.demos.graph import Graph

    t0 = 1_796_000_000 * 10**9
    latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                         reliability=ReliabilityPolicy.RELIABLE)
    statuses = {}
    with Graph(tmp_path / "logs") as g:
        js = g.node.create_publisher(JointState, "joint_states", WHOLE_RUN)
        g.start("orthoglide_recorder", "recorder", {"output_dir": str(tmp_path / "bags")},
                params_file=ROOT / "config" / "ros2_control.yaml")
        g.wait_for_subscriber("joint_states", "orthoglide_recorder")
        for name, extra in (("point", ["--payload-known", "point"]), ("mass", [])):
            start = subprocess.run(
                [sys.executable, "-m", "orthoglide_ident.cli", "record", "start", "--condition",
                 "loaded", "--payload-mass", "2", "--name", name, *extra],
                env=ros_env, capture_output=True, text=True, timeout=120)
            assert start.returncode == 0, start.stderr
            got: list = []
            g._listen(RecorderStatus, "orthoglide/recorder/status", latched, got.append,
                      lambda: any(m.recording and name in m.bag_path for m in got), 30,
                      lambda: "no recording status")
            statuses[name] = next(m for m in got if m.recording and name in m.bag_path)
            g.wait_for_match(js)
            for k in range(100):
                m = JointState(name=["j1", "j2"], position=[0.001 * k, 0.0], effort=[0.1, 0.2])
                m.header.stamp.sec, m.header.stamp.nanosec = divmod(t0 + k * 1_000_000, 10**9)
                js.publish(m)
                time.sleep(0.001)
            g.wait_for_status(lambda s: s.ticks_written == 100 and name in s.bag_path)
            assert g.call(Trigger, "orthoglide/recorder/stop").success
            t0 += 10**9
    assert statuses["point"].payload_known == "point"
    assert status_payload(statuses["point"]).known == "point"
    assert statuses["mass"].payload_known == "mass"
    assert status_payload(statuses["mass"]).known == "mass"
    assert bags.read_bag(tmp_path / "bags" / "point").tags.payload_known == "point"
    tags = bags.read_bag(tmp_path / "bags" / "mass").tags
    assert tags.payload_known is None and tags.knowledge == "mass"


def test_the_robot_file_s_signal_sides_go_into_the_tag(tmp_path):
    """A robot file with a transmission: the recorder tags its bags with the file's
    position_side and effort_side (orthoglide.position_side, orthoglide.effort_side); without
    one (or the Orthoglide's ""), no side keys."""
    from orthoglide_ident import bags
    from orthoglide_ident.model.registry import ROBOTS_DIR
    from orthoglide_ident.nodes.recorder import robot_sides

    urdf = (ROBOTS_DIR / "ur5.urdf").read_text()
    block = "".join(
        f"<transmission name='t{k}'><plugin>transmission_interface/SimpleTransmission</plugin>"
        f"<actuator name='{j}'/><joint name='{j}'><mechanical_reduction>-32"
        "</mechanical_reduction></joint></transmission>"
        for k, j in enumerate(("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint",
                               "wrist_1_joint", "wrist_2_joint", "wrist_3_joint")))
    path = tmp_path / "ur5_tx.urdf"
    path.write_text(urdf.replace("</robot>", f"<ros2_control name='hw' type='system'>{block}"
                                             "</ros2_control></robot>"))
    sides = robot_sides(str(path))
    assert sides == {"position_side": "joint", "effort_side": "actuator"}
    tag = bags.BagTags.checked("unloaded", 0.0, **sides).to_dict()
    assert tag[bags.tags.POSITION_SIDE_KEY] == "joint"
    assert tag[bags.tags.EFFORT_SIDE_KEY] == "actuator"
    plain = tmp_path / "ur5.urdf"
    plain.write_text(urdf)
    assert robot_sides(str(plain)) == {} and robot_sides("") == {}
