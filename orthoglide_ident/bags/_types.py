"""Message types known to the bag code: definitions, RIHS01 hashes, rosbag2 QoS records.

The custom ``orthoglide_msgs`` definitions (docs/design/interfaces.md, fields exactly) and the
ros2_control
``control_msgs`` ones the product reads and writes (Jazzy's fields, msg_defs/control_msgs) are
embedded so that an installed copy works without the source tree or any compiled type; other
packages' .msg files are looked up under the ament prefixes when a recorder meets an unknown
type. Reading a bag needs none of this for its own types: :func:`schema_store` decodes from the
definitions the MCAP file carries.
"""

from __future__ import annotations

import functools
import os
import sys
import threading
from pathlib import Path
from typing import Any

from orthoglide_ident.errors import BagError

JOINT_STATES_TOPIC = "/orthoglide/joint_states"
CURRENT_REFERENCE_TOPIC = "/orthoglide/current_reference"
JOINT_STATE_TYPE = "sensor_msgs/msg/JointState"
CURRENT_REFERENCE_TYPE = "orthoglide_msgs/msg/CurrentReference"
# ros2_control's joint_state_broadcaster (Jazzy): one update, one header.stamp on both topics
ROS2_CONTROL_JOINT_STATES_TOPIC = "/joint_states"
DYNAMIC_JOINT_STATES_TOPIC = "/dynamic_joint_states"
DYNAMIC_JOINT_STATE_TYPE = "control_msgs/msg/DynamicJointState"
INTERFACE_VALUE_TYPE = "control_msgs/msg/InterfaceValue"
JTC_STATE_TYPE = "control_msgs/msg/JointTrajectoryControllerState"

EMBEDDED_MSGS: dict[str, str] = {
    CURRENT_REFERENCE_TYPE: "std_msgs/Header header\nstring[] name\nfloat64[] current\n",
    "orthoglide_msgs/msg/IdentifiedParameters": (
        "std_msgs/Header header\nstring method\nstring[] joint_names\nfloat64[] drive_gains\n"
        "float64[] drive_gains_rel_std\nstring[] names\nfloat64[] values\nfloat64[] rel_std\n"
        "float64 payload_mass\nfloat64 residual_rms\nfloat64 condition_number\n"
        "string[] source_bags\n"
    ),
    # control_msgs 5.8.0 (jazzy branch), fields of msg_defs/control_msgs/msg/*.msg
    INTERFACE_VALUE_TYPE: "string[] interface_names\nfloat64[] values\n",
    DYNAMIC_JOINT_STATE_TYPE: (
        "std_msgs/Header header\nstring[] joint_names\nInterfaceValue[] interface_values\n"
    ),
    JTC_STATE_TYPE: (
        "std_msgs/Header header\nstring[] joint_names\n"
        "trajectory_msgs/JointTrajectoryPoint reference\n"
        "trajectory_msgs/JointTrajectoryPoint feedback\n"
        "trajectory_msgs/JointTrajectoryPoint error\n"
        "trajectory_msgs/JointTrajectoryPoint output\n"
        "string[] multi_dof_joint_names\n"
        "trajectory_msgs/MultiDOFJointTrajectoryPoint multi_dof_reference\n"
        "trajectory_msgs/MultiDOFJointTrajectoryPoint multi_dof_feedback\n"
        "trajectory_msgs/MultiDOFJointTrajectoryPoint multi_dof_error\n"
        "trajectory_msgs/MultiDOFJointTrajectoryPoint multi_dof_output\n"
        "float64 speed_scaling_factor\n"
    ),
}

_lock = threading.Lock()


@functools.cache
def typestore() -> Any:
    """rosbags Jazzy typestore with the embedded orthoglide_msgs types registered."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.ROS2_JAZZY)
    types: dict[str, Any] = {}
    for name, text in EMBEDDED_MSGS.items():
        types.update(get_types_from_msg(text, name))
    store.register(types)
    return store


def _find_msg_file(msgtype: str) -> Path | None:
    pkg, kind, name = msgtype.split("/")
    roots = [p for p in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]
    roots.append(sys.prefix)
    roots.append(str(Path(__file__).resolve().parents[2] / "msg_defs"))
    for root in roots:
        for cand in (
            Path(root) / "share" / pkg / kind / f"{name}.msg",
            Path(root) / pkg / kind / f"{name}.msg",
        ):
            if cand.is_file():
                return cand
    return None


def ensure_type(msgtype: str) -> None:
    """Make ``msgtype`` (``pkg/msg/Name``) known to the typestore, from its .msg file if needed."""
    store = typestore()
    if msgtype in store.types:
        return
    from rosbags.typesys import get_types_from_msg

    with _lock:
        pending = [msgtype]
        seen: set[str] = set()
        while pending:
            name = pending.pop()
            if name in store.types or name in seen:
                continue
            seen.add(name)
            path = _find_msg_file(name) if name.count("/") == 2 else None
            if path is None:
                raise BagError(
                    f"message type {name} is unknown: its .msg file was not found under "
                    "AMENT_PREFIX_PATH; install its interface package"
                )
            try:
                store.register(get_types_from_msg(path.read_text(), name))
            except Exception as exc:  # rosbags raises several types for missing dependencies
                text = str(exc)
                dep = next((w.strip("'\".,") for w in text.split() if w.count("/") == 2), None)
                if dep and dep not in seen:
                    pending.extend([name, dep])
                    seen.discard(name)
                    continue
                raise BagError(f"cannot load message type {name} from {path}: {exc}") from None


@functools.lru_cache(maxsize=64)
def schema_store(msgtype: str, encoding: str, schema: str) -> Any:
    """A typestore that decodes ``msgtype`` as the bag's own MCAP schema defines it.

    rosbag2 stores each type's full definition (``ros2msg``, dependencies after ``MSG:`` lines,
    or ``ros2idl``), so a bag of a real robot decodes without any compiled or embedded type;
    an empty schema falls back to :func:`typestore`. BagError if the schema does not parse.
    """
    if not schema.strip():
        ensure_type(msgtype)
        return typestore()
    from rosbags.typesys import Stores, get_types_from_idl, get_types_from_msg, get_typestore

    store = get_typestore(Stores.EMPTY)
    try:
        types = (get_types_from_idl(schema) if encoding == "ros2idl"
                 else get_types_from_msg(schema, msgtype))
        store.register(types)
    except Exception as exc:  # rosbags raises several types for a definition it cannot use
        raise BagError(f"the bag's {encoding} definition of {msgtype} does not parse: "
                       f"{str(exc).splitlines()[0] if str(exc) else type(exc).__name__}") from None
    if msgtype not in store.types:
        raise BagError(f"the bag's {encoding} schema named {msgtype} does not define it")
    return store


def msgdef_and_hash(msgtype: str) -> tuple[str, str]:
    """Full ros2msg definition text (with dependencies, as rosbag2 stores it) and RIHS01 hash."""
    ensure_type(msgtype)
    store = typestore()
    msgdef, _ = store.generate_msgdef(msgtype, ros_version=2)
    return msgdef, store.hash_rihs01(msgtype)


_INFINITE = {"sec": 9223372036, "nsec": 854775807}


def qos_profile(
    reliability: str = "reliable",
    durability: str = "volatile",
    history: str = "unknown",
    depth: int = 0,
    deadline: dict[str, int] | None = None,
    lifespan: dict[str, int] | None = None,
    liveliness: str = "automatic",
    lease: dict[str, int] | None = None,
) -> dict[str, Any]:
    """One offered QoS profile in the rosbag2 v9 metadata layout."""
    return {
        "history": history,
        "depth": int(depth),
        "reliability": reliability,
        "durability": durability,
        "deadline": dict(deadline or _INFINITE),
        "lifespan": dict(lifespan or _INFINITE),
        "liveliness": liveliness,
        "liveliness_lease_duration": dict(lease or _INFINITE),
        "avoid_ros_namespace_conventions": False,
    }


def default_qos() -> list[dict[str, Any]]:
    """What rosbag2 records for a default reliable publisher found by discovery."""
    return [qos_profile()]
