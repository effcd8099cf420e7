"""Reading tagged rosbag2/MCAP bags fast: raw chunks, messages decoded in bulk with numpy."""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml

from orthoglide_ident.errors import BagError, DataError

from . import _cdr, _mcap
from ._tags import METADATA_NAME, BagTags
from ._types import (CURRENT_REFERENCE_TOPIC, CURRENT_REFERENCE_TYPE, JOINT_STATE_TYPE, JOINT_STATES_TOPIC,
                     ensure_type, typestore)

DECODED = {JOINT_STATES_TOPIC: "position", CURRENT_REFERENCE_TOPIC: "current"}


def is_decoded(topic: str) -> bool:
    """One of the two topics of every tick, at the root (/orthoglide/joint_states) or under a
    robot's namespace (/robot2/orthoglide/joint_states)."""
    return any(topic == base or topic.endswith(base) for base in DECODED)


def _recorded_name(scan_topics: Iterable[str], base: str, path: Path) -> str | None:
    hits = [t for t in scan_topics if t == base or t.endswith(base)]
    if len(hits) > 1:
        raise BagError(f"{path}: {len(hits)} robots' {base} in one bag ({', '.join(sorted(hits))}); "
                       "record one namespace per bag")
    return hits[0] if hits else None
FIELD_OF_TYPE = {JOINT_STATE_TYPE: "position", CURRENT_REFERENCE_TYPE: "current"}


@dataclass
class JointStates:
    """``stamps_ns`` (N,) int64 header stamps; ``position`` (N, n_joints) [m] by ``names``."""

    stamps_ns: np.ndarray
    names: tuple[str, ...]
    position: np.ndarray


@dataclass
class CurrentReferences:
    """``stamps_ns`` (N,) int64 header stamps; ``current`` (N, n_joints) [A] by ``names``."""

    stamps_ns: np.ndarray
    names: tuple[str, ...]
    current: np.ndarray


@dataclass
class BagData:
    """What :func:`read_bag` returns. ``tags`` is None only with ``require_tags=False``."""

    path: Path
    joint_states: JointStates
    current_reference: CurrentReferences
    tags: BagTags | None
    warnings: list[str] = field(default_factory=list)


@dataclass
class FileStatus:
    path: Path
    size: int
    closed: bool
    chunks: int
    messages: int
    lost: str = ""


@dataclass
class TopicSeries:
    topic: str
    msgtype: str
    count: int = 0
    log_start: int = 2**63 - 1
    log_end: int = 0
    stamps: list[np.ndarray] = field(default_factory=list)
    values: list[np.ndarray] = field(default_factory=list)
    names: tuple[str, ...] | None = None


@dataclass
class _Scan:
    path: Path
    files: list[FileStatus]
    topics: dict[str, TopicSeries]
    tags: BagTags | None
    tag_problem: str
    warnings: list[str]


def bag_files(path: str | Path) -> tuple[Path, list[Path], dict | None, list[str]]:
    """Bag directory or lone .mcap → (bag path, .mcap files, metadata info, warnings)."""
    p = Path(path)
    warnings: list[str] = []
    if not p.exists():
        raise BagError(f"{p}: no such bag (give a rosbag2 directory or an .mcap file)")
    if p.is_file():
        return p, [p], None, warnings
    meta_path = p / "metadata.yaml"
    info = None
    files: list[Path] = []
    if meta_path.is_file():
        try:
            doc = yaml.safe_load(meta_path.read_text())
            info = doc["rosbag2_bagfile_information"]
            if info.get("storage_identifier", "mcap") != "mcap":
                raise BagError(
                    f"{p}: storage {info.get('storage_identifier')!r} is not supported, only mcap"
                )
            files = [p / Path(x).name for x in info.get("relative_file_paths", [])]
        except (yaml.YAMLError, KeyError, TypeError, AttributeError) as exc:
            warnings.append(
                f"{meta_path}: unreadable ({type(exc).__name__}); using the .mcap files found"
            )
            info = None
    else:
        warnings.append(
            f"{p}: no metadata.yaml (recording interrupted?); using the .mcap files found"
        )
    missing = [f for f in files if not f.exists()]
    if missing:
        raise BagError(
            f"{p}: files listed in metadata.yaml are missing: {', '.join(m.name for m in missing)}"
        )
    extra = sorted((f for f in p.glob("*.mcap") if f not in files), key=_split_index)
    if extra and files:
        warnings.append(
            f"{p}: .mcap files not listed in metadata.yaml also read: "
            f"{', '.join(f.name for f in extra)}"
        )
    files += extra
    if not files:
        raise BagError(f"{p}: no .mcap file in this bag directory")
    return p, files, info, warnings


def _split_index(f: Path) -> tuple[int, str]:
    tail = f.stem.rsplit("_", 1)[-1]
    return (int(tail) if tail.isdigit() else -1, f.name)


def _decode_rows(series: TopicSeries, rows: Iterable[bytes]) -> None:
    """Slow path: rosbags deserialiser for messages without the expected fixed layout."""
    ensure_type(series.msgtype)
    store = typestore()
    field_name = FIELD_OF_TYPE[series.msgtype]
    st, vals = [], []
    for raw in rows:
        try:
            msg = store.deserialize_cdr(raw, series.msgtype)
        except Exception as exc:
            raise BagError(f"{series.topic}: undecodable {series.msgtype} message: {exc}") from None
        names = tuple(msg.name)
        v = np.asarray(getattr(msg, field_name), float)
        if len(v) != len(names):
            raise DataError(f"{series.topic}: message with {len(names)} names but {len(v)} values")
        if series.names is None:
            series.names = names
        if names != series.names:
            if sorted(names) != sorted(series.names):
                raise DataError(
                    f"{series.topic}: joint names change from {series.names} to {names}"
                )
            v = v[[names.index(n) for n in series.names]]
        st.append(msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec)
        vals.append(v)
    if st:
        series.stamps.append(np.asarray(st, np.int64))
        series.values.append(np.vstack(vals))


class _Decoder:
    """Bulk decoding of one topic's messages, with a cache of layouts per message length."""

    def __init__(self, series: TopicSeries) -> None:
        self.series = series
        self.cache: dict[int, tuple[_cdr.Layout, np.ndarray] | None] = {}

    def add(self, arr: np.ndarray, data_offs: np.ndarray, data_lens: np.ndarray) -> None:
        s = self.series
        for length in np.unique(data_lens):
            length = int(length)
            sel = data_offs[data_lens == length]
            steps = np.diff(sel)
            if len(sel) > 1 and steps[0] >= length and (steps == steps[0]).all():
                # evenly spaced records (the usual interleaving): a strided view, no gather
                block = np.lib.stride_tricks.as_strided(
                    arr[sel[0] :],
                    shape=(len(sel), length),
                    strides=(int(steps[0]), 1),
                    writeable=False,
                )
            else:
                block = arr[sel[:, None] + np.arange(length)]
            if length not in self.cache:
                lay = (
                    _cdr.layout(block[0].tobytes(), _cdr.FLOAT_ARRAYS.get(s.msgtype, -1))
                    if s.msgtype in _cdr.FLOAT_ARRAYS
                    else None
                )
                ok_layout = (
                    lay is not None and len(lay.arrays) > 0 and lay.arrays[0][1] == len(lay.names)
                )
                self.cache[length] = (lay, block[0].copy()) if ok_layout else None
            entry = self.cache[length]
            if entry is None:
                _decode_rows(s, (r.tobytes() for r in block))
                continue
            lay, tpl = entry
            ok, st, vals = _cdr.decode_group(block, lay, tpl)
            if s.names is None:
                s.names = lay.names
            if lay.names != s.names:
                _decode_rows(s, (r.tobytes() for r in block))
                continue
            if ok.all():
                s.stamps.append(st)
                s.values.append(vals)
            else:
                s.stamps.append(st[ok])
                s.values.append(vals[ok])
                _decode_rows(s, (r.tobytes() for r in block[~ok]))


def _scan_bag(path: str | Path, decode: bool) -> _Scan:
    bag, files, info, warnings = bag_files(path)
    topics: dict[str, TopicSeries] = {}
    decoders: dict[str, _Decoder] = {}
    statuses: list[FileStatus] = []
    file_tags: list[tuple[Path, BagTags | None]] = []
    tag_problem = ""
    for fpath in files:
        status, tag, problem = _scan_file(fpath, topics, decoders, decode, warnings)
        statuses.append(status)
        file_tags.append((fpath, tag))
        tag_problem = tag_problem or problem
    tags, tag_problem = _agree_tags(bag, info, file_tags, tag_problem)
    if decode:
        for s in topics.values():
            _concat_sorted(s)
    return _Scan(bag, statuses, topics, tags, tag_problem, warnings)


def _file_tag(
    fpath: Path, metadata: list[tuple[str, dict[str, str]]]
) -> tuple[BagTags | None, str]:
    """The tag of one file's first ``orthoglide`` metadata record, or the problem with it."""
    for name, items in metadata:
        if name == METADATA_NAME:
            try:
                return BagTags.from_dict(items, f"{fpath.name} metadata record '{name}'"), ""
            except BagError as exc:
                return None, str(exc)
    return None, ""


def _scan_file(
    fpath: Path,
    topics: dict[str, TopicSeries],
    decoders: dict[str, _Decoder],
    decode: bool,
    warnings: list[str],
) -> tuple[FileStatus, BagTags | None, str]:
    """Read one .mcap into ``topics``: its status, its tag and the problem with its tag."""
    res = _mcap.scan(fpath)
    try:
        tag, problem = _file_tag(fpath, res.metadata)
        status = FileStatus(fpath, res.size, res.closed, 0, 0)
        for arr, per, in_chunk in _mcap.iter_messages(res, warnings):
            status.chunks += in_chunk
            for cid, offs in per.items():
                _take(res, cid, arr, offs, topics, decoders, decode, status)
        status.lost = res.loss()
        if not res.closed and res.data_end:
            warnings.append(
                f"{fpath}: summary or footer missing or damaged; all "
                f"{status.messages} messages of the data section were read"
            )
        elif not res.closed:
            warnings.append(
                f"{fpath}: not closed properly (recording interrupted?): read {status.chunks} "
                f"complete chunks, {status.messages} messages; {status.lost}; messages the "
                "recorder still held in memory (at most one chunk, about 0.5 s) are not in the "
                "file; `orthoglide-ident reindex` writes a closed copy"
            )
        if status.messages == 0 and not res.channels:
            raise BagError(f"{fpath}: nothing readable (no complete chunk or channel)")
        return status, tag, problem
    finally:
        del res


def _agree_tags(
    bag: Path, info: dict | None, file_tags: list[tuple[Path, BagTags | None]], tag_problem: str
) -> tuple[BagTags | None, str]:
    """The bag's tag: metadata.yaml custom_data and every file's record must agree."""
    yaml_tag = None
    if info is not None:
        try:
            yaml_tag = BagTags.from_dict(
                info.get("custom_data"), f"{bag / 'metadata.yaml'} custom_data"
            )
        except BagError as exc:
            tag_problem = tag_problem or str(exc)
    found = [(str(bag / "metadata.yaml"), yaml_tag)] if yaml_tag else []
    found += [(str(p), t) for p, t in file_tags if t is not None]
    if not found:
        return None, tag_problem or (
            f"{bag}: not tagged: no orthoglide.condition/orthoglide.payload_mass in metadata.yaml "
            f"custom_data nor in an MCAP metadata record '{METADATA_NAME}'"
        )
    tags = found[0][1]
    for where, t in found[1:]:
        if t != tags:
            return None, (
                f"{bag}: contradictory tags: {found[0][0]} says {tags.condition} "
                f"{tags.payload_mass:g} kg, {where} says {t.condition} {t.payload_mass:g} kg"
            )
    return (None, tag_problem) if tag_problem else (tags, "")


def _concat_sorted(s: TopicSeries) -> None:
    """One stamps array and one values array per topic, sorted by stamp."""
    if len(s.stamps) > 1 or (s.stamps and np.any(np.diff(s.stamps[0]) < 0)):
        st = np.concatenate(s.stamps) if s.stamps else np.zeros(0, np.int64)
        vals = np.concatenate(s.values) if s.values else np.zeros((0, 0))
        if np.any(np.diff(st) < 0):
            order = np.argsort(st, kind="stable")
            st, vals = st[order], vals[order]
        s.stamps, s.values = [st], [vals]


def _take(
    res: _mcap.ScanResult,
    cid: int,
    arr: np.ndarray,
    offs: np.ndarray,
    topics: dict[str, TopicSeries],
    decoders: dict[str, _Decoder],
    decode: bool,
    status: FileStatus,
) -> None:
    ch = res.channels.get(cid)
    if ch is None:
        return
    schema = res.schemas.get(ch.schema_id)
    msgtype = schema.name if schema else "?"
    s = topics.get(ch.topic)
    if s is None:
        s = topics[ch.topic] = TopicSeries(ch.topic, msgtype)
    n = len(offs)
    s.count += n
    status.messages += n
    if n == 0:
        return
    logs = _mcap.log_times(arr, offs)
    s.log_start = min(s.log_start, int(logs.min()))
    s.log_end = max(s.log_end, int(logs.max()))
    if decode and is_decoded(ch.topic) and ch.encoding == "cdr":
        dec = decoders.get(ch.topic)
        if dec is None:
            dec = decoders[ch.topic] = _Decoder(s)
        lens = _mcap.record_lengths(arr, offs) - _mcap.MSG_HEAD_LEN
        dec.add(arr, offs + _mcap.MSG_HEAD_LEN, lens)


def decode_messages(raw: Sequence[bytes], msgtype: str) -> tuple[np.ndarray, tuple[str, ...], np.ndarray]:
    """Serialized JointState or CurrentReference messages (CDR, as a raw subscription receives
    them) decoded in bulk: (header stamps ns (n,), joint names, values (n, len(names))). Raises
    DataError when the joint names change from one message to another."""
    series = TopicSeries(msgtype, msgtype)
    if raw:
        lens = np.fromiter((len(r) for r in raw), np.int64, len(raw))
        offs = np.concatenate([[0], np.cumsum(lens)[:-1]])
        _Decoder(series).add(np.frombuffer(b"".join(raw), np.uint8), offs, lens)
    if not series.stamps:
        return np.empty(0, np.int64), series.names or (), np.empty((0, len(series.names or ())))
    return np.concatenate(series.stamps), series.names or (), np.concatenate(series.values)


def read_bag(path: str | Path, *, require_tags: bool = True) -> BagData:
    """Read q and v_tau of one bag (a rosbag2 directory or a lone .mcap file).

    Raises BagError when the bag is unreadable, lacks one of the two topics, or (with
    ``require_tags``) is untagged or carries contradictory tags; DataError when joint names change
    inside a topic. A bag cut short by a crash is read up to its last complete chunk, with a
    warning in ``BagData.warnings``.
    """
    scan = _scan_bag(path, decode=True)
    if require_tags and scan.tags is None:
        raise BagError(scan.tag_problem)
    warnings = list(scan.warnings)
    if scan.tags is None:
        warnings.append(scan.tag_problem)
    out = []
    for base in (JOINT_STATES_TOPIC, CURRENT_REFERENCE_TOPIC):
        topic = _recorded_name(scan.topics, base, scan.path) or base
        s = scan.topics.get(topic)
        if s is None or not s.stamps:
            raise BagError(
                f"{scan.path}: topic {topic} is missing (found: "
                f"{', '.join(sorted(scan.topics)) or 'no topics'})"
            )
        out.append((s.stamps[0], s.names or (), s.values[0]))
    (js_t, js_n, js_v), (cr_t, cr_n, cr_v) = out
    return BagData(
        scan.path,
        JointStates(js_t, tuple(js_n), js_v),
        CurrentReferences(cr_t, tuple(cr_n), cr_v),
        scan.tags,
        warnings,
    )
