"""Bags both ways: our reader on other writers' files, other readers on our files.

Other writers: rosbags (rosbag2 v9, MCAP storage) and the official MCAP library (zstd, lz4, no
compression, no message index, unchunked, cut short). Other readers: rosbags and the MCAP library
with every CRC validated, plus the checks ``mcap doctor --strict-message-order`` makes (log times
never decrease in file order), the layout rosbag2's MCAP plugin writes (schemas and channels in the
chunks, ``rosbag2`` and ``orthoglide`` metadata records), and the message definition and type hash
of orthoglide_msgs/msg/CurrentReference against what rosidl generated into the venv.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from orthoglide_ident import bags
from orthoglide_ident.bags import topics
from orthoglide_ident.bags.encoding import encode_messages

NAMES = ("q11", "q12", "q13")
T0 = 1_700_000_000_000_000_000
N = 1500  # ticks: 1.5 s at 1 kHz, three 0.5 s chunks


def _record(n: int = N, seed: int = 1) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    return T0 + np.arange(n, dtype=np.int64) * 1_000_000, rng.normal(size=(n, 3)), rng.normal(
        size=(n, 3)
    )


def _encoded(stamps: np.ndarray, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return (
        encode_messages(topics.JOINT_STATE_TYPE, NAMES, stamps, q),
        encode_messages(topics.CURRENT_REFERENCE_TYPE, NAMES, stamps, v),
    )


def _assert_same(data: bags.BagData, stamps: np.ndarray, q: np.ndarray, v: np.ndarray) -> None:
    n = len(data.joint_states.stamps_ns)
    np.testing.assert_array_equal(data.joint_states.stamps_ns, stamps[:n])
    np.testing.assert_array_equal(data.current_reference.stamps_ns, stamps[:n])
    np.testing.assert_array_equal(data.joint_states.position, q[:n])
    np.testing.assert_array_equal(data.current_reference.current, v[:n])


# -- our reader on other writers' bags -----------------------------------------------------------
def test_reads_rosbags_mcap_bag(tmp_path: Path) -> None:
    from rosbags.rosbag2 import StoragePlugin, Writer

    stamps, q, v = _record()
    js, cr = _encoded(stamps, q, v)
    store = bags.topics.typestore()
    path = tmp_path / "rb"
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        w.set_custom_data("orthoglide.condition", "loaded")
        w.set_custom_data("orthoglide.payload_mass", "1.136")
        a = w.add_connection(topics.JOINT_STATES_TOPIC, topics.JOINT_STATE_TYPE, typestore=store)
        b = w.add_connection(
            topics.CURRENT_REFERENCE_TOPIC, topics.CURRENT_REFERENCE_TYPE, typestore=store
        )
        for i, t in enumerate(stamps.tolist()):
            w.write(a, t, js[i].tobytes())
            w.write(b, t, cr[i].tobytes())
    data = bags.read_bag(path)
    assert data.tags == bags.BagTags("loaded", 1.136) and data.warnings == []
    assert len(data.joint_states.stamps_ns) == N
    _assert_same(data, stamps, q, v)


def _mcap_file(path: Path, compression: str, index: bool = True, chunked: bool = True) -> None:
    """A tagged ros2-profile file written directly with the official MCAP writer."""
    from mcap.writer import CompressionType, IndexType, Writer

    stamps, q, v = _record()
    js, cr = _encoded(stamps, q, v)
    kinds = {"zstd": CompressionType.ZSTD, "lz4": CompressionType.LZ4, "": CompressionType.NONE}
    with path.open("wb") as fh:
        w = Writer(
            fh,
            chunk_size=64 * 1024,
            compression=kinds[compression],
            index_types=IndexType.ALL if index else IndexType.CHUNK,
            use_chunking=chunked,
        )
        w.start("ros2", "test")
        w.add_metadata("orthoglide", bags.BagTags("unloaded", 0.0).to_dict())
        channels = []
        for topic, msgtype in (
            (topics.JOINT_STATES_TOPIC, topics.JOINT_STATE_TYPE),
            (topics.CURRENT_REFERENCE_TOPIC, topics.CURRENT_REFERENCE_TYPE),
        ):
            sid = w.register_schema(msgtype, "ros2msg", topics.msgdef_and_hash(msgtype)[0].encode())
            channels.append(w.register_channel(topic, "cdr", sid))
        for i, t in enumerate(stamps.tolist()):
            w.add_message(channels[0], t, js[i].tobytes(), t, i)
            w.add_message(channels[1], t, cr[i].tobytes(), t, i)
        w.finish()


@pytest.mark.parametrize(
    "compression, index, chunked",
    [("zstd", True, True), ("lz4", True, True), ("", True, True), ("zstd", False, True),
     ("", False, False)],
    ids=["zstd", "lz4", "none", "no-message-index", "unchunked"],
)
def test_reads_mcap_library_files(
    tmp_path: Path, compression: str, index: bool, chunked: bool
) -> None:
    f = tmp_path / "lib.mcap"
    _mcap_file(f, compression, index, chunked)
    data = bags.read_bag(f)
    assert data.tags == bags.BagTags("unloaded", 0.0) and data.warnings == []
    assert len(data.joint_states.stamps_ns) == N
    _assert_same(data, *_record())


def test_reads_mcap_library_file_cut_short(tmp_path: Path) -> None:
    f = tmp_path / "lib.mcap"
    _mcap_file(f, "zstd")
    raw = f.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(raw[: len(raw) * 2 // 3])
    data = bags.read_bag(cut)
    n = len(data.joint_states.stamps_ns)
    assert 0 < n < N
    _assert_same(data, *_record())
    assert len(data.warnings) == 1 and "cut.mcap" in data.warnings[0]
    assert "not closed" in data.warnings[0]


# -- other readers on our bags -------------------------------------------------------------------
@pytest.fixture(scope="module")
def split_bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A recorder-like bag: streaming writer, best-effort QoS on one topic, 3 split files."""
    stamps, q, v = _record()
    js, cr = _encoded(stamps, q, v)
    path = tmp_path_factory.mktemp("ours") / "split"
    w = bags.BagWriter(path, bags.BagTags("loaded", 2.5), chunk_duration_s=0.1,
                       split_duration_s=0.5, custom_data={"note": "interop"}).open()
    a = w.add_topic(topics.JOINT_STATES_TOPIC, topics.JOINT_STATE_TYPE,
                    qos=[topics.qos_profile("best_effort", depth=10, history="keep_last")])
    b = w.add_topic(topics.CURRENT_REFERENCE_TOPIC, topics.CURRENT_REFERENCE_TYPE)
    for i, t in enumerate(stamps.tolist()):
        w.write(a, js[i].tobytes(), t + 20_000, t + 10_000)  # received 20 µs after the tick
        w.write(b, cr[i].tobytes(), t + 30_000, t + 10_000)
    w.close()
    return path


def test_rosbags_reads_our_split_bag(split_bag: Path) -> None:
    from rosbags.highlevel import AnyReader
    from rosbags.interfaces import QosReliability

    stamps, q, v = _record()
    with AnyReader([split_bag]) as reader:
        conns = {c.topic: c for c in reader.connections}
        assert reader.message_count == 2 * N
        assert conns[topics.CURRENT_REFERENCE_TOPIC].digest == topics.msgdef_and_hash(
            topics.CURRENT_REFERENCE_TYPE)[1]
        qos = conns[topics.JOINT_STATES_TOPIC].ext.offered_qos_profiles
        assert qos[0].reliability == QosReliability.BEST_EFFORT and qos[0].depth == 10
        got = [reader.deserialize(raw, c.msgtype).position
               for c, _, raw in reader.messages(connections=[conns[topics.JOINT_STATES_TOPIC]])]
    np.testing.assert_array_equal(np.array(got), q)


def _strict_order(f: Path) -> list:
    """Every record of a file, chunks expanded, CRCs validated; asserts that log times never
    decrease in file order and that chunks do not overlap in time (mcap doctor's strict check)."""
    from mcap.records import Chunk, Message
    from mcap.stream_reader import StreamReader

    with f.open("rb") as fh:
        records = list(StreamReader(fh, validate_crcs=True, emit_chunks=True).records)
    last_log, last_chunk_end = 0, 0
    for r in records:
        if isinstance(r, Chunk):
            assert r.uncompressed_crc != 0, "chunk CRCs are written"
            assert r.message_start_time >= last_chunk_end, f"{f.name}: chunks overlap in time"
            last_chunk_end = r.message_end_time
    with f.open("rb") as fh:
        for r in StreamReader(fh, validate_crcs=True).records:
            if isinstance(r, Message):
                assert r.log_time >= last_log, f"{f.name}: log time goes back in file order"
                last_log = r.log_time
    return records


def test_mcap_library_reads_our_files_strictly(split_bag: Path) -> None:
    from mcap.reader import make_reader
    from mcap.records import Channel, DataEnd, Metadata, Schema

    files = sorted(split_bag.glob("*.mcap"))
    assert [f.name for f in files] == [f"split_{i}.mcap" for i in range(3)]
    total = 0
    for f in files:
        records = _strict_order(f)
        data_section = records[: next(i for i, r in enumerate(records) if isinstance(r, DataEnd))]
        # rosbag2's layout: schemas and channels only inside the chunks of the data section
        assert not any(isinstance(r, (Schema, Channel)) for r in data_section)
        names = [r.name for r in data_section if isinstance(r, Metadata)]
        assert names[:2] == ["orthoglide", "rosbag2"] and names[-1] == "rosbag2"
        with f.open("rb") as fh:
            reader = make_reader(fh, validate_crcs=True)
            assert reader.get_header().profile == "ros2"
            summary = reader.get_summary()
            assert summary is not None and summary.statistics.chunk_count >= 5
            assert all(c.message_index_offsets for c in summary.chunk_indexes)
            times = [m.log_time for _, _, m in reader.iter_messages(log_time_order=False)]
            assert times == sorted(times)
            total += len(times)
    assert total == 2 * N


def test_rosbag2_record_holds_the_bag_metadata(split_bag: Path) -> None:
    from mcap.reader import make_reader

    info = yaml.safe_load((split_bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert info["custom_data"] == {"note": "interop", "orthoglide.condition": "loaded",
                                   "orthoglide.payload_mass": "2.5"}
    for i, f in enumerate(sorted(split_bag.glob("*.mcap"))):
        with f.open("rb") as fh:
            records = [m for m in make_reader(fh).iter_metadata() if m.name == "rosbag2"]
        assert all(list(m.metadata) == ["serialized_metadata"] for m in records)
        first, last = (yaml.safe_load(m.metadata["serialized_metadata"]) for m in (records[0],
                                                                                   records[-1]))
        assert first["version"] == 9 and first["custom_data"] == info["custom_data"]
        assert first["relative_file_paths"][-1] == f.name  # written when the file was opened
        assert last["relative_file_paths"][: i + 1] == info["relative_file_paths"][: i + 1]
    assert last == info  # the last file's closing record: exactly metadata.yaml


def test_current_reference_definition_matches_rosidl() -> None:
    share = Path(sys.prefix) / "share" / "orthoglide_msgs" / "msg"
    msg_file = share / "CurrentReference.msg"
    assert msg_file.is_file(), "orthoglide_msgs is not built into this environment: make setup"

    def fields(text: str) -> list[str]:
        return [" ".join(ln.split("#")[0].split()) for ln in text.splitlines()
                if ln.split("#")[0].strip()]

    msgdef, type_hash = topics.msgdef_and_hash(topics.CURRENT_REFERENCE_TYPE)
    ours = msgdef.split("=" * 80)[0]
    assert fields(ours) == fields(msg_file.read_text())
    assert "MSG: std_msgs/Header" in msgdef and "MSG: builtin_interfaces/Time" in msgdef
    generated = share / "CurrentReference.json"
    if generated.is_file():
        hashes = {h["type_name"]: h["hash_string"]
                  for h in json.loads(generated.read_text())["type_hashes"]}
        assert type_hash == hashes[topics.CURRENT_REFERENCE_TYPE]
