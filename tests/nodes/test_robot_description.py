"""robot_description: with its robot parameter empty, the identification node takes the URDF that
robot_state_publisher publishes (std_msgs/String, transient local) as the robot."""
from __future__ import annotations

import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.model.registry import ROBOTS_DIR, load_robot_description

ROOT = Path(__file__).resolve().parents[2]
URDF = (ROBOTS_DIR / "ur5.urdf").read_text()


def test_a_urdf_text_is_loaded_once_by_its_hash(tmp_path):
    a = load_robot_description(URDF, tmp_path)
    assert a.name == "ur5" and a.n_joints == 6 and list(a.nominal_gains) == [1.0] * 6
    assert len(list(tmp_path.glob("*.urdf"))) == 1
    assert load_robot_description(URDF, tmp_path) is a  # published again: the same model
    other = URDF.replace('name="ur5"', 'name="ur5_b"', 1)
    assert (
        load_robot_description(other, tmp_path).name == "ur5_b"
        and len(list(tmp_path.glob("*.urdf"))) == 2
    )
    for bad, reason in (
        ("<robot name='x'", "not valid XML"),
        ("<sdf/>", r"not a URDF \(root element <sdf>"),
    ):
        with pytest.raises(ConfigError, match=reason) as e:
            load_robot_description(bad, tmp_path)
        assert "\n" not in str(e.value)


class _Node:
    """The identification node (robot empty) and a client that publishes robot_description."""

    def __init__(
        self, ros_env: dict, tmp_path: Path, args: list[str] = (), urdf: str = URDF
    ) -> None:
        import rclpy
        from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
        from std_msgs.msg import String

        from orthoglide_msgs.srv import Identify

        env = dict(ros_env, XDG_CACHE_HOME=str(tmp_path / "cache"))
        code = (
            "from orthoglide_ident.nodes.identification import main; import sys; sys.exit(main())"
        )
        self.proc = subprocess.Popen(
            [sys.executable, "-c", code, "--ros-args", "-p", "live:=false", *args],
            env=env,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
        )
        self.lines: list[str] = []
        threading.Thread(
            target=lambda: self.lines.extend(iter(self.proc.stdout.readline, "")), daemon=True
        ).start()
        self.rclpy = rclpy
        rclpy.init()
        self.node = rclpy.create_node("test_robot_description")
        latched = QoSProfile(
            depth=1,
            durability=DurabilityPolicy.TRANSIENT_LOCAL,
            reliability=ReliabilityPolicy.RELIABLE,
        )
        self.pub = self.node.create_publisher(String, "/robot_description", latched)
        self.pub.publish(String(data=urdf))
        self.cli = self.node.create_client(Identify, "/orthoglide/identify")

    def wait_log(self, text: str, timeout: float = 60.0) -> None:
        t_end = time.monotonic() + timeout
        while not any(text in x for x in self.lines):
            assert time.monotonic() < t_end and self.proc.poll() is None, "".join(self.lines)
            time.sleep(0.05)

    def identify(self, bags: list[str]):
        from orthoglide_msgs.srv import Identify

        assert self.cli.wait_for_service(timeout_sec=60)
        fut = self.cli.call_async(Identify.Request(bags=bags))
        self.rclpy.spin_until_future_complete(self.node, fut, timeout_sec=300)
        return fut.result()

    def close(self) -> None:
        self.node.destroy_node()
        self.rclpy.shutdown()
        self.proc.terminate()
        self.proc.wait(timeout=60)


def test_the_node_takes_the_published_urdf(ros_env, tmp_path):
    import rclpy  # noqa: F401
    n = _Node(ros_env, tmp_path)
    try:
        n.wait_log("robot from robot_description: ur5, 6 joints shoulder_pan_joint")
        # Orthoglide bags
        res = n.identify([str(ROOT / "bags" / "unloaded"), str(ROOT / "bags" / "loaded")])
    finally:
        n.close()
    # the UR5's joints now
    assert not res.success and "'shoulder_pan_joint'" in res.message, res.message


@pytest.mark.slow
def test_identifies_a_ur5_from_the_published_urdf(ros_env, tmp_path):
    """20 s + 20 s of the simulated UR5 (currents in A, gains 8.9-13.5 N·m/A, the 2 kg payload's
    shape in the tag), identified with the URDF from robot_description, which has no nominal gains
    (1 N·m/A: gain_range_ratio widened to admit 13.5): every gain within 0.5 % of the plant's."""
    import rclpy  # noqa: F401

    from orthoglide_sim.arm_or_chain.bags import write_record
    from orthoglide_sim.arms.record import simulate_arm

    recs = [simulate_arm(20.0, "ur5_mount", payload=None, trajectory="exciting1", seed=0),
            simulate_arm(20.0, "ur5_mount", payload="2.0", trajectory="exciting2", seed=1)]
    bags = [str(write_record(tmp_path / name, r)) for name, r in zip(("u", "l"), recs)]
    n = _Node(
        ros_env,
        tmp_path,
        ["-p", "gain_range_ratio:=20.0"],
        (ROBOTS_DIR / "ur5_mount.urdf").read_text(),
    )
    try:
        n.wait_log("robot from robot_description")
        res = n.identify(bags)
    finally:
        n.close()
    assert res.success, res.message
    g_true = recs[0].truth.drive_array("g_tau")
    assert np.abs(np.array(res.parameters.drive_gains) / g_true - 1).max() < 0.005
    assert list(res.parameters.joint_names) == list(recs[0].joint_names)
