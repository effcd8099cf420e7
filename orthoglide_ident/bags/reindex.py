"""``orthoglide-ident reindex BAG``: make a bag whose recorder was killed whole again.

A recorder killed by SIGKILL or a power cut leaves metadata.yaml as the placeholder written at
start (no topics, 0 messages: rosbags and ``ros2 bag`` see nothing) and its last .mcap file cut
short (no summary, the open chunk lost). :func:`reindex`

- writes a closed copy of every .mcap file that was not closed, with every complete chunk of it
  (through the official MCAP writer, as the recorder writes), and keeps the original next to it
  as ``<file>.mcap.orig``; it says what was lost (the incomplete record at the end, and what the
  recorder still held in memory: at most one chunk);
- rebuilds metadata.yaml from the files, as ``ros2 bag reindex`` does: message counts, start and
  duration (log times), topics with their offered QoS and type hash (channel metadata), and
  ``custom_data`` from the ``rosbag2`` metadata records (the last readable one), the tag of the
  ``orthoglide`` record and what the old metadata.yaml still had.

A lone .mcap file gets its closed copy only. Closed files are left as they are.

:func:`left_open` finds the bags of a folder that a killed recorder left open (the recorder
reindexes them when it starts); a file that a running writer still holds (its lock) is not one.
"""

from __future__ import annotations

import fcntl
import os
import struct
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from orthoglide_ident.errors import BagError

from . import _mcap
from ._mcapfile import McapFile
from ._metadata import (
    ROSBAG2_RECORD,
    BagMetadata,
    FileStat,
    TopicStat,
    channel_qos,
    parse_record,
)
from ._tags import METADATA_NAME
from ._types import default_qos, msgdef_and_hash
from .reader import _split_index

ORIGINAL_SUFFIX = ".orig"
_MSG = struct.Struct("<BQHIQQ")  # opcode, length, channel, sequence, log time, publish time


@dataclass
class FileReport:
    """What reindex found in (and did to) one .mcap file."""

    path: Path
    closed: bool
    chunks: int
    messages: int
    start_ns: int = 0
    end_ns: int = 0
    lost: str = ""  # what a file that was not closed lost at its end
    original: Path | None = None  # the cut-short original, kept under another name

    def to_text(self) -> str:
        span = f"{(self.end_ns - self.start_ns) / 1e9:.3f} s" if self.messages else "no messages"
        head = f"  {self.path.name}: {self.messages} messages in {self.chunks} chunks, {span}"
        if self.closed:
            return f"{head}; closed, left as it was"
        kept = self.original.name if self.original else "?"
        return (
            f"{head}; was not closed: closed copy written (original kept as {kept}); "
            f"lost: {self.lost}"
        )


@dataclass
class ReindexResult:
    """What :func:`reindex` did; ``metadata`` is None for a lone .mcap file."""

    path: Path
    files: list[FileReport]
    metadata: BagMetadata | None
    warnings: list[str] = field(default_factory=list)

    def to_text(self) -> str:
        """Human-readable summary, as printed by ``orthoglide-ident reindex``."""
        lines = [f"reindexed {self.path}:"] + [f.to_text() for f in self.files]
        m = self.metadata
        if m is not None:
            total = sum(f.count for f in m.files)
            topics = ", ".join(f"{t.name} {t.count}" for t in m.topics) or "none"
            tags = ", ".join(f"{k}={v}" for k, v in m.custom_data.items()) or "none"
            lines.append(f"  metadata.yaml rewritten: {total} messages; topics: {topics}")
            lines.append(f"  custom_data: {tags}")
        lines += [f"warning: {w}" for w in self.warnings]
        return "\n".join(lines)


@dataclass
class _Scanned:
    """One file's statistics (first pass)."""

    report: FileReport
    stat: FileStat
    res: _mcap.ScanResult
    counts: dict[int, int]  # channel id -> messages


def reindex(path: str | Path) -> ReindexResult:
    """Close the cut-short .mcap files of a bag (or a lone .mcap) and rebuild its metadata.yaml.

    Raises BagError with a one-line reason when the path is not a bag, a file is not MCAP, or a
    file cannot be written; nothing is changed then unless the reason says so.
    """
    p = Path(path)
    if not p.exists():
        raise BagError(f"{p}: no such bag (give a rosbag2 directory or an .mcap file)")
    files = [p] if p.is_file() else sorted(p.glob("*.mcap"), key=_split_index)
    if not files:
        raise BagError(f"{p}: no .mcap file in this bag directory")
    warnings: list[str] = []
    stubs = [f for f in files if _is_stub(f)]
    scanned = [_scan(f, warnings) for f in files if f not in stubs]
    if not scanned:
        raise BagError(f"{p}: no .mcap file holds anything readable")
    meta = _bag_metadata(p if p.is_dir() else None, scanned)
    for f in stubs + [s.report.path for s in scanned if not s.report.closed]:
        _check_free(f)
    try:
        for f in stubs:  # killed as it was created: nothing in it, set aside so readers skip it
            os.replace(f, f.with_name(f.name + ORIGINAL_SUFFIX))
            warnings.append(f"{f.name}: empty (killed as it was created?), kept as "
                            f"{f.name + ORIGINAL_SUFFIX} and left out of the bag")
        for s in scanned:
            if not s.report.closed:
                s.report.original = _close_copy(s, meta)
        if p.is_dir():
            meta.write_yaml(p)
    except OSError as exc:
        raise BagError(f"{p}: cannot write: {exc.strerror or exc}") from None
    return ReindexResult(p, [s.report for s in scanned], meta if p.is_dir() else None, warnings)


def left_open(folder: str | Path) -> list[Path]:
    """Bag directories directly under ``folder`` with a .mcap file that was not closed (no MCAP
    magic at its end) and that no process is writing (no lock held on it); [] for no folder."""
    root = Path(folder)
    if not root.is_dir():
        return []
    found = []
    for bag in sorted(p for p in root.iterdir() if (p / "metadata.yaml").is_file()):
        if any(_unclosed_and_free(f) for f in bag.glob("*.mcap")):
            found.append(bag)
    return found


def _unclosed_and_free(f: Path) -> bool:
    try:
        with f.open("rb") as fh:
            size = fh.seek(0, os.SEEK_END)
            fh.seek(max(0, size - len(_mcap.MAGIC)))
            if size >= 2 * len(_mcap.MAGIC) and fh.read() == _mcap.MAGIC:
                return False  # closed
            try:
                fcntl.flock(fh.fileno(), fcntl.LOCK_SH | fcntl.LOCK_NB)
            except BlockingIOError:
                return False  # a writer holds it: being recorded
            except OSError:
                pass  # no locks on this file system
            return True
    except OSError:
        return False


def _is_stub(f: Path) -> bool:
    """A file cut before its magic bytes were complete: nothing in it."""
    try:
        head = f.read_bytes()[:8] if f.stat().st_size < 8 else b"-"
    except OSError as exc:
        raise BagError(f"{f}: cannot read: {exc.strerror or exc}") from None
    return _mcap.MAGIC.startswith(head)


def _check_free(f: Path) -> None:
    for other in (f.with_name(f.name + ORIGINAL_SUFFIX), f.with_name(f.name + ".tmp")):
        if other.exists():
            raise BagError(f"{other} is in the way of the closed copy of {f.name}; move it away")


def _scan(f: Path, warnings: list[str]) -> _Scanned:
    """Count one file's messages per channel and its log-time span (BagError: not MCAP)."""
    res = _mcap.scan(f)
    report = FileReport(f, res.closed, 0, 0, lost=_lost(res))
    stat = FileStat(f)
    counts: dict[int, int] = {}
    for arr, per, in_chunk in _mcap.iter_messages(res, warnings):
        report.chunks += in_chunk
        for cid, offs in per.items():
            if len(offs) and cid in res.channels:
                logs = _mcap.log_times(arr, offs)
                stat.add(int(logs.min()), int(logs.max()), len(offs))
                counts[cid] = counts.get(cid, 0) + len(offs)
    report.messages = stat.count
    report.start_ns, report.end_ns = (stat.start, stat.end) if stat.count else (0, 0)
    return _Scanned(report, stat, res, counts)


def _lost(res: _mcap.ScanResult) -> str:
    if res.closed:
        return ""
    if res.data_end:
        return "nothing (the data section was complete; the summary was rebuilt)"
    return (f"{res.loss()}, and what the recorder still held in memory (at most one chunk, "
            "about 0.5 s)")


def _bag_metadata(bag_dir: Path | None, scanned: list[_Scanned]) -> BagMetadata:
    """Topics (in order of appearance), files and custom_data of the rebuilt metadata."""
    topics: dict[str, TopicStat] = {}
    for s in scanned:
        for cid, ch in sorted(s.res.channels.items()):
            t = topics.get(ch.topic)
            if t is None:
                t = topics[ch.topic] = _topic(s.res, ch)
            t.count += s.counts.get(cid, 0)
    custom, distro = _custom_data(bag_dir, scanned)
    meta = BagMetadata(list(topics.values()), [s.stat for s in scanned], custom)
    if distro:
        meta.ros_distro = distro
    return meta


def _topic(res: _mcap.ScanResult, ch: _mcap.Channel) -> TopicStat:
    schema = res.schemas.get(ch.schema_id)
    msgtype = schema.name if schema else ""
    type_hash = ch.metadata.get("topic_type_hash", "")
    if not type_hash and msgtype:
        try:
            type_hash = msgdef_and_hash(msgtype)[1]
        except BagError:
            pass  # a type this installation does not know: no hash, as rosbag2 leaves it
    qos = channel_qos(ch.metadata.get("offered_qos_profiles")) or default_qos()
    return TopicStat(ch.topic, msgtype, qos, type_hash, 0, ch.encoding)


def _custom_data(bag_dir: Path | None, scanned: list[_Scanned]) -> tuple[dict[str, str], str]:
    """custom_data: old metadata.yaml < last readable ``rosbag2`` record < ``orthoglide`` tag."""
    custom: dict[str, str] = {}
    distro = ""
    old = _old_info(bag_dir)
    if isinstance(old.get("custom_data"), dict):
        custom.update({str(k): str(v) for k, v in old["custom_data"].items()})
    tag: dict[str, str] = {}
    for s in scanned:
        for name, items in s.res.metadata:
            doc = parse_record(items) if name == ROSBAG2_RECORD else None
            if doc is not None:
                if isinstance(doc.get("custom_data"), dict):
                    custom.update({str(k): str(v) for k, v in doc["custom_data"].items()})
                distro = str(doc.get("ros_distro") or distro)
            elif name == METADATA_NAME and not tag:
                tag = dict(items)
    custom.update(tag)
    return custom, distro


def _old_info(bag_dir: Path | None) -> dict[str, Any]:
    if bag_dir is None or not (bag_dir / "metadata.yaml").is_file():
        return {}
    try:
        doc = yaml.safe_load((bag_dir / "metadata.yaml").read_text())
        info = doc["rosbag2_bagfile_information"]
    except (OSError, yaml.YAMLError, KeyError, TypeError):
        return {}
    return info if isinstance(info, dict) else {}


def _close_copy(s: _Scanned, meta: BagMetadata) -> Path:
    """Write the closed copy of a cut-short file in its place; returns where the original is."""
    f = s.report.path
    tmp = f.with_name(f.name + ".tmp")
    comp = s.res.chunks[0].compression if s.res.chunks else "zstd"
    out = McapFile(
        tmp,
        compression=comp if comp in ("zstd", "lz4", "") else "zstd",
        profile=s.res.profile,
        check_order=False,  # another writer's file is copied as it is
    )
    try:
        _copy_records(s.res, out)
        out.close([(ROSBAG2_RECORD, meta.record())])
    except BaseException:
        out.abort()
        tmp.unlink(missing_ok=True)
        raise
    original = f.with_name(f.name + ORIGINAL_SUFFIX)
    os.replace(f, original)
    os.replace(tmp, f)
    return original


def _copy_records(res: _mcap.ScanResult, out: McapFile) -> None:
    """Metadata records, then every message of the complete chunks, chunk by chunk."""
    for name, items in res.metadata:
        out.add_metadata(name, items)
    schema_ids: dict[int, int] = {}
    channel_ids: dict[int, int] = {}
    for arr, per, _ in _mcap.iter_messages(res, []):
        known = [o for cid, o in per.items() if cid in res.channels and len(o)]
        if not known:
            continue
        buf = arr.data
        for off in np.sort(np.concatenate(known)).tolist():  # file order
            _, length, cid, seq, log, pub = _MSG.unpack_from(buf, off)
            new = channel_ids.get(cid)
            if new is None:
                new = channel_ids[cid] = _copy_channel(res, cid, out, schema_ids)
            out.add_message(new, seq, log, pub, buf[off + _MSG.size : off + 9 + length])
        out.flush_chunk()


def _copy_channel(
    res: _mcap.ScanResult, cid: int, out: McapFile, schema_ids: dict[int, int]
) -> int:
    """Register channel ``cid`` of the scanned file (and its schema) in the copy; its new id."""
    ch = res.channels[cid]
    sid = schema_ids.get(ch.schema_id)
    if sid is None:
        schema = res.schemas.get(ch.schema_id)
        sid = 0 if schema is None else out.add_schema(schema.name, schema.encoding, schema.data)
        schema_ids[ch.schema_id] = sid
    return out.add_channel(sid, ch.topic, ch.encoding, ch.metadata)
