"""The orthoglide_msgs interfaces (docs/design/interfaces.md): exact fields, CDR round trip, and
real exchange
between processes over Fast DDS -- a publisher and a subscriber, a service server and a client.
The control_msgs messages of ros2_control (docs/design/architecture.md §3): Jazzy's fields, a real
install's type
hashes, and the same exchange between processes."""
from __future__ import annotations

import json
from pathlib import Path

import pytest
from rclpy.serialization import deserialize_message, serialize_message

from control_msgs.msg import DynamicJointState, InterfaceValue, JointTrajectoryControllerState
from orthoglide_ident.bags import topics
from orthoglide_msgs.msg import CurrentReference, IdentifiedParameters
from orthoglide_msgs.srv import Identify, StartRecording, StopRecording

# docs/design/interfaces.md, field for field; tools outside the project rely on these.
EXPECTED_FIELDS = {
    CurrentReference: {
        "header": "std_msgs/Header",
        "name": "sequence<string>",
        "current": "sequence<double>",
    },
    IdentifiedParameters: {
        "header": "std_msgs/Header",
        "method": "string",
        "joint_names": "sequence<string>",
        "drive_gains": "sequence<double>",
        "drive_gains_rel_std": "sequence<double>",
        "names": "sequence<string>",
        "values": "sequence<double>",
        "rel_std": "sequence<double>",
        "payload_mass": "double",
        "residual_rms": "double",
        "condition_number": "double",
        "source_bags": "sequence<string>",
    },
    Identify.Request: {
        "bags": "sequence<string>",
        "payload_mass": "double",
        "method": "string",
        "essential": "boolean",
    },
    Identify.Response: {
        "success": "boolean",
        "message": "string",
        "parameters": "orthoglide_msgs/IdentifiedParameters",
    },
    StartRecording.Request: {
        "condition": "string",
        "payload_mass": "double",
        "name": "string",
    },
    StartRecording.Response: {
        "success": "boolean",
        "message": "string",
        "bag_path": "string",
    },
    StopRecording.Request: {"incomplete_reason": "string"},  # added: recorder/stop_incomplete
    StopRecording.Response: {
        "success": "boolean",
        "message": "string",
        "bag_path": "string",
    },
}


# Fields added after the design's, never changing them (DESIGN §9: a partial answer's flags).
ADDED_FIELDS = {
    IdentifiedParameters: {
        "drive_gains_determined": "sequence<boolean>",
        "drive_gains_reason": "sequence<string>",
    },
}


@pytest.mark.parametrize("msg_type", list(EXPECTED_FIELDS), ids=lambda t: t.__qualname__)
def test_fields_are_exactly_those_of_the_design(msg_type: type) -> None:
    fields = msg_type.get_fields_and_field_types()
    assert list(fields)[:len(EXPECTED_FIELDS[msg_type])] == list(EXPECTED_FIELDS[msg_type])
    assert fields == {**EXPECTED_FIELDS[msg_type], **ADDED_FIELDS.get(msg_type, {})}


def _identified_parameters() -> IdentifiedParameters:
    msg = IdentifiedParameters(
        method="tls",
        joint_names=["q11", "q12", "q13"],
        drive_gains=[2170.0, 2100.0, 2070.0],
        drive_gains_rel_std=[0.0006, 0.001, 0.002],
        names=["m_11R", "fv_31R", "ia_12"],
        values=[3.5, 12.25, -0.125],
        rel_std=[0.5, 1.5, 40.0],
        payload_mass=1.136,
        residual_rms=0.75,
        condition_number=123.5,
        source_bags=["bags/unloaded", "bags/loaded.mcap"],
    )
    msg.header.stamp.sec = 1_700_000_000
    msg.header.stamp.nanosec = 1_000_000
    msg.header.frame_id = "base"
    return msg


def _examples() -> list[object]:
    current = CurrentReference(name=["q11", "q12", "q13"], current=[0.25, -1.5, 3.0e-3])
    current.header.stamp.sec = 42
    current.header.stamp.nanosec = 999_000_000
    return [
        current,
        _identified_parameters(),
        Identify.Request(bags=["a", "b/c.mcap"], payload_mass=1.136, method="wls", essential=True),
        Identify.Response(success=True, message="ok", parameters=_identified_parameters()),
        StartRecording.Request(condition="loaded", payload_mass=1.136, name="loaded_01"),
        StartRecording.Response(success=False, message="already recording", bag_path="/tmp/x"),
        StopRecording.Request(incomplete_reason="loaded run aborted: PATH_TOLERANCE_VIOLATED"),
    ]


@pytest.mark.parametrize("msg", _examples(), ids=lambda m: type(m).__qualname__)
def test_cdr_round_trip(msg: object) -> None:
    data = serialize_message(msg)
    assert isinstance(data, bytes) and len(data) > 4
    back = deserialize_message(data, type(msg))
    assert back == msg
    # Not `serialize_message(back) == data`: rmw_fastrtps leaves CDR alignment padding
    # uninitialised, so equal messages may serialise to bytes that differ in the padding.
    assert deserialize_message(serialize_message(back), type(msg)) == msg


SUBSCRIBER = r"""
import json, sys
import rclpy
from orthoglide_msgs.msg import CurrentReference

rclpy.init()
node = rclpy.create_node("test_current_reference_listener")
received = []
node.create_subscription(CurrentReference, sys.argv[1], received.append, 10)
print("ready", flush=True)
deadline = node.get_clock().now().nanoseconds + 30e9
while not received and node.get_clock().now().nanoseconds < deadline:
    rclpy.spin_once(node, timeout_sec=0.1)
if received:
    msg = received[0]
    print(json.dumps({"name": list(msg.name), "current": list(msg.current),
                      "sec": msg.header.stamp.sec, "nanosec": msg.header.stamp.nanosec}),
                      flush=True)
node.destroy_node()
rclpy.shutdown()
sys.exit(0 if received else 3)
"""

PUBLISHER = r"""
import sys, time
import rclpy
from orthoglide_msgs.msg import CurrentReference

rclpy.init()
node = rclpy.create_node("test_current_reference_talker")
pub = node.create_publisher(CurrentReference, sys.argv[1], 10)
msg = CurrentReference(name=["q11", "q12", "q13"], current=[0.25, -1.5, 0.003])
msg.header.stamp.sec = 12
msg.header.stamp.nanosec = 345
for _ in range(600):  # until the test stops us (at most ~60 s)
    pub.publish(msg)
    rclpy.spin_once(node, timeout_sec=0.1)
"""


def test_current_reference_between_two_processes(spawn_python) -> None:
    topic = "/orthoglide/current_reference"
    listener = spawn_python(SUBSCRIBER, topic)
    talker = spawn_python(PUBLISHER, topic)
    out, err = listener.communicate(timeout=60)
    talker.terminate()
    assert listener.returncode == 0, f"subscriber got nothing (rc {listener.returncode}):\n{err}"
    got = json.loads(out.strip().splitlines()[-1])
    assert got == {"name": ["q11", "q12", "q13"], "current": [0.25, -1.5, 0.003],
                   "sec": 12, "nanosec": 345}


SERVER = r"""
import rclpy
from orthoglide_msgs.srv import Identify

def handle(request, response):
    response.success = True
    response.message = (f"{len(request.bags)} bags, {request.payload_mass} kg, "
                        f"{request.method}, essential={request.essential}")
    p = response.parameters
    p.method = request.method
    p.joint_names = ["q11", "q12", "q13"]
    p.drive_gains = [2170.0, 2100.0, 2070.0]
    p.payload_mass = request.payload_mass
    p.source_bags = list(request.bags)
    return response

rclpy.init()
node = rclpy.create_node("test_identify_server")
node.create_service(Identify, "/orthoglide/identify", handle)
try:
    rclpy.spin(node)
except KeyboardInterrupt:
    pass
"""

CLIENT = r"""
import json, sys
import rclpy
from orthoglide_msgs.srv import Identify

rclpy.init()
node = rclpy.create_node("test_identify_client")
client = node.create_client(Identify, "/orthoglide/identify")
if not client.wait_for_service(timeout_sec=30.0):
    sys.exit(3)
future = client.call_async(Identify.Request(bags=["bags/unloaded", "bags/loaded"],
                                            payload_mass=1.136, method="tls", essential=True))
rclpy.spin_until_future_complete(node, future, timeout_sec=30.0)
if not future.done():
    sys.exit(4)
r = future.result()
print(json.dumps({"success": r.success, "message": r.message, "method": r.parameters.method,
                  "gains": list(r.parameters.drive_gains), "mass": r.parameters.payload_mass,
                  "bags": list(r.parameters.source_bags)}), flush=True)
node.destroy_node()
rclpy.shutdown()
"""


def test_identify_service_between_two_processes(spawn_python) -> None:
    server = spawn_python(SERVER)
    client = spawn_python(CLIENT)
    out, err = client.communicate(timeout=90)
    server.terminate()
    assert client.returncode == 0, f"client failed (rc {client.returncode}: 3 = no service, " \
                                   f"4 = no response):\n{err}"
    got = json.loads(out.strip().splitlines()[-1])
    assert got == {
        "success": True,
        "message": "2 bags, 1.136 kg, tls, essential=True",
        "method": "tls",
        "gains": [2170.0, 2100.0, 2070.0],
        "mass": 1.136,
        "bags": ["bags/unloaded", "bags/loaded"],
    }


# -- control_msgs (ros2_control, Jazzy): built from msg_defs/control_msgs unless installed --------

ROOT = Path(__file__).resolve().parents[1]

# RIHS01 hashes that rosidl computed on real Jazzy installs of control_msgs, read from generated
# code published in two unrelated repositories: a colcon install of Jazzy's control_msgs
# (saahu27/aprs, aprs_ws/install/control_msgs/include/.../msg/detail/*__description.c) and
# micro-ROS's generated headers (micro-ROS/micro_ros_arduino,
# src/control_msgs/msg/detail/dynamic_joint_state__struct.h, same DynamicJointState value).
REAL_INSTALL_HASHES = {
    "control_msgs/msg/DynamicJointState":
        "RIHS01_18024c98a62697680f581108eeed40b28fb4542fa0ac5a8e36f56c62b6813d26",
    "control_msgs/msg/InterfaceValue":
        "RIHS01_74a12144ef6b7af67533195cb30f7f607d3301b66950208a72d280695f3e190c",
}
# That install is control_msgs 5.0-5.2, before speed_scaling_factor was appended to
# JointTrajectoryControllerState (5.3.0, Nov. 2024; every later Jazzy release has it):
JTC_STATE_WITHOUT_SPEED_SCALING = (
    "RIHS01_6cb9ac0858fc11b54bd6c0a46f032ea243c16856182276d8eb0875f6ce6a8335")
# Ours (control_msgs >= 5.3.0 fields) as rosidl computes it; checked equal to rosbags' below.
JTC_STATE_HASH = "RIHS01_51d8dd89cc624cbe9daaeeb4d80d6de9b86168ffdc3be41fefc0953e3c26e480"

CONTROL_MSGS = {
    DynamicJointState: {
        "header": "std_msgs/Header",
        "joint_names": "sequence<string>",
        "interface_values": "sequence<control_msgs/InterfaceValue>",
    },
    InterfaceValue: {"interface_names": "sequence<string>", "values": "sequence<double>"},
    JointTrajectoryControllerState: {
        "header": "std_msgs/Header",
        "joint_names": "sequence<string>",
        **{k: "trajectory_msgs/JointTrajectoryPoint"
           for k in ("reference", "feedback", "error", "output")},
        "multi_dof_joint_names": "sequence<string>",
        **{f"multi_dof_{k}": "trajectory_msgs/MultiDOFJointTrajectoryPoint"
           for k in ("reference", "feedback", "error", "output")},
        "speed_scaling_factor": "double",
    },
}


def _type_name(msg_type: type) -> str:
    return f"control_msgs/msg/{msg_type.__name__}"


def _rosidl_hash(type_name: str) -> str:
    """The hash rosidl generated for the installed control_msgs (share/<pkg>/msg/<T>.json)."""
    from ament_index_python.packages import get_package_share_directory

    pkg, _, name = type_name.split("/")
    doc = json.loads(Path(get_package_share_directory(pkg), "msg", f"{name}.json").read_text())
    return {h["type_name"]: h["hash_string"] for h in doc["type_hashes"]}[type_name]


@pytest.mark.parametrize("msg_type", list(CONTROL_MSGS), ids=lambda t: t.__name__)
def test_control_msgs_fields_are_jazzys(msg_type: type) -> None:
    assert msg_type.get_fields_and_field_types() == CONTROL_MSGS[msg_type]


@pytest.mark.parametrize("type_name", sorted(REAL_INSTALL_HASHES))
def test_control_msgs_hash_is_a_real_installs(type_name: str) -> None:
    """rosidl's hash of the built type and rosbags' hash of the definition the bag code embeds
    (two implementations of REP 2011) both equal the one a real Jazzy install reports."""
    assert _rosidl_hash(type_name) == REAL_INSTALL_HASHES[type_name]
    assert topics.typestore().hash_rihs01(type_name) == REAL_INSTALL_HASHES[type_name]


def test_jtc_state_hash() -> None:
    """All fields but the appended speed_scaling_factor hash as the real 5.0-5.2 install's; the
    whole message hashes alike in rosidl and rosbags."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    name = _type_name(JointTrajectoryControllerState)
    assert _rosidl_hash(name) == JTC_STATE_HASH == topics.typestore().hash_rihs01(name)
    text = (ROOT / "msg_defs/control_msgs/msg/JointTrajectoryControllerState.msg").read_text()
    before_5_3 = "\n".join(ln for ln in text.splitlines() if "speed_scaling_factor" not in ln)
    store = get_typestore(Stores.ROS2_JAZZY)
    store.register(get_types_from_msg(before_5_3, name))
    assert store.hash_rihs01(name) == JTC_STATE_WITHOUT_SPEED_SCALING


@pytest.mark.parametrize("msg_type", list(CONTROL_MSGS), ids=lambda t: t.__name__)
def test_embedded_definitions_are_the_msg_files(msg_type: type) -> None:
    """The bag code's embedded text (read without the source tree) says what the .msg file says."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    name = _type_name(msg_type)
    store = get_typestore(Stores.ROS2_JAZZY)
    for dep in ("InterfaceValue", "DynamicJointState", "JointTrajectoryControllerState"):
        path = ROOT / "msg_defs/control_msgs/msg" / f"{dep}.msg"
        store.register(get_types_from_msg(path.read_text(), f"control_msgs/msg/{dep}"))
    msgdef, type_hash = topics.msgdef_and_hash(name)
    assert type_hash == store.hash_rihs01(name)
    assert msgdef == store.generate_msgdef(name, ros_version=2)[0]


def test_control_msgs_package_layout() -> None:
    """package.xml is valid format 3 named control_msgs, and ament finds the package."""
    from ament_index_python.packages import get_package_prefix, get_package_share_directory
    from catkin_pkg.package import parse_package

    package = parse_package(ROOT / "msg_defs/control_msgs/package.xml")
    package.validate()
    assert package.package_format == 3 and package.name == "control_msgs"
    assert Path(get_package_share_directory("control_msgs"), "package.xml").is_file()
    prefix = Path(get_package_prefix("control_msgs"))
    assert (prefix / "share/ament_index/resource_index/packages/control_msgs").is_file()


def _dynamic_joint_state() -> DynamicJointState:
    msg = DynamicJointState(
        joint_names=["shoulder_lift_joint", "gripper_joint"],
        interface_values=[
            InterfaceValue(interface_names=["position", "velocity", "current"],
                           values=[0.5, -0.25, 1.75]),
            InterfaceValue(interface_names=["position"], values=[0.01]),
        ],
    )
    msg.header.stamp.sec, msg.header.stamp.nanosec = 7, 1_000_000
    return msg


def test_control_msgs_cdr_round_trip() -> None:
    from trajectory_msgs.msg import JointTrajectoryPoint

    jtc = JointTrajectoryControllerState(
        joint_names=["a", "b"], output=JointTrajectoryPoint(effort=[1.5, -2.0]),
        speed_scaling_factor=0.5)
    for msg in (_dynamic_joint_state(), jtc):
        assert deserialize_message(serialize_message(msg), type(msg)) == msg
    # rclpy's bytes decode in rosbags with the embedded definition (the bag reader's slow path)
    back = topics.typestore().deserialize_cdr(serialize_message(_dynamic_joint_state()),
                                              "control_msgs/msg/DynamicJointState")
    assert list(back.interface_values[0].values) == [0.5, -0.25, 1.75]


CONTROL_SUBSCRIBER = r"""
import json, sys
import rclpy
from control_msgs.msg import DynamicJointState, JointTrajectoryControllerState

rclpy.init()
node = rclpy.create_node("test_control_msgs_listener")
got = {}
node.create_subscription(DynamicJointState, "/dynamic_joint_states",
                         lambda m: got.setdefault("djs", m), 10)
node.create_subscription(JointTrajectoryControllerState, "/jtc/controller_state",
                         lambda m: got.setdefault("jtc", m), 10)
deadline = node.get_clock().now().nanoseconds + 30e9
while len(got) < 2 and node.get_clock().now().nanoseconds < deadline:
    rclpy.spin_once(node, timeout_sec=0.1)
if len(got) == 2:
    hashes = {t: str(node.get_publishers_info_by_topic(t)[0].topic_type_hash)
              for t in ("/dynamic_joint_states", "/jtc/controller_state")}
    d, j = got["djs"], got["jtc"]
    print(json.dumps({
        "joints": list(d.joint_names), "stamp": [d.header.stamp.sec, d.header.stamp.nanosec],
        "interfaces": [[list(v.interface_names), list(v.values)] for v in d.interface_values],
        "effort": list(j.output.effort), "speed": j.speed_scaling_factor, "hashes": hashes}),
        flush=True)
node.destroy_node()
rclpy.shutdown()
sys.exit(0 if len(got) == 2 else 3)
"""

CONTROL_PUBLISHER = r"""
import rclpy
from control_msgs.msg import DynamicJointState, InterfaceValue, JointTrajectoryControllerState
from trajectory_msgs.msg import JointTrajectoryPoint

rclpy.init()
node = rclpy.create_node("test_control_msgs_talker")
djs_pub = node.create_publisher(DynamicJointState, "/dynamic_joint_states", 10)
jtc_pub = node.create_publisher(JointTrajectoryControllerState, "/jtc/controller_state", 10)
djs = DynamicJointState(joint_names=["shoulder_lift_joint", "gripper_joint"], interface_values=[
    InterfaceValue(interface_names=["position", "velocity", "current"], values=[0.5, -0.25, 1.75]),
    InterfaceValue(interface_names=["position"], values=[0.01])])
djs.header.stamp.sec, djs.header.stamp.nanosec = 7, 1_000_000
jtc = JointTrajectoryControllerState(joint_names=["a", "b"],
                                     output=JointTrajectoryPoint(effort=[1.5, -2.0]),
                                     speed_scaling_factor=0.5)
for _ in range(600):  # until the test stops us (at most ~60 s)
    djs_pub.publish(djs)
    jtc_pub.publish(jtc)
    rclpy.spin_once(node, timeout_sec=0.1)
"""


def test_control_msgs_between_two_processes(spawn_python) -> None:
    """Published and received over Fast DDS; the hash the publisher advertises on the graph is
    the real install's (so a real ros2_control graph matches these endpoints)."""
    listener = spawn_python(CONTROL_SUBSCRIBER)
    talker = spawn_python(CONTROL_PUBLISHER)
    out, err = listener.communicate(timeout=60)
    talker.terminate()
    assert listener.returncode == 0, f"subscriber got nothing (rc {listener.returncode}):\n{err}"
    got = json.loads(out.strip().splitlines()[-1])
    assert got["joints"] == ["shoulder_lift_joint", "gripper_joint"]
    assert got["stamp"] == [7, 1_000_000]
    assert got["interfaces"] == [[["position", "velocity", "current"], [0.5, -0.25, 1.75]],
                                 [["position"], [0.01]]]
    assert got["effort"] == [1.5, -2.0] and got["speed"] == 0.5
    assert got["hashes"] == {
        "/dynamic_joint_states": REAL_INSTALL_HASHES["control_msgs/msg/DynamicJointState"],
        "/jtc/controller_state": JTC_STATE_HASH}


# control_msgs/action/FollowJointTrajectory (excite run, the stand-in's JTC): the jazzy branch's
# fields; rosidl's hashes of them (no real Jazzy install's found to compare: docs/design/bags.md).
FOLLOW_JOINT_TRAJECTORY_HASHES = {
    "control_msgs/action/FollowJointTrajectory":
        "RIHS01_738ebcb7a2d7cfa42f9f1001cc99ce3a4383d1cfe508015d9be8485e4b1c66f6",
    "control_msgs/action/FollowJointTrajectory_Goal":
        "RIHS01_8a9060704b269608f5a340934cc26e66869dd14bdac29e2e7fd9ec8b9882d205",
    "control_msgs/action/FollowJointTrajectory_Result":
        "RIHS01_8002e99ed2c14c6faa522f2a93c26d744c5982f254f9e98ff9c6f19789bdb220",
    "control_msgs/action/FollowJointTrajectory_Feedback":
        "RIHS01_3fd0aaecf71725121ae1ff7f01098a5e0da581e672be18a6b2c286cb43d96b49",
    "control_msgs/msg/JointTolerance":
        "RIHS01_c254f9cece0f3b733017b6990fd46d1326e25242d6b8844398c97d9a88e7d648",
    "control_msgs/msg/JointComponentTolerance":
        "RIHS01_739ea7566931944d33830fa10f1bf5e7a7fbdc3172bce7a7eaac642bd6e3ffa4",
}


def test_follow_joint_trajectory_hashes_agree_in_rosidl_and_rosbags() -> None:
    """The built action's hashes (rosidl) are the pinned ones, and rosbags' independent REP 2011
    implementation hashes the .action/.msg files' goal, result, feedback and tolerances alike."""
    from ament_index_python.packages import get_package_share_directory
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    from control_msgs.action import FollowJointTrajectory

    share = Path(get_package_share_directory("control_msgs"))
    built = {}
    for f in (share / "action/FollowJointTrajectory.json", share / "msg/JointTolerance.json",
              share / "msg/JointComponentTolerance.json"):
        built.update(
            {h["type_name"]: h["hash_string"] for h in json.loads(f.read_text())["type_hashes"]}
        )
    assert {k: built[k] for k in FOLLOW_JOINT_TRAJECTORY_HASHES} == FOLLOW_JOINT_TRAJECTORY_HASHES
    store = get_typestore(Stores.ROS2_JAZZY)
    defs = ROOT / "msg_defs/control_msgs"
    for name in ("JointTolerance", "JointComponentTolerance"):
        store.register(
            get_types_from_msg((defs / f"msg/{name}.msg").read_text(), f"control_msgs/msg/{name}")
        )
    text = (defs / "action/FollowJointTrajectory.action").read_text()
    text = text.replace("JointTolerance[]", "control_msgs/msg/JointTolerance[]").replace(
        "JointComponentTolerance[]", "control_msgs/msg/JointComponentTolerance[]")
    for part, suffix in zip(text.split("\n---\n"), ("Goal", "Result", "Feedback")):
        store.register(
            get_types_from_msg(part, f"control_msgs/action/FollowJointTrajectory_{suffix}")
        )
    for name, h in FOLLOW_JOINT_TRAJECTORY_HASHES.items():
        if name != "control_msgs/action/FollowJointTrajectory":  # rosbags has no actions
            assert store.hash_rihs01(name) == h, name
    assert set(FollowJointTrajectory.Feedback.get_fields_and_field_types()) == {
        "header", "joint_names", "desired", "actual", "error", "multi_dof_joint_names",
        # jazzy: no `index` (6.x adds it)
        "multi_dof_desired", "multi_dof_actual", "multi_dof_error"}
