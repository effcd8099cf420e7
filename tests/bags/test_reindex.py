"""Recovery of a bag whose recorder was killed: ``bags.reindex`` and ``orthoglide-ident reindex``.

A SIGKILL is staged without ROS: a streaming writer's file is copied while it is still open (what
the disk holds then), cut inside the open chunk, and metadata.yaml put back to the placeholder the
writer wrote at open.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml
from rosbags.highlevel import AnyReaderError

from orthoglide_ident import bags
from orthoglide_ident.bags import topics
from orthoglide_ident.bags.encoding import encode_messages
from orthoglide_ident.errors import BagError
from orthoglide_ident.ros import processes as children  # children end with this process

NAMES = ("q11", "q12", "q13")
T0 = 1_700_000_000_000_000_000
BEST_EFFORT = [topics.qos_profile("best_effort", "volatile", "keep_last", 5)]


def _killed_bag(path: Path, n: int, split_duration_s: float | None = None) -> int:
    """Write ``n`` ticks, then leave the bag as a SIGKILL would: its last file cut inside the open
    chunk, metadata.yaml the placeholder written at open. Returns the messages left on disk."""
    stamps = T0 + np.arange(n, dtype=np.int64) * 1_000_000
    rng = np.random.default_rng(3)
    js = encode_messages(topics.JOINT_STATE_TYPE, NAMES, stamps, rng.normal(size=(n, 3)))
    cr = encode_messages(topics.CURRENT_REFERENCE_TYPE, NAMES, stamps, rng.normal(size=(n, 3)))
    w = bags.BagWriter(path, bags.BagTags("loaded", 2.5), split_duration_s=split_duration_s,
                       custom_data={"sim.seed": "3"}).open()
    placeholder = (path / "metadata.yaml").read_text()
    a = w.add_topic(topics.JOINT_STATES_TOPIC, topics.JOINT_STATE_TYPE, qos=BEST_EFFORT)
    b = w.add_topic(topics.CURRENT_REFERENCE_TOPIC, topics.CURRENT_REFERENCE_TYPE)
    for i, t in enumerate(stamps.tolist()):
        w.write(a, js[i].tobytes(), t)
        w.write(b, cr[i].tobytes(), t)
    last = w.files[-1].path
    on_disk = len(last.read_bytes())  # the open chunk is still in memory
    w.close()
    last.write_bytes(last.read_bytes()[: on_disk + 2000])  # + part of the chunk being written
    (path / "metadata.yaml").write_text(placeholder)
    return sum(_messages(f) for f in path.glob("*.mcap"))


def _messages(f: Path) -> int:
    """Messages in the complete chunks of one file, as the MCAP library's stream reader finds
    them before the cut (independent of our scanner)."""
    from mcap.exceptions import EndOfFile
    from mcap.records import Message
    from mcap.stream_reader import StreamReader

    n = 0
    with f.open("rb") as fh:
        try:
            for record in StreamReader(fh).records:
                n += isinstance(record, Message)
        except EndOfFile:  # the chunk being written when the recorder was killed
            pass
    return n


def _rosbags_count(path: Path) -> int:
    from rosbags.highlevel import AnyReader

    with AnyReader([path]) as reader:
        return sum(1 for _ in reader.messages())


def test_reindex_killed_recording(tmp_path: Path) -> None:
    bag = tmp_path / "killed"
    kept = _killed_bag(bag, 2300)
    assert kept == 4000  # four complete 0.5 s chunks of two topics
    with pytest.raises(AnyReaderError, match="magic"):  # rosbags cannot open a file cut short
        _rosbags_count(bag)
    res = bags.reindex(bag)
    text = res.to_text()
    assert "killed_0.mcap: 4000 messages in 4 chunks" in text and "lost:" in text
    assert "incomplete record of 2000 bytes" in text and "\n" in text
    assert (bag / "killed_0.mcap.orig").is_file()
    # every reader agrees now: metadata.yaml, rosbags, our reader (no warning), mcap with CRCs
    info = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert info["message_count"] == 4000 and info["relative_file_paths"] == ["killed_0.mcap"]
    assert info["duration"]["nanoseconds"] == 1_999_000_000
    assert info["starting_time"]["nanoseconds_since_epoch"] == T0
    by_name = {t["topic_metadata"]["name"]: t for t in info["topics_with_message_count"]}
    assert by_name[topics.JOINT_STATES_TOPIC]["message_count"] == 2000
    js_meta = by_name[topics.JOINT_STATES_TOPIC]["topic_metadata"]
    assert js_meta["offered_qos_profiles"] == BEST_EFFORT
    assert js_meta["type_description_hash"] == topics.msgdef_and_hash(topics.JOINT_STATE_TYPE)[1]
    assert info["custom_data"] == {"sim.seed": "3", "orthoglide.condition": "loaded",
                                   "orthoglide.payload_mass": "2.5"}
    assert _rosbags_count(bag) == 4000
    data = bags.read_bag(bag)
    assert data.warnings == [] and len(data.joint_states.stamps_ns) == 2000
    from mcap.reader import make_reader

    with (bag / "killed_0.mcap").open("rb") as fh:
        reader = make_reader(fh, validate_crcs=True)
        assert sum(1 for _ in reader.iter_messages()) == 4000
        names = [m.name for m in reader.iter_metadata()]
    assert names == ["orthoglide", "rosbag2", "rosbag2"]
    # a second run changes nothing
    assert "closed, left as it was" in bags.reindex(bag).to_text()
    info2 = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert info2 == info


def test_reindex_split_bag_closes_only_the_last_file(tmp_path: Path) -> None:
    bag = tmp_path / "split"
    kept = _killed_bag(bag, 2600, split_duration_s=1.0)
    res = bags.reindex(bag)
    assert [f.closed for f in res.files] == [True, True, False]
    assert sorted(p.name for p in bag.iterdir()) == [
        "metadata.yaml", "split_0.mcap", "split_1.mcap", "split_2.mcap", "split_2.mcap.orig"]
    assert _rosbags_count(bag) == kept
    data = bags.read_bag(bag)
    assert data.warnings == [] and data.tags == bags.BagTags("loaded", 2.5)
    np.testing.assert_array_equal(
        data.joint_states.stamps_ns, T0 + np.arange(kept // 2, dtype=np.int64) * 1_000_000)


def test_reindex_lone_file(tmp_path: Path) -> None:
    bag = tmp_path / "lone"
    _killed_bag(bag, 1200)
    lone = tmp_path / "lone.mcap"
    os.replace(bag / "lone_0.mcap", lone)
    res = bags.reindex(lone)
    assert res.metadata is None and not res.files[0].closed
    assert not (tmp_path / "metadata.yaml").exists()
    assert bags.read_bag(lone).warnings == []


def test_reindex_bad_input(tmp_path: Path) -> None:
    with pytest.raises(BagError, match="no such bag"):
        bags.reindex(tmp_path / "nope")
    (tmp_path / "empty").mkdir()
    with pytest.raises(BagError, match="no .mcap file"):
        bags.reindex(tmp_path / "empty")
    (tmp_path / "junk.mcap").write_bytes(b"not a bag at all")
    with pytest.raises(BagError, match="not an MCAP file") as exc:
        bags.reindex(tmp_path / "junk.mcap")
    assert "\n" not in str(exc.value)


def _cli(*args: str, stdout: int = subprocess.PIPE) -> subprocess.CompletedProcess:
    return children.run([sys.executable, "-m", "orthoglide_ident.cli", *args], stdout=stdout,
                          stderr=subprocess.PIPE, text=True, timeout=120)


def test_cli_reindex(tmp_path: Path) -> None:
    bag = tmp_path / "cli"
    _killed_bag(bag, 1200)
    done = _cli("reindex", str(bag))
    assert done.returncode == 0, done.stderr
    assert "closed copy written" in done.stdout and "metadata.yaml rewritten" in done.stdout
    (tmp_path / "junk.mcap").write_bytes(b"junk")
    for bad in (tmp_path / "nope", tmp_path / "junk.mcap"):
        done = _cli("reindex", str(bad))
        assert done.returncode == 2 and done.stdout == ""
        assert done.stderr.count("\n") == 1 and "Traceback" not in done.stderr


def test_cli_output_pipe_closed_early(tmp_path: Path) -> None:
    """`orthoglide-ident info BAG | head -1`: no 'internal error (BrokenPipeError)', no noise."""
    bag = tmp_path / "b"
    _killed_bag(bag, 600)
    bags.reindex(bag)
    read_end, write_end = os.pipe()
    os.close(read_end)  # the reader is gone before the command writes anything
    try:
        done = _cli("info", str(bag), str(bag), stdout=write_end)
    finally:
        os.close(write_end)
    assert done.stderr == "" and done.returncode == 141
