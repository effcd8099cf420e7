"""ros2_control bags both ways, and without any compiled or embedded type.

Our reader on a bag written by rosbags' own rosbag2 writer (frame ids, velocities, interfaces in
changing orders: the bulk decoder's several layouts and its one-by-one fallback), in a process
where the compiled interface packages cannot be imported and the bag code knows nothing of
control_msgs: the types come from the schemas in the MCAP file. Other readers on our ros2_control
bags: rosbags (types from the bag, hashes those of a real install) and the MCAP library with CRCs.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from orthoglide_ident import bags
from orthoglide_ident.bags.topics import DYNAMIC_JOINT_STATE_TYPE, JOINT_STATE_TYPE

ROOT = Path(__file__).resolve().parents[2]
JOINTS = ("joint_a", "joint_b", "joint_c")
HW = ("joint_c", "tool_changer", "joint_a", "joint_b")  # the hardware's order, an extra joint
T0 = 1_700_000_000_000_000_000
N = 1200
DJS_HASH = "RIHS01_18024c98a62697680f581108eeed40b28fb4542fa0ac5a8e36f56c62b6813d26"


def _record() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(11)
    return T0 + np.arange(N, dtype=np.int64) * 1_000_000, rng.normal(size=(N, 3)), rng.normal(
        size=(N, 3))


def _store_from_msg_files():
    """A Jazzy typestore plus control_msgs from msg_defs/*.msg: independent of bags._types."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.ROS2_JAZZY)
    for name in ("InterfaceValue", "DynamicJointState"):
        text = (ROOT / "msg_defs/control_msgs/msg" / f"{name}.msg").read_text()
        store.register(get_types_from_msg(text, f"control_msgs/msg/{name}"))
    return store


@pytest.fixture(scope="module")
def rosbags_bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """/joint_states + /dynamic_joint_states as rosbags writes them, message by message."""
    from rosbags.rosbag2 import StoragePlugin, Writer

    store = _store_from_msg_files()
    T, H = store.types["builtin_interfaces/msg/Time"], store.types["std_msgs/msg/Header"]
    JS, DJS = store.types[JOINT_STATE_TYPE], store.types[DYNAMIC_JOINT_STATE_TYPE]
    IV = store.types["control_msgs/msg/InterfaceValue"]
    stamps, q, v = _record()
    col = {j: JOINTS.index(j) for j in JOINTS}
    path = tmp_path_factory.mktemp("rb") / "ur"
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        w.set_custom_data("orthoglide.condition", "unloaded")
        w.set_custom_data("orthoglide.payload_mass", "0")
        a = w.add_connection("/joint_states", JOINT_STATE_TYPE, typestore=store)
        b = w.add_connection("/dynamic_joint_states", DYNAMIC_JOINT_STATE_TYPE,
                             typestore=store)
        for i, t in enumerate(stamps.tolist()):
            hdr = H(stamp=T(sec=t // 10**9, nanosec=t % 10**9),
                    frame_id="base_link" if i % 400 < 200 else "")
            pos = np.array([q[i, col[j]] if j in col else 0.5 for j in HW])
            js = JS(header=hdr, name=list(HW), position=pos, velocity=np.zeros(4),
                    effort=np.full(4, np.nan))
            ivs = []
            for j in HW:
                if j not in col:
                    ivs.append(IV(interface_names=["position"], values=np.array([0.5])))
                    continue
                names, vals = ["position", "current"], [q[i, col[j]], v[i, col[j]]]
                if i % 7 == 3:  # another shape now and then
                    names, vals = names[::-1], vals[::-1]
                if i % 31 == 5:  # one-off interfaces, more shapes than the bulk decoder caches
                    names, vals = names + [f"temperature_{i:04d}"], vals + [40.0]
                ivs.append(IV(interface_names=names, values=np.array(vals)))
            w.write(a, t, bytes(store.serialize_cdr(js, JOINT_STATE_TYPE)))
            w.write(b, t + 1, bytes(store.serialize_cdr(DJS(header=hdr, joint_names=list(HW),
                                                            interface_values=ivs),
                                                        DYNAMIC_JOINT_STATE_TYPE)))
    return path


NO_TYPES = r"""
import json, sys

class NoCompiledTypes:
    blocked = {"rclpy", "control_msgs", "sensor_msgs", "std_msgs", "builtin_interfaces",
               "trajectory_msgs", "orthoglide_msgs"}
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in self.blocked:
            raise ImportError(f"{name} is made unimportable by this test")
        return None

sys.meta_path.insert(0, NoCompiledTypes())
# private on purpose: the embedded definitions taken away (an install without them), no public way
from orthoglide_ident.bags import _types
for name in [k for k in _types.EMBEDDED_MSGS if k.startswith("control_msgs/")]:
    del _types.EMBEDDED_MSGS[name]
_types._find_msg_file = lambda msgtype: None  # no .msg file anywhere either
from orthoglide_ident import bags

data = bags.read_bag(sys.argv[1], joints=["joint_a", "joint_b", "joint_c"])
assert "control_msgs/msg/DynamicJointState" not in _types.typestore().types
blocked = [m for m in sys.modules if m.split(".")[0] in NoCompiledTypes.blocked]
print(json.dumps({"source": str(data.sources.current), "blocked_imported": blocked,
                  "stamps": data.current.stamps_ns.tolist(), "q": data.positions.position.tolist(),
                  "current": data.current.current.tolist(), "warnings": data.warnings}))
"""


def test_reads_a_real_writers_bag_without_compiled_types(rosbags_bag: Path) -> None:
    done = subprocess.run([sys.executable, "-c", NO_TYPES, str(rosbags_bag)],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-3000:]
    got = json.loads(done.stdout.strip().splitlines()[-1])
    stamps, q, v = _record()
    assert got["source"] == "/dynamic_joint_states current" and got["blocked_imported"] == []
    assert got["warnings"] == []
    np.testing.assert_array_equal(np.array(got["stamps"]), stamps)
    np.testing.assert_array_equal(np.array(got["q"]), q)  # exact: no value passes through text
    np.testing.assert_array_equal(np.array(got["current"]), v)


def test_bulk_and_one_by_one_paths_agree(rosbags_bag: Path, monkeypatch) -> None:
    """Here too (types known): every message once, in stamp order, whichever path decoded it;
    most in bulk (several layouts), the shapes beyond the cache one by one."""
    from orthoglide_ident.bags import _decode  # private on purpose: counts its one-by-one path

    one_by_one: list[int] = []
    slow = _decode.decode_rows

    def counted(series, rows):
        rows = list(rows)
        one_by_one.append(len(rows))
        return slow(series, rows)

    monkeypatch.setattr(_decode, "decode_rows", counted)
    stamps, q, v = _record()
    data = bags.read_bag(rosbags_bag)
    assert 0 < sum(one_by_one) < N // 20
    assert data.current.names == ("joint_c", "joint_a", "joint_b")
    np.testing.assert_array_equal(data.current.current, v[:, [2, 0, 1]])
    np.testing.assert_array_equal(data.positions.position[:, 1], 0.5)  # the extra joint
    info = bags.bag_info(rosbags_bag)
    assert {t.topic: t.gaps.missing for t in info.topics} == {
        "/joint_states": 0, "/dynamic_joint_states": 0}
    assert "current:   /dynamic_joint_states interface 'current' (DynamicJointState)" in \
        info.to_text()


@pytest.fixture(scope="module")
def our_bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    stamps, q, v = _record()
    return bags.write_bag(tmp_path_factory.mktemp("ours") / "ur", stamps, q, v, "loaded", 1.5,
                          JOINTS, layout="dynamic_joint_states", joint_order=HW,
                          extra_joints={"tool_changer": 0.5}, payload={"payload_frame": "tool0"})


def test_rosbags_reads_our_ros2_control_bag(our_bag: Path) -> None:
    from rosbags.highlevel import AnyReader

    stamps, q, v = _record()
    with AnyReader([our_bag]) as reader:
        conns = {c.topic: c for c in reader.connections}
        assert conns["/dynamic_joint_states"].digest == DJS_HASH  # a real install's hash
        assert reader.message_count == 2 * N
        rows = [reader.deserialize(raw, c.msgtype) for c, _, raw in
                reader.messages(connections=[conns["/dynamic_joint_states"]])]
    assert [list(m.joint_names) for m in rows[:1]] == [list(HW)]
    assert [list(iv.interface_names) for iv in rows[0].interface_values] == [
        ["position", "velocity", "current"], ["position", "velocity"],
        ["position", "velocity", "current"], ["position", "velocity", "current"]]
    current = np.array([[m.interface_values[k].values[2] for k in (2, 3, 0)] for m in rows])
    np.testing.assert_array_equal(current, v)
    np.testing.assert_array_equal([m.header.stamp.sec * 10**9 + m.header.stamp.nanosec
                                   for m in rows], stamps)


def test_mcap_library_reads_our_ros2_control_bag_with_crcs(our_bag: Path) -> None:
    from mcap.reader import make_reader

    (f,) = our_bag.glob("*.mcap")
    with f.open("rb") as fh:
        reader = make_reader(fh, validate_crcs=True)
        summary = reader.get_summary()
        assert summary is not None
        assert {s.name for s in summary.schemas.values()} == {JOINT_STATE_TYPE,
                                                               DYNAMIC_JOINT_STATE_TYPE}
        assert {c.topic: c.metadata["topic_type_hash"] for c in summary.channels.values()}[
            "/dynamic_joint_states"] == DJS_HASH
        times = [m.log_time for _, _, m in reader.iter_messages(log_time_order=False)]
    assert len(times) == 2 * N and times == sorted(times)
