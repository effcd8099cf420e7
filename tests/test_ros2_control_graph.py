"""Next to a ros2_control robot, over the real topics: the stand-in publishes what
joint_state_broadcaster publishes, the recorder records it, the identification identifies it live
and from the bags (`make demo-ros2-control` in short)."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml

from orthoglide_sim.demos.graph import Graph  # noqa: E402
from orthoglide_sim.demos.node_set import identify, record  # noqa: E402

STANDIN = "ros2_control_standin"
DROP_RATE, SEED = 3e-4, 4
TOPICS = ("joint_states", "dynamic_joint_states")


def _rel(a, b) -> float:
    a, b = np.asarray(a, float), np.asarray(b, float)
    return float(np.max(np.abs(a - b) / np.abs(b)))


def _dropped_stamps(start_ns: int, n_ticks: int) -> dict[str, set[int]]:
    """The stamps the stand-in's seeded drops leave out, per topic (its TickDropper replayed)."""
    from orthoglide_sim.common.broadcaster import TICK_NS, TickDropper

    d = TickDropper(DROP_RATE, SEED)
    out: dict[str, set[int]] = {t: set() for t in TOPICS}
    for k in range(n_ticks):
        for topic, keep in zip(TOPICS, d.keep()):
            if not keep:
                out[topic].add(start_ns + k * TICK_NS)
    return out


def _system_default_qos() -> dict:
    """Reliability and durability a publisher with the system default profile offers here, as
    rosbag2's metadata writes them (Fast DDS: reliable, transient_local)."""
    import rclpy
    from rclpy.qos import qos_profile_system_default
    from std_msgs.msg import String

    rclpy.init()
    try:
        node = rclpy.create_node("qos_probe")
        node.create_publisher(String, "qos_probe", qos_profile_system_default)
        q = node.get_publishers_info_by_topic("/qos_probe")[0].qos_profile
        return {"reliability": q.reliability.name.lower(), "durability": q.durability.name.lower()}
    finally:
        rclpy.shutdown()


@pytest.mark.slow
def test_record_and_identify_a_ros2_control_robot(tmp_path):
    from sensor_msgs.msg import JointState
    from std_msgs.msg import String

    from orthoglide_ident import bags as bagio
    from orthoglide_ident._install_ament import ROOT
    from orthoglide_sim.arms.description import load_arm
    from orthoglide_sim.arms.truth import load_truth

    config = ROOT / "config" / "ros2_control.yaml"
    with Graph(tmp_path / "logs") as g:
        g.start(
            STANDIN,
            "driver",
            {"robot": "ur5_mount", "drop_rate": DROP_RATE, "seed": SEED},
            params_file=config,
        )
        g.start(
            "orthoglide_recorder",
            "recorder",
            {"output_dir": str(tmp_path / "bags")},
            params_file=config,
        )
        g.start("orthoglide_identification", "identification",
                {"bag_dir": str(tmp_path / "bags"), "lag_model": "off"}, params_file=config)
        g.wait_for_messages(JointState, "joint_states", 1, timeout=60)
        for topic in TOPICS:
            g.wait_for_subscriber(topic, "orthoglide_identification")
            g.wait_for_subscriber(topic, "orthoglide_recorder")
            # live = offline needs every tick of the recordings: its intake says when data come
            g.wait_for_log("orthoglide_identification", f"live identification: receiving /{topic}")
        paths = [record(g, "unloaded", "unloaded", 0.0, 15.0, quiet=True)]
        g.set_params(STANDIN, payload=2.5, trajectory="exciting2")
        g.wait_for_robot_time(3.0, "joint_states")  # the new trajectory blends in (robot time)
        paths.append(record(g, "loaded", "loaded", 2.5, 15.0, quiet=True))
        # live identification has folded in the loaded recording (its feed says so when done)
        g.wait_for_log("orthoglide_identification", f": {paths[-1]} done;")
        live = identify(g, []).parameters
        live_json = json.loads(g.latched(String, "orthoglide/identify/json").data)["result"]
        offline = identify(g, paths).parameters
        off_json = json.loads(g.latched(String, "orthoglide/identify/json").data)["result"]
        log = (tmp_path / "logs" / f"{STANDIN}.log").read_text()
    start_ns = int(log.split("update k is stamped ", 1)[1].split()[0])
    mine = _system_default_qos()  # what rclcpp::SystemDefaultsQoS() offers on this rmw

    # identified, live = offline for the same equations (lag_model: off), the plant's gains
    g_true = load_truth(load_arm("ur5_mount")).drive_array("g_tau")
    assert list(offline.joint_names) == list(load_arm("ur5_mount").joint_names)
    # every sample of the bags reached the live identification (counted per recording)
    counts = ("n_joint_states", "n_current_reference", "n_paired", "n_used", "n_segments")
    for a, b in zip(live_json["diagnostics"]["bags"], off_json["diagnostics"]["bags"]):
        print("samples live vs bag:", {k: (a[k], b[k]) for k in counts})
        assert {k: a[k] for k in counts} == {k: b[k] for k in counts}, (a["bag"], a, b)
    g_live, g_off = np.asarray(live.drive_gains), np.asarray(offline.drive_gains)
    values = dict(zip(offline.names, offline.values))
    big = [(n, v) for n, v in zip(live.names, live.values)
           if abs(values[n]) > 1e-3 * max(map(abs, values.values()))]
    dp = max(abs(v / values[n] - 1) for n, v in big)
    print(f"live vs bags: gains {_rel(g_live, g_off):.3g}, parameters {dp:.3g} relative")
    assert _rel(g_live, g_off) < 1e-6 and dp < 1e-6, (_rel(g_live, g_off), dp)
    assert _rel(offline.drive_gains, g_true) < 0.005

    for path in paths:
        data = bagio.read_bag(path)
        # the hardware's order and the gripper, as published; the current from the interface
        assert "gripper_finger_joint" in data.positions.names
        assert (
            data.sources.current.topic == "/dynamic_joint_states"
            and data.sources.current.field == "current"
        )
        # every tick published is in the bag; the ones missing are exactly those the stand-in
        # dropped
        stamps = {
            "joint_states": data.positions.stamps_ns,
            "dynamic_joint_states": data.current.stamps_ns,
        }
        first, last = (
            min(int(s[0]) for s in stamps.values()),
            max(int(s[-1]) for s in stamps.values()),
        )
        dropped = _dropped_stamps(start_ns, (last - start_ns) // 1_000_000 + 1)
        for topic, st in stamps.items():
            span = set(range(first, last + 1, 1_000_000))
            missing = span - set(int(s) for s in st)
            assert missing == {s for s in dropped[topic] if first <= s <= last}, (path, topic)
        # each channel's offered QoS, as rosbag2 records it: the broadcaster's
        meta = yaml.safe_load((Path(path) / "metadata.yaml").read_text())
        for t in meta["rosbag2_bagfile_information"]["topics_with_message_count"]:
            qos = t["topic_metadata"]["offered_qos_profiles"]
            qos = yaml.safe_load(qos) if isinstance(qos, str) else qos
            assert len(qos) == 1 and qos[0]["reliability"] == mine["reliability"], t
            assert qos[0]["durability"] == mine["durability"], t
