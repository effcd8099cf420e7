"""Reading tagged rosbag2/MCAP bags fast: raw chunks, messages decoded in bulk with numpy.

Any bag of joint states reads: the Orthoglide's (``/orthoglide/joint_states`` +
``/orthoglide/current_reference``) and a ros2_control robot's (``/joint_states``, optionally
``/dynamic_joint_states``). :mod:`.sources` says which topic and field carry q and the current;
message types are decoded from the bag's own schemas, so no compiled type is needed.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml

from orthoglide_ident.errors import BagError
from orthoglide_ident.yaml_files import safe_load

from . import _cdr, _mcap
from ._decode import Decoder, TopicSeries
from ._metadata import ROSBAG2_RECORD, parse_record
from ._tags import INCOMPLETE_KEY, METADATA_NAME, BagTags
from ._types import CURRENT_REFERENCE_TYPE, DYNAMIC_JOINT_STATE_TYPE, JOINT_STATE_TYPE
from .sources import BagSources, choose_sources, take_joints

DEFAULT_FIELD = {JOINT_STATE_TYPE: "position", CURRENT_REFERENCE_TYPE: "current",
                 DYNAMIC_JOINT_STATE_TYPE: "current"}


@dataclass
class JointStates:
    """``stamps_ns`` (N,) int64 header stamps; ``position`` (N, n_joints) [m or rad] by
    ``names``."""

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
    """What :func:`read_bag` returns: q and the current, each with the header stamps of its own
    topic (pairing by stamp is the caller's), ``sources`` saying where each came from; ``tags``
    is None only with ``require_tags=False``. ``joint_states`` / ``current_reference`` are the
    same two series under the names of the Orthoglide's topics."""

    path: Path
    positions: JointStates
    current: CurrentReferences
    sources: BagSources
    tags: BagTags | None
    warnings: list[str] = field(default_factory=list)
    # (N_q, len(positions.names)) rad/s or m/s: JointState.velocity on the positions' topic
    # when every one of those joints has it, else None
    velocity: np.ndarray | None = None

    @property
    def joint_states(self) -> JointStates:
        return self.positions

    @property
    def current_reference(self) -> CurrentReferences:
        return self.current


@dataclass
class FileStatus:
    path: Path
    size: int
    closed: bool
    chunks: int
    messages: int
    lost: str = ""


@dataclass
class _Scan:
    path: Path
    files: list[FileStatus]
    topics: dict[str, TopicSeries]
    tags: BagTags | None
    tag_problem: str
    warnings: list[str]
    incomplete: str = ""  # orthoglide.incomplete: why the recording stopped early ("" if complete)


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
            doc = safe_load(meta_path.read_text())
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


def _scan_bag(path: str | Path, decode: bool,
              progress: Callable[..., None] | None = None) -> _Scan:
    bag, files, info, warnings = bag_files(path)
    topics: dict[str, TopicSeries] = {}
    decoders: dict[str, Decoder] = {}
    statuses: list[FileStatus] = []
    file_tags: list[tuple[Path, BagTags | None]] = []
    tag_problem = ""
    closing: list[str] = []  # orthoglide.incomplete of the files' closing rosbag2 records
    for fpath in files:
        status, tag, problem = _scan_file(fpath, topics, decoders, decode, warnings, closing,
                                          progress)
        statuses.append(status)
        file_tags.append((fpath, tag))
        tag_problem = tag_problem or problem
    tags, tag_problem = _agree_tags(bag, info, file_tags, tag_problem)
    if decode:
        for s in topics.values():
            if s.msgtype in _cdr.DECODABLE:
                s.finish()
    custom = (info or {}).get("custom_data") or {}
    incomplete = str(custom.get(INCOMPLETE_KEY, "") if isinstance(custom, dict) else "") or \
        next((c for c in reversed(closing) if c), "")
    return _Scan(bag, statuses, topics, tags, tag_problem, warnings, incomplete)


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
    decoders: dict[str, Decoder],
    decode: bool,
    warnings: list[str],
    closing: list[str] | None = None,
    progress: Callable[..., None] | None = None,
) -> tuple[FileStatus, BagTags | None, str]:
    """Read one .mcap into ``topics``: its status, its tag and the problem with its tag (and
    appended to ``closing``: the ``orthoglide.incomplete`` of its rosbag2 records, "" if none);
    ``progress(stage, done, total, unit)`` hears the chunks read."""
    res = _mcap.scan(fpath)
    try:
        tag, problem = _file_tag(fpath, res.metadata)
        if closing is not None:
            docs = [parse_record(items) for name, items in res.metadata if name == ROSBAG2_RECORD]
            closing.append(next((str(d["custom_data"][INCOMPLETE_KEY]) for d in reversed(docs)
                                 if d and isinstance(d.get("custom_data"), dict)
                                 and INCOMPLETE_KEY in d["custom_data"]), ""))
        status = FileStatus(fpath, res.size, res.closed, 0, 0)
        for arr, per, in_chunk in _mcap.iter_messages(res, warnings):
            status.chunks += in_chunk
            if progress is not None:
                progress(f"reading {fpath.name}", status.chunks, len(res.chunks), "chunks")
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


def _sides_shared(a: BagTags, b: BagTags) -> tuple[BagTags, BagTags]:
    """Two places of a tag with the signal sides one of them lacks taken from the other (a bag
    written with the sides in metadata.yaml's custom_data only); a conflict stays one."""
    sides = {k: getattr(a, k) or getattr(b, k) for k in ("position_side", "effort_side")}
    return dataclasses.replace(a, **sides), dataclasses.replace(b, **{
        k: getattr(b, k) or v for k, v in sides.items()})


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
        tags, t = _sides_shared(tags, t)
        if t != tags:
            return None, (
                f"{bag}: contradictory tags: {found[0][0]} says {tags.describe()}, {where} "
                f"says {t.describe()}"
            )
    return (None, tag_problem) if tag_problem else (tags, "")


def _take(
    res: _mcap.ScanResult,
    cid: int,
    arr: np.ndarray,
    offs: np.ndarray,
    topics: dict[str, TopicSeries],
    decoders: dict[str, Decoder],
    decode: bool,
    status: FileStatus,
) -> None:
    ch = res.channels.get(cid)
    if ch is None:
        return
    s = topics.get(ch.topic)
    if s is None:
        schema = res.schemas.get(ch.schema_id)
        s = topics[ch.topic] = TopicSeries(
            ch.topic, schema.name if schema else "?", schema.encoding if schema else "",
            schema.data.decode(errors="replace") if schema else "")
    n = len(offs)
    s.count += n
    status.messages += n
    if n == 0:
        return
    logs = _mcap.log_times(arr, offs)
    s.log_start = min(s.log_start, int(logs.min()))
    s.log_end = max(s.log_end, int(logs.max()))
    if decode and s.msgtype in _cdr.DECODABLE and ch.encoding == "cdr":
        dec = decoders.get(ch.topic)
        if dec is None:
            dec = decoders[ch.topic] = Decoder(s)
        lens = _mcap.record_lengths(arr, offs) - _mcap.MSG_HEAD_LEN
        dec.add(arr, offs + _mcap.MSG_HEAD_LEN, lens)


def decode_messages(raw: Sequence[bytes], msgtype: str, field: str | None = None
                    ) -> tuple[np.ndarray, tuple[str, ...], np.ndarray]:
    """Serialized JointState, CurrentReference or DynamicJointState messages (CDR, as a raw
    subscription receives them) decoded in bulk: (header stamps ns (n,), joint names, values
    (n, len(names))) of ``field`` (default: ``position``, ``current``, interface ``current``),
    in arrival order; the joints that lack the field are left out. Raises DataError when the
    joint names change from one message to another."""
    series = TopicSeries(msgtype, msgtype)
    if raw:
        lens = np.fromiter((len(r) for r in raw), np.int64, len(raw))
        offs = np.concatenate([[0], np.cumsum(lens)[:-1]])
        Decoder(series).add(np.frombuffer(b"".join(raw), np.uint8), offs, lens)
    series.finish(sort=False)
    names, values = series.take(field or DEFAULT_FIELD[msgtype])
    assert series.stamps_ns is not None
    return series.stamps_ns, names, values


def read_bag(path: str | Path, *, require_tags: bool = True, interface: str | None = None,
             joints: Sequence[str] | None = None,
             position_joints: Sequence[str] | None = None,
             channels: Callable[[BagTags | None], tuple[Sequence[str], Sequence[str]]]
             | None = None,
             progress: Callable[..., None] | None = None) -> BagData:
    """Read q and the current of one bag (a rosbag2 directory or a lone .mcap file).

    The sources follow the bag's tag, else the order of preference of :mod:`.sources`: a
    DynamicJointState ``interface`` (default ``current``; given explicitly, it must be there),
    the JointState ``effort``, the CurrentReference. ``joints``: those joints in that order
    (BagError naming one that is missing); default: every joint of each source, in its order.
    ``position_joints``: other names for q than for the current (a transmission's positions
    published joint-side, its currents per motor: model/transmission.py); default ``joints``.
    ``channels``: (position_joints, joints) from the bag's tag, in place of those two (the
    tag says whose signals the bag holds: orthoglide.position_side, orthoglide.effort_side).

    Raises BagError when the bag is unreadable, has no joint states or no current, or (with
    ``require_tags``) is untagged or carries contradictory tags; DataError when joint names
    change inside a topic. A bag cut short by a crash is read up to its last complete chunk,
    with a warning in ``BagData.warnings``. ``progress(stage, done, total, unit)`` (None:
    silent) hears the chunks read.
    """
    scan = _scan_bag(path, decode=True, progress=progress)
    if require_tags and scan.tags is None:
        raise BagError(scan.tag_problem)
    warnings = list(scan.warnings)
    if scan.tags is None:
        warnings.append(scan.tag_problem)
    if channels is not None:
        position_joints, joints = channels(scan.tags)
    if scan.incomplete:
        warnings.append(
            f"{scan.path}: tagged incomplete ({scan.incomplete}): its run stopped before "
            "the end of its trajectory, so it holds less excitation than designed"
        )
    src = choose_sources(scan.topics, scan.path, tags=scan.tags, interface=interface,
                         joints=joints)
    out = []
    for one, want in ((src.position, position_joints or joints), (src.current, joints)):
        s = scan.topics[one.topic]
        names, values = take_joints(s, one, want, scan.path)
        out.append((s.stamps_ns, names, values))
    (q_t, q_n, q_v), (c_t, c_n, c_v) = out
    velocity = None
    s = scan.topics[src.position.topic]
    if s.msgtype == JOINT_STATE_TYPE:
        names, values = s.take("velocity", list(q_n))
        if tuple(names) == tuple(q_n) and values.shape == q_v.shape:
            velocity = values
    return BagData(scan.path, JointStates(q_t, q_n, q_v), CurrentReferences(c_t, c_n, c_v), src,
                   scan.tags, warnings, velocity)
