"""orthoglide_ident.bags: tagged rosbag2/MCAP writing, fast reading, crash tolerance, info."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from orthoglide_ident import bags
from orthoglide_ident.bags.encoding import encode_messages
from orthoglide_ident.bags.info import find_gaps
from orthoglide_ident.bags.topics import (
    CURRENT_REFERENCE_TOPIC,
    CURRENT_REFERENCE_TYPE,
    JOINT_STATE_TYPE,
    JOINT_STATES_TOPIC,
    msgdef_and_hash,
)
from orthoglide_ident.errors import BagError, DataError
from orthoglide_ident.model.registry import load_robot

ORTHOGLIDE = load_robot("orthoglide")  # the robot these records are of

NAMES = ("q11", "q12", "q13")
T0 = 1_700_000_000_000_000_000


def _record(n: int = 3000, seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    stamps = T0 + np.arange(n, dtype=np.int64) * 1_000_000
    return stamps, rng.normal(size=(n, 3)) * 0.05, rng.normal(size=(n, 3))


@pytest.fixture(scope="module")
def loaded_bag(
    tmp_path_factory: pytest.TempPathFactory,
) -> tuple[Path, np.ndarray, np.ndarray, np.ndarray]:
    stamps, q, v = _record()
    path = bags.write_bag(
        tmp_path_factory.mktemp("b") / "loaded",
        stamps,
        q,
        v,
        "loaded",
        1.136,
        extra={"sim.seed": "0"}, joint_names=ORTHOGLIDE.joint_names
    )
    return path, stamps, q, v


def test_round_trip_exact(loaded_bag) -> None:
    path, stamps, q, v = loaded_bag
    data = bags.read_bag(path)
    assert data.tags == bags.BagTags("loaded", 1.136)
    assert data.warnings == []
    assert data.joint_states.names == NAMES and data.current_reference.names == NAMES
    np.testing.assert_array_equal(data.joint_states.stamps_ns, stamps)
    np.testing.assert_array_equal(data.current_reference.stamps_ns, stamps)
    np.testing.assert_array_equal(data.joint_states.position, q)
    np.testing.assert_array_equal(data.current_reference.current, v)
    assert data.joint_states.stamps_ns.dtype == np.int64


def test_layout_and_tags_on_disk(loaded_bag) -> None:
    path = loaded_bag[0]
    meta = yaml.safe_load((path / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert meta["version"] == 9 and meta["storage_identifier"] == "mcap"
    assert meta["custom_data"]["orthoglide.condition"] == "loaded"
    assert meta["custom_data"]["orthoglide.payload_mass"] == "1.136"
    assert meta["custom_data"]["sim.seed"] == "0"
    topics = {t["topic_metadata"]["name"]: t for t in meta["topics_with_message_count"]}
    assert topics[JOINT_STATES_TOPIC]["message_count"] == 3000
    assert topics[CURRENT_REFERENCE_TOPIC]["topic_metadata"][
        "type_description_hash"
    ].startswith("RIHS01_")
    assert (
        topics[JOINT_STATES_TOPIC]["topic_metadata"]["offered_qos_profiles"][0]["reliability"]
        == "reliable"
    )


def test_mcap_library_reads_with_crcs(loaded_bag) -> None:
    from mcap.reader import make_reader
    from mcap.stream_reader import StreamReader

    (mcap_file,) = loaded_bag[0].glob("*.mcap")
    with mcap_file.open("rb") as fh:
        reader = make_reader(fh, validate_crcs=True)
        summary = reader.get_summary()
        assert summary is not None and summary.statistics.message_count == 6000
        assert summary.chunk_indexes and all(c.compression == "zstd" for c in summary.chunk_indexes)
        assert {s.name for s in summary.schemas.values()} == {
            JOINT_STATE_TYPE,
            CURRENT_REFERENCE_TYPE,
        }
        assert all("offered_qos_profiles" in c.metadata for c in summary.channels.values())
        meta = [(m.name, m.metadata) for m in reader.iter_metadata()]
        assert (
            "orthoglide",
            {"orthoglide.condition": "loaded", "orthoglide.payload_mass": "1.136"},
        ) in meta
        assert sum(1 for _ in reader.iter_messages()) == 6000
    with mcap_file.open("rb") as fh:  # streaming read validates the data-section and summary CRCs
        assert sum(1 for _ in StreamReader(fh, validate_crcs=True).records) > 6000


def test_rosbags_reads_and_agrees(loaded_bag) -> None:
    from rosbags.highlevel import AnyReader

    path, stamps, q, v = loaded_bag
    with AnyReader([path]) as reader:
        conns = {c.topic: c for c in reader.connections}
        assert (
            conns[CURRENT_REFERENCE_TOPIC].digest
            == msgdef_and_hash(CURRENT_REFERENCE_TYPE)[1]
        )
        got = [
            reader.deserialize(raw, c.msgtype)
            for c, _, raw in reader.messages(connections=[conns[CURRENT_REFERENCE_TOPIC]])
        ]
    assert len(got) == len(stamps)
    np.testing.assert_array_equal(np.array([m.current for m in got]), v)
    assert got[5].header.stamp.sec * 10**9 + got[5].header.stamp.nanosec == stamps[5]


def test_lone_mcap_keeps_tag(loaded_bag) -> None:
    (mcap_file,) = loaded_bag[0].glob("*.mcap")
    data = bags.read_bag(mcap_file)
    assert data.tags == bags.BagTags("loaded", 1.136)
    assert len(data.joint_states.stamps_ns) == 3000


@pytest.mark.parametrize("fraction", [0.5, 0.8])
def test_truncated_file_read_to_last_chunk(loaded_bag, tmp_path: Path, fraction: float) -> None:
    (mcap_file,) = loaded_bag[0].glob("*.mcap")
    raw = mcap_file.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(raw[: int(len(raw) * fraction)])
    data = bags.read_bag(cut)
    n = len(data.joint_states.stamps_ns)
    assert 0 < n < 3000 and n % 500 == 0  # whole 0.5 s chunks
    np.testing.assert_array_equal(data.joint_states.position, loaded_bag[2][:n])
    assert (
        len(data.warnings) == 1
        and "cut.mcap" in data.warnings[0]
        and "not closed" in data.warnings[0]
    )
    info = bags.bag_info(cut)
    assert not info.closed and "NOT CLOSED" in info.to_text()


def test_lost_summary_only(loaded_bag, tmp_path: Path) -> None:
    (mcap_file,) = loaded_bag[0].glob("*.mcap")
    cut = tmp_path / "nosummary.mcap"
    cut.write_bytes(mcap_file.read_bytes()[:-30])
    data = bags.read_bag(cut)
    assert len(data.joint_states.stamps_ns) == 3000
    assert "summary" in data.warnings[0]


@pytest.mark.parametrize(
    "content, reason",
    [
        (b"", "empty"),
        (b"hello, not a bag", "not an MCAP"),
        (b"\x89MCAP0\r\n\x01\x00", "nothing readable"),
    ],
)
def test_unreadable_file(tmp_path: Path, content: bytes, reason: str) -> None:
    f = tmp_path / "x.mcap"
    f.write_bytes(content)
    with pytest.raises(BagError, match=reason) as exc:
        bags.read_bag(f)
    assert "\n" not in str(exc.value)
    with pytest.raises(BagError):
        bags.bag_info(f)


def test_no_such_bag(tmp_path: Path) -> None:
    with pytest.raises(BagError, match="no such bag"):
        bags.read_bag(tmp_path / "nope")


def _stream_bag(
    path: Path, tags: bags.BagTags, topics: tuple[str, ...], n: int = 200, **kw
) -> bags.BagWriter:
    stamps, q, v = _record(n)
    w = bags.BagWriter(path, tags, **kw).open()
    enc = {
        JOINT_STATES_TOPIC: encode_messages(JOINT_STATE_TYPE, NAMES, stamps, q),
        CURRENT_REFERENCE_TOPIC: encode_messages(
            CURRENT_REFERENCE_TYPE, NAMES, stamps, v
        ),
    }
    types = {
        JOINT_STATES_TOPIC: JOINT_STATE_TYPE,
        CURRENT_REFERENCE_TOPIC: CURRENT_REFERENCE_TYPE,
    }
    cids = {t: w.add_topic(t, types[t]) for t in topics}
    for i in range(n):
        for t in topics:
            w.write(cids[t], enc[t][i].tobytes(), int(stamps[i]))
    w.close()
    return w


def test_missing_topic(tmp_path: Path) -> None:
    _stream_bag(tmp_path / "b", bags.BagTags("unloaded", 0.0), (JOINT_STATES_TOPIC,))
    with pytest.raises(BagError, match="/orthoglide/current_reference is missing"):
        bags.read_bag(tmp_path / "b")


def test_untagged_and_contradictory(tmp_path: Path) -> None:
    topics = (JOINT_STATES_TOPIC, CURRENT_REFERENCE_TOPIC)
    _stream_bag(tmp_path / "b", bags.BagTags("unloaded", 0.0), topics)
    meta = tmp_path / "b" / "metadata.yaml"
    doc = yaml.safe_load(meta.read_text())
    doc["rosbag2_bagfile_information"]["custom_data"] = {
        "orthoglide.condition": "loaded",
        "orthoglide.payload_mass": "2.0",
    }
    meta.write_text(yaml.safe_dump(doc))
    with pytest.raises(BagError, match="contradictory tags"):
        bags.read_bag(tmp_path / "b")
    # without any tag: clear message, and readable when tags are not required
    _stream_bag(tmp_path / "d", bags.BagTags("unloaded", 0.0), topics)
    for f in (tmp_path / "d").glob(
        "*.mcap"
    ):  # strip the metadata record's keys by rewriting the name
        raw = f.read_bytes().replace(b"orthoglide.condition", b"xrthoglide.condition")
        raw = raw.replace(b"orthoglide.payload_mass", b"xrthoglide.payload_mass")
        f.write_bytes(raw)
    doc_d = yaml.safe_load((tmp_path / "d" / "metadata.yaml").read_text())
    doc_d["rosbag2_bagfile_information"]["custom_data"] = None
    (tmp_path / "d" / "metadata.yaml").write_text(yaml.safe_dump(doc_d))
    with pytest.raises(BagError, match="not tagged"):
        bags.read_bag(tmp_path / "d")
    assert bags.read_bag(tmp_path / "d", require_tags=False).tags is None


@pytest.mark.parametrize("condition, mass", [("heavy", 1.0), ("loaded", 0.0), ("unloaded", 1.0)])
def test_bad_tags_rejected(tmp_path: Path, condition: str, mass: float) -> None:
    stamps, q, v = _record(10)
    with pytest.raises(Exception, match="condition|payload_mass"):
        bags.write_bag(tmp_path / "b", stamps, q, v, condition, mass,
                       joint_names=ORTHOGLIDE.joint_names)


def test_write_bag_checks_input(tmp_path: Path) -> None:
    stamps, q, v = _record(10)
    with pytest.raises(DataError):
        bags.write_bag(tmp_path / "b", stamps[::-1], q, v, "unloaded", 0,
                       joint_names=ORTHOGLIDE.joint_names)
    with pytest.raises(DataError):
        bags.write_bag(tmp_path / "b", stamps, q[:, :2], v, "unloaded", 0,
                       joint_names=ORTHOGLIDE.joint_names)


def test_split_loses_nothing(tmp_path: Path) -> None:
    topics = (JOINT_STATES_TOPIC, CURRENT_REFERENCE_TOPIC)
    w = _stream_bag(
        tmp_path / "s",
        bags.BagTags("unloaded", 0.0),
        topics,
        n=2000,
        chunk_duration_s=0.1,
        split_duration_s=0.5,
    )
    files = sorted((tmp_path / "s").glob("*.mcap"))
    assert len(files) == 4 and [f.name for f in files] == [f"s_{i}.mcap" for i in range(4)]
    data = bags.read_bag(tmp_path / "s")
    np.testing.assert_array_equal(data.joint_states.stamps_ns, _record(2000)[0])
    assert len(data.current_reference.stamps_ns) == 2000
    assert w.counts == {JOINT_STATES_TOPIC: 2000, CURRENT_REFERENCE_TOPIC: 2000}
    for f in files:  # every part carries the tag
        assert bags.read_bag(f).tags == bags.BagTags("unloaded", 0.0)
    from rosbags.highlevel import AnyReader

    with AnyReader([tmp_path / "s"]) as reader:
        assert sum(1 for _ in reader.messages()) == 4000


def test_gaps_reported(tmp_path: Path) -> None:
    stamps, q, v = _record(1000)
    keep = np.ones(1000, bool)
    keep[[100, 500, 501, 502]] = False
    bags.write_bag(tmp_path / "g", stamps[keep], q[keep], v[keep], "unloaded", 0,
                   joint_names=ORTHOGLIDE.joint_names)
    info = bags.bag_info(tmp_path / "g")
    js = next(t for t in info.topics if t.topic == JOINT_STATES_TOPIC)
    assert js.gaps is not None and js.gaps.missing == 4
    assert [n for _, n in js.gaps.where] == [1, 3]
    assert info.closed and "4 missing ticks" in info.to_text()
    assert find_gaps(stamps).missing == 0


def test_other_layouts_fall_back(tmp_path: Path) -> None:
    """Messages from rclpy, with a frame id, velocities, or reordered names decode the same."""

    store = bags.topics.typestore()
    T, H = store.types["builtin_interfaces/msg/Time"], store.types["std_msgs/msg/Header"]
    JS = store.types[JOINT_STATE_TYPE]
    CR = store.types[CURRENT_REFERENCE_TYPE]
    stamps, q, v = _record(20)
    w = bags.BagWriter(tmp_path / "o", bags.BagTags("unloaded", 0.0)).open()
    a = w.add_topic(JOINT_STATES_TOPIC, JOINT_STATE_TYPE)
    b = w.add_topic(CURRENT_REFERENCE_TOPIC, CURRENT_REFERENCE_TYPE)
    for i, t in enumerate(stamps):
        hdr = H(
            stamp=T(sec=int(t // 10**9), nanosec=int(t % 10**9)), frame_id="base" if i % 3 else ""
        )
        order = [2, 0, 1] if i % 5 == 4 else [0, 1, 2]
        js = JS(
            header=hdr,
            name=[NAMES[k] for k in order],
            position=q[i, order],
            velocity=np.ones(3) if i % 2 else np.zeros(0),
            effort=np.zeros(0),
        )
        w.write(a, bytes(store.serialize_cdr(js, JOINT_STATE_TYPE)), int(t))
        cr = CR(header=hdr, name=list(NAMES), current=v[i])
        w.write(b, bytes(store.serialize_cdr(cr, CURRENT_REFERENCE_TYPE)), int(t))
    w.close()
    data = bags.read_bag(tmp_path / "o")
    np.testing.assert_array_equal(data.joint_states.position, q)
    np.testing.assert_array_equal(data.current_reference.current, v)
    np.testing.assert_array_equal(data.joint_states.stamps_ns, stamps)


def test_rclpy_serialisation_matches(tmp_path: Path) -> None:
    """rclpy's CDR (garbage padding, trailing bytes) reads back (its bulk layout: test_cdr.py);
    ours deserialises in rclpy."""
    from rclpy import serialization as rclpy_ser
    from sensor_msgs.msg import JointState

    stamps, q, v = _record(50)
    raws = []
    for t, row in zip(stamps, q):
        msg = JointState()
        msg.header.stamp.sec, msg.header.stamp.nanosec = int(t // 10**9), int(t % 10**9)
        msg.name = list(NAMES)
        msg.position = row.tolist()
        raws.append(rclpy_ser.serialize_message(msg))
    w = bags.BagWriter(tmp_path / "r", bags.BagTags("unloaded", 0.0)).open()
    a = w.add_topic(JOINT_STATES_TOPIC, JOINT_STATE_TYPE)
    b = w.add_topic(CURRENT_REFERENCE_TOPIC, CURRENT_REFERENCE_TYPE)
    cr = encode_messages(CURRENT_REFERENCE_TYPE, NAMES, stamps, v)
    for i, raw in enumerate(raws):
        w.write(a, raw, int(stamps[i]))
        w.write(b, cr[i].tobytes(), int(stamps[i]))
    w.close()
    data = bags.read_bag(tmp_path / "r")
    np.testing.assert_array_equal(data.joint_states.position, q)
    np.testing.assert_array_equal(data.joint_states.stamps_ns, stamps)
    ours = encode_messages(JOINT_STATE_TYPE, NAMES, stamps[:1], q[:1])[0].tobytes()
    back = rclpy_ser.deserialize_message(ours, JointState)
    assert list(back.name) == list(NAMES) and np.array_equal(back.position, q[0])
