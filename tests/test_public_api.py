"""The public faces: what each package's ``__init__`` hands on, pinned. A change here is a change
of the product's API: make it on purpose (and say so in docs/design/architecture.md "Public
faces")."""
from __future__ import annotations

import importlib

import pytest

API = {
    "orthoglide_ident.identify": [
        "IdentifyOptions",
        "LiveEstimate",
        "LiveIdentification",
        "Record",
        "identify",
        "identify_records",
        "read_record",
    ],
    "orthoglide_ident.model": [
        "ActuatedJoint",
        "Body",
        "Payload",
        "RobotModel",
        "bundled_robots",
        "load_robot",
    ],
    # the bags face (issue 44: at most 15 names); the rest in the submodules that define it
    "orthoglide_ident.bags": [
        "BagData",
        "BagInfo",
        "BagSources",
        "BagTags",
        "BagWriter",
        "Recording",
        "bag_info",
        "encoding",  # bulk CDR encoding, CdrTemplate (the driver's messages)
        "read_bag",
        "reindex",
        "tags",  # tag keys and values (DESIGN.md §4)
        "topics",  # topic names, message types, QoS (DESIGN.md §4)
        "write_bag",
    ],
    "orthoglide_ident.bags.topics": [
        "CURRENT_REFERENCE_TOPIC",
        "CURRENT_REFERENCE_TYPE",
        "DYNAMIC_JOINT_STATES_TOPIC",
        "DYNAMIC_JOINT_STATE_TYPE",
        "INTERFACE_VALUE_TYPE",  # a DynamicJointState's elements
        "JOINT_STATES_TOPIC",
        "JOINT_STATE_TYPE",
        "JTC_STATE_TYPE",
        "ROS2_CONTROL_JOINT_STATES_TOPIC",
        "default_qos",
        "msgdef_and_hash",
        "qos_profile",
        "typestore",  # rosbags' typestore with these types: tests and users write bags with it
    ],
    "orthoglide_ident.bags.tags": [
        "BagTags",
        "COM_KEY",
        "CONDITIONS",
        "CONDITION_KEY",
        "CURRENT_SOURCE_KEY",
        "EFFORT_SIDE_KEY",
        "EFFORT_UNIT_KEY",
        "FRAME_KEY",
        "INCOMPLETE_KEY",
        "INERTIA_KEY",
        "MASS_KEY",
        "METADATA_NAME",
        "POSITION_SIDE_KEY",
        "POSITION_SOURCE_KEY",
        "SIDES",
    ],
    "orthoglide_ident.bags.encoding": [
        "CdrTemplate",
        "MessageTemplate",
        "encode_dynamic_joint_states",
        "encode_joint_states",
        "encode_messages",
    ],
}
# the extension tables (docs/design/architecture.md "Extension points"): one place each
TABLES = {
    "orthoglide_ident.identify.solve.methods": [
        "METHODS",
        "REFINEMENTS",
        "DEFAULT_METHOD",
        "get",
        "solve",
    ],
    "orthoglide_ident.bags.sources": [
        "INPUT_SOURCES",
        "CURRENT_SOURCES",
        "POSITION",
        "DEFAULT_INTERFACE",
    ],
    "orthoglide_ident.model.registry": ["load_robot", "bundled_robots"],
}
# the node plumbing the nodes and the simulator share (rclpy: imported only where used)
ROS = {
    "orthoglide_ident.ros.spin": ["spin", "check_params_files"],
    "orthoglide_ident.ros.params": ["Param", "declare", "on_set", "usage", "from_command_line"],
    "orthoglide_ident.ros.batch": ["BatchTaker", "BatchTopic"],
    "orthoglide_ident.ros.processes": ["popen", "run", "interrupt_on_signals", "Interrupted"],
    "orthoglide_ident.ros.guard": ["CallbackGuard", "FailureLog", "cannot_go_on"],
    "orthoglide_ident.ros.core_log": ["CoreLog"],
}
ROBOT_MODEL = ["forward_model", "identified_urdf", "joint_labels", "gravity", "observation_block",
               "with_payload", "standard_regressor", "random_states", "regressor", "joint_names",
               "nominal_gains", "effort_as_current", "payload_standard_block"]


FACE_AT_MOST = 15  # names a package's face hands on (issue 44)


@pytest.mark.parametrize("package", sorted(API))
def test_each_package_hands_on_what_users_call(package):
    mod = importlib.import_module(package)
    assert sorted(mod.__all__) == sorted(API[package])
    missing = [n for n in mod.__all__ if not hasattr(mod, n)]
    assert not missing, f"{package}.__all__ names {missing}, which it does not define"
    assert len(mod.__all__) <= FACE_AT_MOST, f"{package} hands on {len(mod.__all__)} names"


@pytest.mark.parametrize("module", sorted(TABLES) + sorted(ROS))
def test_the_extension_tables_and_the_node_plumbing_are_public(module):
    if module in ROS:
        import rclpy  # noqa: F401
    mod = importlib.import_module(module)
    missing = [n for n in {**TABLES, **ROS}[module] if not hasattr(mod, n)]
    assert not missing, f"{module} lacks {missing}"


def test_the_robot_model_answers_what_callers_asked_by_type():
    from orthoglide_ident.model import RobotModel, load_robot

    assert all(hasattr(RobotModel, n) for n in ROBOT_MODEL)
    for name in ("orthoglide", "ur5"):
        robot = load_robot(name)
        assert (
            len(robot.gravity) == 3 and abs(sum(g * g for g in robot.gravity) - 9.80665**2) < 1e-9
        )
    # the Orthoglide's gravity is along +y0 (paper Sect. 5.1), a URDF robot's along -z
    assert load_robot("orthoglide").gravity[1] > 0 and load_robot("ur5").gravity[2] < 0
