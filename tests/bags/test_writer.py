"""The streaming writer over the official MCAP library: time-bounded chunks, log-time order,
chunk compressions, split by size, a file readable while it is being written."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from orthoglide_ident import bags
from orthoglide_ident.bags.encoding import encode_messages
from orthoglide_ident.bags.tags import CONDITION_KEY, INCOMPLETE_KEY
from orthoglide_ident.bags.topics import (
    CURRENT_REFERENCE_TOPIC,
    CURRENT_REFERENCE_TYPE,
    JOINT_STATE_TYPE,
    JOINT_STATES_TOPIC,
)
from orthoglide_ident.errors import BagError, DataError

NAMES = ("q11", "q12", "q13")
T0 = 1_700_000_000_000_000_000


def _open(path: Path, **kw) -> tuple[bags.BagWriter, int, np.ndarray, np.ndarray]:
    n = 3000
    stamps = T0 + np.arange(n, dtype=np.int64) * 1_000_000
    msgs = encode_messages(JOINT_STATE_TYPE, NAMES, stamps, np.zeros((n, 3)))
    w = bags.BagWriter(path, bags.BagTags("unloaded", 0.0), **kw).open()
    return w, w.add_topic(JOINT_STATES_TOPIC, JOINT_STATE_TYPE), stamps, msgs


def _chunk_indexes(f: Path) -> list:
    from mcap.reader import make_reader

    with f.open("rb") as fh:
        summary = make_reader(fh, validate_crcs=True).get_summary()
    assert summary is not None
    return summary.chunk_indexes


def test_chunks_are_time_bounded(tmp_path: Path) -> None:
    w, cid, stamps, msgs = _open(tmp_path / "t", chunk_duration_s=0.2)
    for i, t in enumerate(stamps.tolist()):
        w.write(cid, msgs[i].tobytes(), t)
    w.close()
    chunks = _chunk_indexes(w.files[0].path)
    assert len(chunks) == 15
    assert all(c.message_end_time - c.message_start_time < 200_000_000 for c in chunks)


def test_flush_if_due_makes_the_open_file_readable(tmp_path: Path) -> None:
    w, cid, stamps, msgs = _open(tmp_path / "f", chunk_duration_s=10.0)
    for i in range(700):
        w.write(cid, msgs[i].tobytes(), int(stamps[i]))
    w.flush_if_due(int(stamps[699]) + 1_000_000)  # not due: 0.7 s < 10 s
    f = w.files[0].path
    with pytest.raises(BagError, match="nothing readable"):
        bags.bag_info(f)
    w.flush_if_due(int(stamps[0]) + 10_000_000_000)  # due: the chunk goes to disk now
    copy = tmp_path / "snapshot.mcap"
    copy.write_bytes(f.read_bytes())  # what a reader sees while the recorder runs
    info = bags.bag_info(copy)
    assert info.topics[0].count == 700 and "not closed" in info.warnings[0]
    w.close()


def test_log_time_going_back_is_refused(tmp_path: Path) -> None:
    w, cid, stamps, msgs = _open(tmp_path / "o")
    w.write(cid, msgs[0].tobytes(), int(stamps[1]))
    w.write(cid, msgs[1].tobytes(), int(stamps[1]))  # equal: fine
    with pytest.raises(DataError, match="must not decrease") as exc:
        w.write(cid, msgs[2].tobytes(), int(stamps[0]))
    assert "\n" not in str(exc.value)
    w.close()
    info = bags.bag_info(tmp_path / "o")
    assert info.closed and info.topics[0].count == 2 and info.warnings == []


@pytest.mark.parametrize("compression", ["zstd", "lz4", ""])
def test_compressions(tmp_path: Path, compression: str) -> None:
    w, cid, stamps, msgs = _open(tmp_path / "c", compression=compression)
    for i, t in enumerate(stamps.tolist()):
        w.write(cid, msgs[i].tobytes(), t)
    w.close()
    assert {c.compression for c in _chunk_indexes(w.files[0].path)} == {compression}
    data = bags.bag_info(tmp_path / "c")
    assert data.closed and data.topics[0].count == 3000


def test_unknown_compression(tmp_path: Path) -> None:
    with pytest.raises(BagError, match="unknown chunk compression 'gzip'"):
        bags.BagWriter(tmp_path / "x", bags.BagTags("unloaded", 0.0), compression="gzip").open()


def test_split_by_size_loses_nothing(tmp_path: Path) -> None:
    from mcap.reader import make_reader

    w, cid, stamps, msgs = _open(tmp_path / "s", chunk_duration_s=0.1, split_size_bytes=15_000)
    for i, t in enumerate(stamps.tolist()):
        w.write(cid, msgs[i].tobytes(), t)
    w.close()
    files = sorted((tmp_path / "s").glob("*.mcap"))
    assert len(files) >= 3
    for f in files:  # every part: tag first, then the rosbag2 record; channel ids kept
        with f.open("rb") as fh:
            reader = make_reader(fh, validate_crcs=True)
            assert [m.name for m in reader.iter_metadata()][:2] == ["orthoglide", "rosbag2"]
            assert list(reader.get_summary().channels) == [cid]
    info = bags.bag_info(tmp_path / "s")
    assert info.topics[0].count == 3000 and info.topics[0].gaps.missing == 0 and info.closed


def test_a_robot_namespace_is_read_like_the_root(tmp_path):
    """A recorder in namespace /robot2 records /robot2/orthoglide/joint_states: the readers find
    the two topics of every tick under it; two robots in one bag are refused with a reason."""
    import numpy as np
    import pytest

    from orthoglide_ident import bags
    from orthoglide_ident.errors import BagError

    names = ("q11", "q12", "q13")
    stamps = np.arange(50, dtype=np.int64) * 1_000_000 + 10**9
    values = np.random.default_rng(0).normal(size=(50, 3))

    def write(path, prefixes):
        w = bags.BagWriter(path, bags.BagTags("unloaded", 0.0)).open()
        for n, prefix in enumerate(prefixes):
            c_js = w.add_topic(prefix + JOINT_STATES_TOPIC, JOINT_STATE_TYPE)
            c_cr = w.add_topic(prefix + CURRENT_REFERENCE_TOPIC, CURRENT_REFERENCE_TYPE)
            js = encode_messages(JOINT_STATE_TYPE, names, stamps, values)
            cr = encode_messages(CURRENT_REFERENCE_TYPE, names, stamps, values)
            for k, st in enumerate(stamps):
                # log times never go back
                w.write(c_js, js[k].tobytes(), int(st) + n * 10**9, int(st))
                w.write(c_cr, cr[k].tobytes(), int(st) + n * 10**9 + 1, int(st))
        w.close()

    write(tmp_path / "ns", ["/robot2"])
    data = bags.read_bag(tmp_path / "ns")
    np.testing.assert_array_equal(data.joint_states.stamps_ns, stamps)
    np.testing.assert_allclose(data.current_reference.current, values)
    info = bags.bag_info(tmp_path / "ns")
    assert {t.topic for t in info.topics} == {
        "/robot2/orthoglide/joint_states",
        "/robot2/orthoglide/current_reference",
    }
    write(tmp_path / "two", ["/robot2", "/robot3"])
    with pytest.raises(BagError, match="robots"):
        bags.read_bag(tmp_path / "two")


def test_a_bag_stopped_early_is_kept_and_tagged_incomplete(tmp_path: Path) -> None:
    """orthoglide.incomplete (excite run's cancel/abort): in metadata.yaml and in the closing
    rosbag2 record, so the bag directory and its lone .mcap file both say it; the tag is kept."""
    w, cid, stamps, msgs = _open(tmp_path / "cut", chunk_duration_s=0.2)
    for i, t in enumerate(stamps.tolist()):
        w.write(cid, msgs[i].tobytes(), t)
    w.mark_incomplete("unloaded run aborted:\n PATH_TOLERANCE_VIOLATED: elbow_joint ...")
    w.close()
    reason = "unloaded run aborted: PATH_TOLERANCE_VIOLATED: elbow_joint ..."  # one line
    import yaml

    custom = yaml.safe_load((tmp_path / "cut" / "metadata.yaml").read_text())[
        "rosbag2_bagfile_information"
    ]["custom_data"]
    assert custom[INCOMPLETE_KEY] == reason and custom[CONDITION_KEY] == "unloaded"
    for where in (tmp_path / "cut", w.files[0].path):  # the directory, the lone file
        info = bags.bag_info(where)
        assert info.incomplete == reason and info.tags == bags.BagTags("unloaded", 0.0)
        assert f"INCOMPLETE: {reason}" in info.to_text()
    complete, cid2, stamps2, msgs2 = _open(tmp_path / "whole")
    complete.write(cid2, msgs2[0].tobytes(), int(stamps2[0]))
    complete.close()
    assert bags.bag_info(tmp_path / "whole").incomplete == ""
