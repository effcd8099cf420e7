"""Writing rosbag2 directories (metadata.yaml version 9 + MCAP files) tagged loaded/unloaded."""

from __future__ import annotations

import functools
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import TracebackType
from typing import Any

import numpy as np
import yaml

from orthoglide_ident import __version__
from orthoglide_ident.errors import BagError, DataError

from . import _cdr, _mcap
from ._tags import METADATA_NAME, BagTags
from ._types import (
    CURRENT_REFERENCE_TOPIC,
    CURRENT_REFERENCE_TYPE,
    JOINT_STATE_TYPE,
    JOINT_STATES_TOPIC,
    default_qos,
    msgdef_and_hash,
    typestore,
)

LIBRARY = f"orthoglide_ident {__version__}"


@dataclass
class _Topic:
    channel_id: int
    topic: str
    msgtype: str
    schema_id: int
    qos: list[dict[str, Any]]
    type_hash: str
    count: int = 0
    sequence: int = 0


@dataclass
class _FileStat:
    path: Path
    count: int = 0
    start: int = 2**63 - 1
    end: int = 0


@dataclass
class BagWriter:
    """Streaming writer of one tagged rosbag2 directory, used by the recorder.

    ``chunk_duration_s`` / ``chunk_size_bytes`` bound the data held in memory: a killed process
    loses at most that much. ``split_duration_s`` / ``split_size_bytes`` start a new file
    ``<name>_<i>.mcap`` at a chunk boundary (the message that triggers the split opens the new
    file, so nothing is lost). Times are in ns; sizes in bytes.
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
    files: list[_FileStat] = field(default_factory=list, init=False)

    def __post_init__(self) -> None:
        self.path = Path(self.path)
        self._file: _mcap.McapFileWriter | None = None
        self._schemas: dict[str, tuple[int, str]] = {}
        self._closed = False

    # -- lifecycle -----------------------------------------------------------------------------
    def open(self) -> BagWriter:
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
        stat = _FileStat(self.path / f"{self.path.name}_{len(self.files)}.mcap")
        self._file = _mcap.McapFileWriter(stat.path, compression=self.compression, library=LIBRARY)
        self.files.append(stat)
        self._file.add_metadata(METADATA_NAME, self.tags.to_dict())
        for name, (sid, msgdef) in self._schemas.items():
            self._file.add_schema(sid, name, "ros2msg", msgdef)
        for t in self.topics.values():
            self._add_channel(t)
        self._file.flush_chunk()
        assert self._file is not None
        self.write_metadata()

    def _add_channel(self, t: _Topic) -> None:
        assert self._file is not None
        meta = {
            "offered_qos_profiles": yaml.safe_dump(t.qos, sort_keys=False).strip(),
            "topic_type_hash": t.type_hash,
        }
        self._file.add_channel(t.channel_id, t.schema_id, t.topic, "cdr", meta)

    def add_topic(
        self,
        topic: str,
        msgtype: str,
        *,
        qos: Sequence[Mapping[str, Any]] | None = None,
        msgdef: str | None = None,
        type_hash: str | None = None,
    ) -> int:
        """Register a topic; returns the channel id to pass to :meth:`write`."""
        if self._file is None:
            raise BagError("bag writer is not open")
        if msgdef is None or type_hash is None:
            d, h = msgdef_and_hash(msgtype)
            msgdef, type_hash = msgdef or d, type_hash or h
        if msgtype not in self._schemas:
            sid = len(self._schemas) + 1
            self._schemas[msgtype] = (sid, msgdef)
            self._file.add_schema(sid, msgtype, "ros2msg", msgdef)
        t = _Topic(
            len(self.topics) + 1,
            topic,
            msgtype,
            self._schemas[msgtype][0],
            [dict(q) for q in (qos or default_qos())],
            type_hash,
        )
        self.topics[t.channel_id] = t
        self._add_channel(t)
        return t.channel_id

    def write(
        self,
        channel_id: int,
        data: bytes | memoryview,
        log_time_ns: int,
        publish_time_ns: int | None = None,
    ) -> None:
        """Append one serialized (CDR) message. OSError (disk full) propagates to the caller."""
        f = self._file
        if f is None:
            raise BagError("bag writer is not open")
        if f.pending_bytes and (
            log_time_ns - f.chunk_start_time >= self.chunk_duration_s * 1e9
            or f.pending_bytes >= self.chunk_size_bytes
        ):
            f.flush_chunk(self.fsync)
            self._maybe_split(log_time_ns)
            f = self._file
            assert f is not None
        t = self.topics[channel_id]
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
        st.count += 1
        st.start = min(st.start, log_time_ns)
        st.end = max(st.end, log_time_ns)

    def _maybe_split(self, now_ns: int) -> None:
        st, f = self.files[-1], self._file
        assert f is not None
        if not st.count:
            return
        if (self.split_duration_s and now_ns - st.start >= self.split_duration_s * 1e9) or (
            self.split_size_bytes and f.size >= self.split_size_bytes
        ):
            f.close()
            self._open_file()

    def flush_if_due(self, now_ns: int) -> None:
        """Write the open chunk if it is older than the chunk duration (call from a timer)."""
        f = self._file
        if (
            f is not None
            and f.pending_bytes
            and now_ns - f.chunk_start_time >= self.chunk_duration_s * 1e9
        ):
            f.flush_chunk(self.fsync)
            self._maybe_split(now_ns)

    def close(self) -> None:
        """Write the last chunk, the summaries and metadata.yaml."""
        if self._file is not None:
            self._file.close()
            self._file = None
            self.write_metadata()
        self._closed = True

    def abort(self) -> None:
        """Stop after an error: keep what is on disk (readable up to its last chunk)."""
        f, self._file = self._file, None
        if f is not None:
            try:
                f.flush_chunk()
            except OSError:
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

    # -- metadata.yaml -------------------------------------------------------------------------
    def write_metadata(self) -> None:
        """(Re)write metadata.yaml; done at open, at each split and at close."""
        files = [f for f in self.files]
        start = min((f.start for f in files if f.count), default=0)
        end = max((f.end for f in files if f.count), default=0)
        info = {
            "version": 9,
            "storage_identifier": "mcap",
            "duration": {"nanoseconds": max(0, end - start)},
            "starting_time": {"nanoseconds_since_epoch": start},
            "message_count": sum(f.count for f in files),
            "topics_with_message_count": [
                {
                    "topic_metadata": {
                        "name": t.topic,
                        "type": t.msgtype,
                        "serialization_format": "cdr",
                        "offered_qos_profiles": t.qos,
                        "type_description_hash": t.type_hash,
                    },
                    "message_count": t.count,
                }
                for t in self.topics.values()
            ],
            "compression_format": "",
            "compression_mode": "",
            "relative_file_paths": [f.path.name for f in files],
            "files": [
                {
                    "path": f.path.name,
                    "starting_time": {"nanoseconds_since_epoch": f.start if f.count else 0},
                    "duration": {"nanoseconds": max(0, f.end - f.start) if f.count else 0},
                    "message_count": f.count,
                }
                for f in files
            ],
            "custom_data": {**self.custom_data, **self.tags.to_dict()},
            "ros_distro": "jazzy",
        }
        text = yaml.safe_dump({"rosbag2_bagfile_information": info}, sort_keys=False)
        tmp = self.path / "metadata.yaml.tmp"
        tmp.write_text(text)
        os.replace(tmp, self.path / "metadata.yaml")


@functools.lru_cache(maxsize=32)
def _template(msgtype: str, names: tuple[str, ...], n: int) -> tuple[np.ndarray, _cdr.Layout]:
    store = typestore()
    T = store.types["builtin_interfaces/msg/Time"]
    H = store.types["std_msgs/msg/Header"]
    hdr = H(stamp=T(sec=0, nanosec=0), frame_id="")
    z, e = np.zeros(n), np.zeros(0)
    if msgtype == JOINT_STATE_TYPE:
        msg = store.types[msgtype](header=hdr, name=list(names), position=z, velocity=e, effort=e)
    else:
        msg = store.types[msgtype](header=hdr, name=list(names), current=z)
    raw = bytes(store.serialize_cdr(msg, msgtype))
    lay = _cdr.layout(raw, _cdr.FLOAT_ARRAYS[msgtype])
    assert lay is not None
    return np.frombuffer(raw, np.uint8), lay


def encode_messages(
    msgtype: str, names: Sequence[str], stamps_ns: np.ndarray, values: np.ndarray
) -> np.ndarray:
    """CDR bytes of many JointState (position) or CurrentReference (current) messages at once.

    ``stamps_ns`` (N,) header stamps, ``values`` (N, len(names)); returns ``(N, L) uint8``, one
    serialized message per row (empty frame id; JointState velocity and effort empty).
    """
    values = np.asarray(values, float)
    stamps_ns = np.asarray(stamps_ns, np.int64)
    tpl, lay = _template(msgtype, tuple(names), values.shape[1])
    out = np.tile(tpl, (len(stamps_ns), 1))
    sec, nsec = np.divmod(stamps_ns, 1_000_000_000)
    out[:, 4:8] = sec.astype("<i4").view(np.uint8).reshape(-1, 4)
    out[:, 8:12] = nsec.astype("<u4").view(np.uint8).reshape(-1, 4)
    off, c = lay.arrays[0]
    out[:, off : off + 8 * c] = (
        np.ascontiguousarray(values, "<f8").view(np.uint8).reshape(-1, 8 * c)
    )
    return out


def write_bag(
    path: str | Path,
    stamps_ns: np.ndarray,
    q: np.ndarray,
    v_tau: np.ndarray,
    condition: str,
    payload_mass: float,
    joint_names: Sequence[str] = ("q11", "q12", "q13"),
    extra: Mapping[str, str] | None = None,
    *,
    compression: str = "zstd",
    chunk_duration_s: float = 0.5,
) -> Path:
    """Write a tagged rosbag2 bag of /orthoglide/joint_states and /orthoglide/current_reference.

    ``stamps_ns`` (N,) int controller ticks (ns, used for header.stamp and as log/publish time),
    ``q`` (N, 3) actuated joint positions [m], ``v_tau`` (N, 3) current references [A], columns in
    ``joint_names`` order. ``extra``: additional string entries for metadata.yaml custom_data
    (e.g. the simulator's seed). Encoding is vectorised, chunk by chunk (≈ 0.5 M messages/s,
    memory O(chunk)).
    Returns the bag directory path.
    """
    tags = BagTags.checked(condition, payload_mass)
    stamps = np.asarray(stamps_ns)
    q = np.asarray(q, float)
    v_tau = np.asarray(v_tau, float)
    n = len(stamps)
    if stamps.ndim != 1 or not np.issubdtype(stamps.dtype, np.integer):
        raise DataError("stamps_ns must be a 1-D integer array of nanoseconds")
    stamps = stamps.astype(np.int64)
    k = len(joint_names)
    if q.shape != (n, k) or v_tau.shape != (n, k):
        raise DataError(f"q and v_tau must be ({n}, {k}); got {q.shape} and {v_tau.shape}")
    if n and (stamps.min() < 0 or np.any(np.diff(stamps) <= 0)):
        raise DataError("stamps_ns must be non-negative and strictly increasing")
    w = BagWriter(
        Path(path),
        tags,
        compression=compression,
        custom_data={key: str(val) for key, val in (extra or {}).items()},
    )
    w.open()
    try:
        c_js = w.add_topic(JOINT_STATES_TOPIC, JOINT_STATE_TYPE)
        c_cr = w.add_topic(CURRENT_REFERENCE_TOPIC, CURRENT_REFERENCE_TYPE)
        names = tuple(joint_names)
        f = w._file
        assert f is not None
        step_ns = chunk_duration_s * 1e9
        i = 0
        while i < n:
            j = int(np.searchsorted(stamps, stamps[i] + step_ns, side="left"))
            j = max(j, i + 1)
            m = j - i
            st = stamps[i:j]  # encode chunk by chunk: memory stays O(chunk)
            rec_js = _mcap.message_records(
                c_js, st, st, encode_messages(JOINT_STATE_TYPE, names, st, q[i:j]), i
            )
            rec_cr = _mcap.message_records(
                c_cr, st, st, encode_messages(CURRENT_REFERENCE_TYPE, names, st, v_tau[i:j]), i
            )
            pair = np.concatenate(
                [rec_js, rec_cr], axis=1
            )  # one tick: joint state then current reference
            stride, lj = pair.shape[1], rec_js.shape[1]
            offs = np.empty(2 * m, np.int64)
            offs[0::2] = np.arange(m) * stride
            offs[1::2] = offs[0::2] + lj
            cids = np.tile(np.array([c_js, c_cr]), m)
            times = np.repeat(stamps[i:j], 2)
            f.add_message_block(cids, times, pair.tobytes(), offs)
            f.flush_chunk()
            i = j
        for t in w.topics.values():
            t.count = t.sequence = n
        fstat = w.files[-1]
        fstat.count = 2 * n
        if n:
            fstat.start, fstat.end = int(stamps[0]), int(stamps[-1])
        w.close()
    except BaseException:
        w.abort()
        raise
    return Path(path)
