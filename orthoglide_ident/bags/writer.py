"""Writing rosbag2 directories (metadata.yaml version 9 + MCAP files) tagged loaded/unloaded.

Every .mcap file is written by the official MCAP library (:mod:`._mcapfile`), laid out as
rosbag2's MCAP storage plugin does; metadata.yaml and the ``rosbag2`` record come from
:mod:`._metadata`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import TracebackType
from typing import Any

import numpy as np
import yaml

from orthoglide_ident.errors import BagError, DataError
from orthoglide_ident.progress import ProgressLine

from ._encode import encode_dynamic_joint_states, encode_joint_states, encode_messages
from ._mcapfile import McapFile
from ._metadata import ROSBAG2_RECORD, BagMetadata, FileStat, TopicStat
from ._tags import INCOMPLETE_KEY, METADATA_NAME, BagTags
from ._types import (
    CURRENT_REFERENCE_TOPIC,
    CURRENT_REFERENCE_TYPE,
    DYNAMIC_JOINT_STATE_TYPE,
    DYNAMIC_JOINT_STATES_TOPIC,
    JOINT_STATE_TYPE,
    JOINT_STATES_TOPIC,
    ROS2_CONTROL_JOINT_STATES_TOPIC,
    default_qos,
    msgdef_and_hash,
)


@dataclass
class _Topic:
    channel_id: int
    topic: str
    msgtype: str
    msgdef: str
    qos: list[dict[str, Any]]
    type_hash: str
    count: int = 0
    sequence: int = 0


@dataclass
class BagWriter:
    """Streaming writer of one tagged rosbag2 directory, used by the recorder.

    ``chunk_duration_s`` / ``chunk_size_bytes`` bound the data held in memory: a killed process
    loses at most that much. ``split_duration_s`` / ``split_size_bytes`` start a new file
    ``<name>_<i>.mcap`` at a chunk boundary (the message that triggers the split opens the new
    file, so nothing is lost); each file starts with the ``orthoglide`` tag record and a
    ``rosbag2`` metadata record, and closes with a final ``rosbag2`` record. Log times must not
    decrease (DataError otherwise). Times are in ns; sizes in bytes.
    """

    path: Path
    tags: BagTags
    compression: str = "zstd"
    chunk_duration_s: float = 0.5
    chunk_size_bytes: int = 1 << 20
    split_duration_s: float | None = None
    split_size_bytes: int | None = None
    fsync: bool = False
    custom_data: dict[str, str] = field(default_factory=dict)
    topics: dict[int, _Topic] = field(default_factory=dict, init=False)
    files: list[FileStat] = field(default_factory=list, init=False)

    def __post_init__(self) -> None:
        self.path = Path(self.path)
        self._file: McapFile | None = None
        self._schema_ids: dict[str, int] = {}  # message type -> schema id in the open file
        self._chunk_ns = self.chunk_duration_s * 1e9

    # -- lifecycle -----------------------------------------------------------------------------
    def open(self) -> BagWriter:
        """Create the bag directory and its first file; BagError if it exists or cannot be made."""
        if self.path.exists():
            raise BagError(f"{self.path} exists already; choose another bag name")
        try:
            self.path.mkdir(parents=True)
        except OSError as exc:
            raise BagError(
                f"cannot create bag directory {self.path}: {exc.strerror or exc}"
            ) from None
        self._open_file()
        return self

    def __enter__(self) -> BagWriter:
        return self.open() if self._file is None else self

    def __exit__(
        self, et: type[BaseException] | None, ev: BaseException | None, tb: TracebackType | None
    ) -> None:
        if et is None or issubclass(et, (KeyboardInterrupt, SystemExit)):
            self.close()
        else:
            self.abort()

    def _open_file(self) -> None:
        """Next ``<name>_<i>.mcap``: tag and rosbag2 records, then every known topic again."""
        stat = FileStat(self.path / f"{self.path.name}_{len(self.files)}.mcap")
        self._file = McapFile(stat.path, compression=self.compression)
        self.files.append(stat)
        self._schema_ids = {}
        self._file.add_metadata(METADATA_NAME, self.tags.to_dict())
        self._file.add_metadata(ROSBAG2_RECORD, self.bag_metadata().record())
        for t in self.topics.values():
            self._register(t)
        self.write_metadata()

    def _register(self, t: _Topic) -> None:
        """Schema (once per type and file) and channel of ``t`` in the open file."""
        f = self._file
        assert f is not None
        sid = self._schema_ids.get(t.msgtype)
        if sid is None:
            sid = self._schema_ids[t.msgtype] = f.add_schema(t.msgtype, "ros2msg", t.msgdef)
        meta = {
            "offered_qos_profiles": yaml.safe_dump(t.qos, sort_keys=False).strip(),
            "topic_type_hash": t.type_hash,
        }
        cid = f.add_channel(sid, t.topic, "cdr", meta)
        assert cid == t.channel_id, "channel ids are the same in every file of a bag"

    def add_topic(
        self,
        topic: str,
        msgtype: str,
        *,
        qos: Sequence[Mapping[str, Any]] | None = None,
        msgdef: str | None = None,
        type_hash: str | None = None,
    ) -> int:
        """Register a topic (offered QoS in rosbag2's layout); returns the id for :meth:`write`."""
        if self._file is None:
            raise BagError("bag writer is not open")
        if msgdef is None or type_hash is None:
            d, h = msgdef_and_hash(msgtype)
            msgdef, type_hash = msgdef or d, type_hash or h
        t = _Topic(
            len(self.topics) + 1,
            topic,
            msgtype,
            msgdef,
            [dict(q) for q in (qos or default_qos())],
            type_hash,
        )
        self._register(t)
        self.topics[t.channel_id] = t
        return t.channel_id

    def write(
        self,
        channel_id: int,
        data: bytes | memoryview,
        log_time_ns: int,
        publish_time_ns: int | None = None,
    ) -> None:
        """Append one serialized (CDR) message. OSError (disk full) propagates to the caller;
        DataError when ``log_time_ns`` is before the previous message's."""
        f = self._file
        if f is None:
            raise BagError("bag writer is not open")
        if f.pending_bytes and (
            log_time_ns - f.chunk_start_time >= self._chunk_ns
            or f.pending_bytes >= self.chunk_size_bytes
        ):
            self._end_chunk(log_time_ns)
            f = self._file
            assert f is not None
        t = self.topics.get(channel_id)
        if t is None:
            raise BagError(f"unknown channel id {channel_id}: register the topic with add_topic")
        f.add_message(
            channel_id,
            t.sequence,
            log_time_ns,
            log_time_ns if publish_time_ns is None else publish_time_ns,
            data,
        )
        t.sequence += 1
        t.count += 1
        st = self.files[-1]
        if not st.count:
            st.start = log_time_ns
        st.count += 1
        st.end = log_time_ns  # log times never decrease in a file

    def _end_chunk(self, now_ns: int) -> None:
        """Write the open chunk; start the next file if the split duration or size is reached."""
        f, st = self._file, self.files[-1]
        assert f is not None
        f.flush_chunk(self.fsync)
        if not st.count:
            return
        if (self.split_duration_s and now_ns - st.start >= self.split_duration_s * 1e9) or (
            self.split_size_bytes and f.size >= self.split_size_bytes
        ):
            self._close_file()
            self._open_file()

    def _close_file(self) -> None:
        f, self._file = self._file, None
        if f is not None:
            f.close([(ROSBAG2_RECORD, self.bag_metadata().record())])

    def flush_if_due(self, now_ns: int) -> None:
        """Write the open chunk if it is older than the chunk duration (call from a timer)."""
        f = self._file
        if f is not None and f.pending_bytes and now_ns - f.chunk_start_time >= self._chunk_ns:
            self._end_chunk(now_ns)

    def mark_incomplete(self, reason: str) -> None:
        """Tag the bag incomplete (``orthoglide.incomplete``: ``reason``) when it closes."""
        self.custom_data[INCOMPLETE_KEY] = " ".join(str(reason).split()) or "stopped early"

    def close(self) -> None:
        """Write the last chunk, the closing ``rosbag2`` record, the summary and metadata.yaml."""
        if self._file is not None:
            self._close_file()
            self.write_metadata()

    def abort(self) -> None:
        """Stop after an error: keep what is on disk (readable up to its last chunk)."""
        f, self._file = self._file, None
        if f is not None:
            try:
                f.flush_chunk()
            except (OSError, BagError):
                pass
            f.abort()
        try:
            self.write_metadata()
        except OSError:
            pass

    @property
    def counts(self) -> dict[str, int]:
        """Messages written per topic."""
        return {t.topic: t.count for t in self.topics.values()}

    # -- metadata ------------------------------------------------------------------------------
    def bag_metadata(self) -> BagMetadata:
        """The bag's rosbag2 metadata as written so far (counts, files, tags in custom_data)."""
        topics = [TopicStat(t.topic, t.msgtype, t.qos, t.type_hash, t.count)
                  for t in self.topics.values()]
        return BagMetadata(topics, list(self.files), {**self.custom_data, **self.tags.to_dict()})

    def write_metadata(self) -> None:
        """(Re)write metadata.yaml; done at open, at each split and at close."""
        self.bag_metadata().write_yaml(self.path)


def _checked_record(
    stamps_ns: np.ndarray, q: np.ndarray, v_tau: np.ndarray, n_joints: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """write_bag's inputs as int64 stamps and float arrays; DataError with the reason otherwise."""
    stamps = np.asarray(stamps_ns)
    q = np.asarray(q, float)
    v_tau = np.asarray(v_tau, float)
    n = len(stamps)
    if stamps.ndim != 1 or not np.issubdtype(stamps.dtype, np.integer):
        raise DataError("stamps_ns must be a 1-D integer array of nanoseconds")
    stamps = stamps.astype(np.int64)
    if q.shape != (n, n_joints) or v_tau.shape != (n, n_joints):
        raise DataError(f"q and v_tau must be ({n}, {n_joints}); got {q.shape} and {v_tau.shape}")
    if n and (stamps.min() < 0 or np.any(np.diff(stamps) <= 0)):
        raise DataError("stamps_ns must be non-negative and strictly increasing")
    return stamps, q, v_tau


_BLOCK = 4096  # ticks encoded at once by write_bag (memory O(block))
# write_bag's layouts:
# - orthoglide: /orthoglide/joint_states (position) and /orthoglide/current_reference;
# - joint_states: what a ros2_control joint_state_broadcaster with
#   map_interface_to_joint_state: {effort: current} publishes: /joint_states with position,
#   velocity (qd, default the derivative of q) and effort = v_tau;
# - dynamic_joint_states: the same /joint_states (effort: `effort`, default v_tau) and
#   /dynamic_joint_states with interfaces position, velocity and current per joint.
# The ros2_control layouts may list the joints in joint_order and add extra_joints (name ->
# constant position; no current, NaN effort), as real hardware does.
LAYOUTS = ("orthoglide", "joint_states", "dynamic_joint_states")
DJS_INTERFACES = ("position", "velocity", "current")  # of an actuated joint in the sample bags
EXTRA_INTERFACES = ("position", "velocity")  # of an extra joint (a gripper without current)


@dataclass
class _Robot:
    """What a ros2_control layout publishes: joints in message order, q (N, n) and its rate,
    JointState effort and the current (N, n) in that order (NaN for extra joints)."""

    names: tuple[str, ...]
    q: np.ndarray
    qd: np.ndarray
    effort: np.ndarray
    current: np.ndarray
    actuated: tuple[bool, ...]


def _robot(stamps: np.ndarray, names: tuple[str, ...], q: np.ndarray, v_tau: np.ndarray,
           qd: np.ndarray | None, effort: np.ndarray | None, joint_order: Sequence[str] | None,
           extra_joints: Mapping[str, float] | None) -> _Robot:
    """The columns of a ros2_control layout; DataError with the reason on bad input."""
    extra = dict(extra_joints or {})
    all_names = names + tuple(extra)
    order = tuple(joint_order) if joint_order is not None else all_names
    if sorted(order) != sorted(all_names) or len(set(order)) != len(order):
        raise DataError(f"joint_order {order} must name each of {all_names} once")
    n = len(stamps)
    if qd is None:  # the hardware's velocity: a derivative of q
        qd = np.gradient(q, stamps * 1e-9, axis=0) if n > 1 else np.zeros_like(q)
    effort = v_tau if effort is None else effort
    for name, a in (("qd", qd), ("effort", effort)):
        if np.shape(a) != q.shape:
            raise DataError(f"{name} must be {q.shape}; got {np.shape(a)}")
    pad = np.full((n, len(extra)), np.nan)
    cols = {j: k for k, j in enumerate(all_names)}
    perm = [cols[j] for j in order]
    stack = lambda a, b: np.hstack([np.asarray(a, float), b])[:, perm]  # noqa: E731
    q_all = stack(q, np.tile(np.fromiter(extra.values(), float, len(extra)), (n, 1)))
    return _Robot(order, q_all, stack(qd, np.zeros((n, len(extra)))), stack(effort, pad),
                  stack(v_tau, pad), tuple(j in names for j in order))


def _ros2_control_topics(w: BagWriter, robot: _Robot, dynamic: bool
                         ) -> list[tuple[int, Callable[[slice, np.ndarray], np.ndarray]]]:
    """Register /joint_states (and /dynamic_joint_states): (channel, encoder of a tick block)."""
    def joint_states(k: slice, st: np.ndarray) -> np.ndarray:
        return encode_joint_states(robot.names, st, robot.q[k], robot.qd[k], robot.effort[k])

    ifs = [DJS_INTERFACES if a else EXTRA_INTERFACES for a in robot.actuated]

    def dynamic_joint_states(k: slice, st: np.ndarray) -> np.ndarray:
        values = {"position": robot.q[k], "velocity": robot.qd[k], "current": robot.current[k]}
        return encode_dynamic_joint_states(robot.names, ifs, st, values)

    out = [(w.add_topic(ROS2_CONTROL_JOINT_STATES_TOPIC, JOINT_STATE_TYPE), joint_states)]
    if dynamic:
        out.append((w.add_topic(DYNAMIC_JOINT_STATES_TOPIC, DYNAMIC_JOINT_STATE_TYPE),
                    dynamic_joint_states))
    return out


def write_bag(
    path: str | Path,
    stamps_ns: np.ndarray,
    q: np.ndarray,
    v_tau: np.ndarray,
    condition: str,
    payload_mass: float,
    joint_names: Sequence[str],
    extra: Mapping[str, str] | None = None,
    *,
    layout: str = "orthoglide",
    qd: np.ndarray | None = None,
    effort: np.ndarray | None = None,
    joint_order: Sequence[str] | None = None,
    extra_joints: Mapping[str, float] | None = None,
    payload: Mapping[str, Any] | None = None,
    tag_sources: bool = True,
    effort_unit: str | None = None,
    position_side: str | None = None,
    effort_side: str | None = None,
    current_sampling: str | None = None,
    compression: str = "zstd",
    chunk_duration_s: float = 0.5,
) -> Path:
    """Write a tagged rosbag2 bag of one record; returns the bag directory path.

    ``stamps_ns`` (N,) int controller ticks (ns, used for header.stamp and as log/publish time),
    ``q`` (N, n) actuated joint positions [m or rad], ``v_tau`` (N, n) currents [A], columns in
    ``joint_names`` order. ``extra``: additional string entries for metadata.yaml custom_data
    (e.g. the simulator's seed); ``payload``: ``payload_frame``, ``payload_com``,
    ``payload_inertia`` for the tag (:class:`BagTags`). ``layout``: one of :data:`LAYOUTS`
    (the topics each writes, ``qd``, ``effort``, ``joint_order`` and ``extra_joints`` there);
    with ``tag_sources`` a ros2_control layout's tag names the topics and fields that carry q
    and the current.
    ``effort_unit`` (``A`` | ``torque``) tags what ``v_tau`` holds when it is not a current
    (``orthoglide.effort_unit``; None: untagged, read as a current). ``position_side``,
    ``effort_side`` (``joint`` | ``actuator``) tag whose positions and currents they are for a
    robot with a transmission (``orthoglide.position_side``, ``orthoglide.effort_side``).
    ``current_sampling`` (``held`` | ``sampled``) tags how the current relates to its stamps
    (``orthoglide.current_sampling``; None: untagged, the ``current_sampling`` option decides).
    Messages are encoded in bulk, block by block, and written tick by tick through
    :class:`BagWriter`, in chunks of ``chunk_duration_s`` s.
    """
    if layout not in LAYOUTS:
        raise DataError(f"unknown layout {layout!r}: use one of {', '.join(LAYOUTS)}")
    names = tuple(joint_names)
    stamps, q, v_tau = _checked_record(stamps_ns, q, v_tau, len(names))
    robot = None
    if layout != "orthoglide":
        robot = _robot(stamps, names, q, v_tau, qd, effort, joint_order, extra_joints)
    elif any(x is not None for x in (qd, effort, joint_order, extra_joints)):
        raise DataError("layout 'orthoglide' publishes q and v_tau only: qd, effort, joint_order "
                        "and extra_joints are for the ros2_control layouts")
    sources = _source_tags(layout) if robot is not None and tag_sources else {}
    tags = BagTags.checked(condition, payload_mass, **dict(payload or {}), **sources,
                           effort_unit=effort_unit, position_side=position_side,
                           effort_side=effort_side, current_sampling=current_sampling)
    w = BagWriter(Path(path), tags, compression=compression, chunk_duration_s=chunk_duration_s,
                  custom_data={key: str(val) for key, val in (extra or {}).items()})
    w.open()
    try:
        if robot is None:
            topics = _orthoglide_topics(w, names, q, v_tau)
        else:
            topics = _ros2_control_topics(w, robot, layout == "dynamic_joint_states")
        _write_blocks(w, topics, stamps)
        w.close()
    except BaseException:
        w.abort()
        raise
    return Path(path)


def _source_tags(layout: str) -> dict[str, str]:
    """The tag's position and current sources of a ros2_control layout (the topics and fields)."""
    current = (f"{DYNAMIC_JOINT_STATES_TOPIC} current" if layout == "dynamic_joint_states"
               else f"{ROS2_CONTROL_JOINT_STATES_TOPIC} effort")
    return {"position_source": f"{ROS2_CONTROL_JOINT_STATES_TOPIC} position",
            "current_source": current}


def _write_blocks(w: BagWriter, topics: list[tuple[int, Callable[[slice, np.ndarray], np.ndarray]]],
                  stamps: np.ndarray) -> None:
    """Every tick of ``topics`` (channel, encoder of a tick block), encoded _BLOCK ticks at a time;
    a progress line on a terminal (progress.py)."""
    with ProgressLine("writing the bag", len(stamps), "ticks") as line:
        for i in range(0, len(stamps), _BLOCK):
            k = slice(i, i + _BLOCK)
            rows = tuple(encode(k, stamps[k]) for _, encode in topics)
            _write_ticks(w, tuple(c for c, _ in topics), rows, stamps[k])
            line.update(min(i + _BLOCK, len(stamps)))


def _orthoglide_topics(w: BagWriter, names: tuple[str, ...], q: np.ndarray, v_tau: np.ndarray
                       ) -> list[tuple[int, Callable[[slice, np.ndarray], np.ndarray]]]:
    """Register the Orthoglide's two topics (docs/design/interfaces.md): (channel, encoder of a
    tick block)."""
    return [
        (w.add_topic(JOINT_STATES_TOPIC, JOINT_STATE_TYPE),
         lambda k, st: encode_messages(JOINT_STATE_TYPE, names, st, q[k])),
        (w.add_topic(CURRENT_REFERENCE_TOPIC, CURRENT_REFERENCE_TYPE),
         lambda k, st: encode_messages(CURRENT_REFERENCE_TYPE, names, st, v_tau[k])),
    ]


def _write_ticks(
    w: BagWriter, channels: tuple[int, ...], rows: tuple[np.ndarray, ...], stamps: np.ndarray
) -> None:
    """One message per channel and tick, in tick order; ``rows[c]`` (n, L_c) serialized bytes."""
    views = [(cid, memoryview(r.tobytes()), r.shape[1]) for cid, r in zip(channels, rows)]
    write = w.write
    for k, t in enumerate(stamps.tolist()):
        for cid, mv, length in views:
            write(cid, mv[k * length : (k + 1) * length], t, t)
