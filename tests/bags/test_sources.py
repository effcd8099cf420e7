"""Bags of a ros2_control robot (docs/design/architecture.md §3): /joint_states alone or with
/dynamic_joint_states,
joints in the hardware's order with an extra joint, read by name; the current by the order of
preference (a DynamicJointState interface, the JointState effort, the CurrentReference) or by the
bag's tag; a missing joint, interface or topic refused with a one-line reason."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from orthoglide_ident import bags
from orthoglide_ident.bags.encoding import encode_dynamic_joint_states, encode_joint_states
from orthoglide_ident.bags.reader import decode_messages
from orthoglide_ident.bags.topics import (
    DYNAMIC_JOINT_STATE_TYPE,
    DYNAMIC_JOINT_STATES_TOPIC,
    JOINT_STATE_TYPE,
    ROS2_CONTROL_JOINT_STATES_TOPIC,
)
from orthoglide_ident.errors import BagError
from orthoglide_ident.model.registry import load_robot

ORTHOGLIDE = load_robot("orthoglide")  # the robot these records are of

UR5 = ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint",
       "wrist_2_joint", "wrist_3_joint")
# what the hardware publishes: its own order, a gripper in the middle
HW_ORDER = ("wrist_3_joint", "elbow_joint", "gripper_finger_joint", "shoulder_pan_joint",
            "wrist_1_joint", "shoulder_lift_joint", "wrist_2_joint")
T0 = 1_700_000_000_000_000_000


def _record(n: int = 1500, seed: int = 1) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    stamps = T0 + np.arange(n, dtype=np.int64) * 1_000_000
    return stamps, rng.normal(size=(n, 6)), rng.normal(size=(n, 6))


def _write(path: Path, layout: str, **kw) -> Path:
    stamps, q, v = _record()
    kw.setdefault("joint_order", HW_ORDER)
    kw.setdefault("extra_joints", {"gripper_finger_joint": 0.02})
    return bags.write_bag(path, stamps, q, v, "loaded", 2.0, UR5, layout=layout, **kw)


@pytest.fixture(scope="module")
def two_layouts(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    root = tmp_path_factory.mktemp("ros2_control")
    return {lay: _write(root / lay, lay) for lay in ("joint_states", "dynamic_joint_states")}


@pytest.mark.parametrize("layout, current", [
    ("joint_states", "/joint_states effort"),
    ("dynamic_joint_states", "/dynamic_joint_states current"),
])
def test_each_layout_reads_q_and_current_by_name(two_layouts, layout: str, current: str) -> None:
    stamps, q, v = _record()
    data = bags.read_bag(two_layouts[layout], joints=UR5)
    assert data.positions.names == UR5 and data.current.names == UR5
    np.testing.assert_array_equal(data.positions.position, q)
    np.testing.assert_array_equal(data.current.current, v)
    np.testing.assert_array_equal(data.positions.stamps_ns, stamps)
    np.testing.assert_array_equal(data.current.stamps_ns, stamps)
    assert str(data.sources.position) == "/joint_states position"
    assert str(data.sources.current) == current
    assert data.tags is not None and data.tags.current_source == current
    assert data.warnings == []


def test_extra_joints_are_kept_in_the_hardware_order(two_layouts) -> None:
    stamps, q, v = _record()
    data = bags.read_bag(two_layouts["joint_states"])
    assert data.positions.names == HW_ORDER
    g = HW_ORDER.index("gripper_finger_joint")
    np.testing.assert_array_equal(data.positions.position[:, g], 0.02)
    assert np.isnan(data.current.current[:, g]).all()  # no current interface: NaN effort
    # the DynamicJointState's gripper has no current: it is not among the current's joints
    dyn = bags.read_bag(two_layouts["dynamic_joint_states"])
    assert dyn.current.names == tuple(j for j in HW_ORDER if j != "gripper_finger_joint")
    k = dyn.current.names.index("elbow_joint")
    np.testing.assert_array_equal(dyn.current.current[:, k], v[:, UR5.index("elbow_joint")])


def test_the_same_record_from_effort_and_from_the_interface_is_identical(two_layouts) -> None:
    a = bags.read_bag(two_layouts["joint_states"], joints=UR5)
    b = bags.read_bag(two_layouts["dynamic_joint_states"], joints=UR5)
    for x, y in ((a.positions, b.positions), (a.current, b.current)):
        assert x.names == y.names
        np.testing.assert_array_equal(x.stamps_ns, y.stamps_ns)
    np.testing.assert_array_equal(a.positions.position, b.positions.position)
    np.testing.assert_array_equal(a.current.current, b.current.current)


def test_interface_beats_effort_and_effort_beats_current_reference(tmp_path: Path) -> None:
    """Untagged bags: the order of preference decides, whatever the effort holds."""
    stamps, q, v = _record()
    torque = 13.0 * v  # an effort that is not the current: the interface must win
    p = _write(tmp_path / "d", "dynamic_joint_states", effort=torque, tag_sources=False)
    data = bags.read_bag(p, joints=UR5)
    assert str(data.sources.current) == "/dynamic_joint_states current"
    np.testing.assert_array_equal(data.current.current, v)
    assert data.tags is not None and data.tags.current_source is None
    # a DynamicJointState without the asked interface falls back to the effort only by default
    with pytest.raises(BagError, match="interface 'voltage' is not in /dynamic_joint_states"):
        bags.read_bag(p, joints=UR5, interface="voltage")
    js = bags.read_bag(_write(tmp_path / "j", "joint_states", tag_sources=False), joints=UR5)
    assert str(js.sources.current) == "/joint_states effort"
    # the Orthoglide's bags: JointState without effort, so the CurrentReference
    orth = bags.write_bag(tmp_path / "o", stamps, q[:, :3], v[:, :3], "unloaded", 0,
                          joint_names=ORTHOGLIDE.joint_names)
    data = bags.read_bag(orth)
    assert str(data.sources.current) == "/orthoglide/current_reference current"
    assert data.current.names == ("q11", "q12", "q13")


def test_nan_effort_is_not_a_current(tmp_path: Path) -> None:
    """joint_state_broadcaster fills effort with NaN for joints without an effort interface."""
    stamps, q, v = _record()
    p = _write(tmp_path / "n", "dynamic_joint_states", effort=np.full_like(v, np.nan),
               tag_sources=False)
    assert str(bags.read_bag(p).sources.current) == "/dynamic_joint_states current"


def test_other_interface_by_argument(tmp_path: Path) -> None:
    stamps, q, v = _record()
    p = _write(tmp_path / "v", "dynamic_joint_states")
    data = bags.read_bag(p, joints=UR5, interface="velocity")  # overrides the tag's source
    assert str(data.sources.current) == "/dynamic_joint_states velocity"
    np.testing.assert_allclose(data.current.current, np.gradient(q, stamps * 1e-9, axis=0))


def test_a_missing_joint_or_interface_is_a_one_line_reason(two_layouts) -> None:
    with pytest.raises(BagError) as exc:
        bags.read_bag(two_layouts["joint_states"], joints=UR5 + ("forearm_joint",))
    assert "joint 'forearm_joint' is not in /joint_states" in str(exc.value)
    assert "\n" not in str(exc.value)
    # the robot's other joints are there: likely a gripper's joint, locked_joints named
    assert "lock it in a robot file (locked_joints" in str(exc.value)
    with pytest.raises(BagError) as exc:  # none of the robot's joints: another robot, no hint
        bags.read_bag(two_layouts["joint_states"], joints=("q11", "q12", "q13"))
    assert "joint 'q11' is not in /joint_states" in str(exc.value)
    assert "locked_joints" not in str(exc.value)
    with pytest.raises(BagError) as exc:
        bags.read_bag(two_layouts["dynamic_joint_states"],
                      joints=("elbow_joint", "gripper_finger_joint"))
    msg = str(exc.value)
    assert "joint 'gripper_finger_joint' has no current in /dynamic_joint_states" in msg
    assert "(it has: position, velocity)" in msg and "\n" not in msg


def test_a_missing_topic_is_a_one_line_reason(tmp_path: Path) -> None:
    stamps, q, v = _record(50)
    w = bags.BagWriter(tmp_path / "dyn_only", bags.BagTags("unloaded", 0.0)).open()
    cid = w.add_topic(DYNAMIC_JOINT_STATES_TOPIC, DYNAMIC_JOINT_STATE_TYPE)
    rows = encode_dynamic_joint_states(UR5, [("current",)] * 6, stamps, {"current": v})
    for k, t in enumerate(stamps):
        w.write(cid, rows[k].tobytes(), int(t))
    w.close()
    with pytest.raises(BagError,
                       match=r"no joint_states topic .* \(found: /dynamic_joint_states\)"):
        bags.read_bag(tmp_path / "dyn_only")
    w = bags.BagWriter(tmp_path / "q_only", bags.BagTags("unloaded", 0.0)).open()
    cid = w.add_topic(ROS2_CONTROL_JOINT_STATES_TOPIC, JOINT_STATE_TYPE)
    rows = encode_joint_states(UR5, stamps, q)
    for k, t in enumerate(stamps):
        w.write(cid, rows[k].tobytes(), int(t))
    w.close()
    with pytest.raises(BagError) as exc:
        bags.read_bag(tmp_path / "q_only")
    assert "no current: /current_reference is missing, /joint_states carries no effort and no " \
           "dynamic_joint_states topic has interface 'current'" in str(exc.value)


def test_the_tag_names_the_sources(tmp_path: Path) -> None:
    """A tag saying the current is the effort is obeyed even with a DynamicJointState present
    (an explicit interface still wins); a tag naming a source the bag lacks is refused."""
    stamps, q, v = _record()
    tags = bags.BagTags.checked("unloaded", 0, current_source="/joint_states effort")
    w = bags.BagWriter(tmp_path / "t", tags).open()
    js = w.add_topic(ROS2_CONTROL_JOINT_STATES_TOPIC, JOINT_STATE_TYPE)
    dj = w.add_topic(DYNAMIC_JOINT_STATES_TOPIC, DYNAMIC_JOINT_STATE_TYPE)
    a = encode_joint_states(UR5, stamps, q, effort=2 * v)
    b = encode_dynamic_joint_states(UR5, [("current",)] * 6, stamps, {"current": v})
    for k, t in enumerate(stamps):
        w.write(js, a[k].tobytes(), int(t))
        w.write(dj, b[k].tobytes(), int(t))
    w.close()
    data = bags.read_bag(tmp_path / "t")
    assert str(data.sources.current) == "/joint_states effort"
    np.testing.assert_array_equal(data.current.current, 2 * v)
    assert bags.read_bag(tmp_path / "t", interface="current").current.current.tolist() == v.tolist()
    bad = bags.BagTags.checked("unloaded", 0, current_source="/robot/dynamic_joint_states current")
    w = bags.BagWriter(tmp_path / "bad", bad).open()
    js = w.add_topic(ROS2_CONTROL_JOINT_STATES_TOPIC, JOINT_STATE_TYPE)
    for k, t in enumerate(stamps[:10]):
        w.write(js, a[k].tobytes(), int(t))
    w.close()
    with pytest.raises(BagError, match="the tag's current_source '/robot/dynamic_joint_states "
                                       "current' names a topic this bag does not hold"):
        bags.read_bag(tmp_path / "bad")


def test_decode_messages_of_each_type() -> None:
    """What the live nodes get from raw subscriptions: the same decoding as the bags'."""
    stamps, q, v = _record(20)
    raw = [r.tobytes() for r in encode_dynamic_joint_states(
        UR5, [("position", "current")] * 6, stamps, {"position": q, "current": v})]
    st, names, vals = decode_messages(raw, DYNAMIC_JOINT_STATE_TYPE)
    assert names == UR5
    np.testing.assert_array_equal(st, stamps)
    np.testing.assert_array_equal(vals, v)
    raw = [r.tobytes() for r in encode_joint_states(UR5, stamps, q, 0 * q, v)]
    _, names, vals = decode_messages(raw, JOINT_STATE_TYPE, "effort")
    np.testing.assert_array_equal(vals, v)
    _, _, vals = decode_messages(raw, JOINT_STATE_TYPE)
    np.testing.assert_array_equal(vals, q)


def test_cli_info_shows_the_sources(two_layouts, capsys) -> None:
    from orthoglide_ident.cli import main

    assert main(["info", str(two_layouts["dynamic_joint_states"])]) == 0
    out = capsys.readouterr().out
    assert "q:         /joint_states position (JointState)" in out
    assert "current:   /dynamic_joint_states interface 'current' (DynamicJointState)" in out
