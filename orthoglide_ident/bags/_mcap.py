"""Minimal MCAP record layer: a chunked writer with CRCs and indexes, and a crash-tolerant scanner.

Written against the MCAP specification (https://mcap.dev/spec). The writer produces what rosbag2's
MCAP storage produces (profile ``ros2``, ros2msg schemas, CDR channels, chunk + message indexes,
summary with statistics, metadata index and summary offsets, all CRCs). The scanner walks the data
section record by record, so a file cut short by a crash is read up to its last complete record.
"""

from __future__ import annotations

import mmap
import struct
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

import numpy as np

from orthoglide_ident.errors import BagError

MAGIC = b"\x89MCAP0\r\n"
OP_HEADER, OP_FOOTER, OP_SCHEMA, OP_CHANNEL, OP_MESSAGE = 0x01, 0x02, 0x03, 0x04, 0x05
OP_CHUNK, OP_MESSAGE_INDEX, OP_CHUNK_INDEX, OP_STATISTICS = 0x06, 0x07, 0x08, 0x0B
OP_METADATA, OP_METADATA_INDEX, OP_SUMMARY_OFFSET, OP_DATA_END = 0x0C, 0x0D, 0x0E, 0x0F

_u8, _u16, _u32, _u64 = (
    struct.Struct("<B"),
    struct.Struct("<H"),
    struct.Struct("<I"),
    struct.Struct("<Q"),
)
_rec_head = struct.Struct("<BQ")
_msg_head = struct.Struct("<BQHIQQ")  # opcode, length, channel, sequence, log_time, publish_time
MSG_HEAD_LEN = _msg_head.size  # 31


def _s(text: str) -> bytes:
    b = text.encode()
    return _u32.pack(len(b)) + b


def _map(items: dict[str, str]) -> bytes:
    body = b"".join(_s(k) + _s(v) for k, v in items.items())
    return _u32.pack(len(body)) + body


def _record(op: int, body: bytes) -> bytes:
    return _rec_head.pack(op, len(body)) + body


def _compressor(name: str) -> Any:
    if name == "zstd":
        import zstandard

        return zstandard.ZstdCompressor(level=1).compress
    if name == "lz4":
        import lz4.frame

        return lambda data: lz4.frame.compress(data, compression_level=0)
    if name == "":
        return bytes
    raise BagError(f"unknown chunk compression {name!r}: use zstd, lz4 or ''")


def _decompress(name: str, data: bytes, size: int) -> bytes:
    if name == "":
        return bytes(data)
    if name == "zstd":
        import zstandard

        return zstandard.ZstdDecompressor().decompress(data, max_output_size=size)
    if name == "lz4":
        import lz4.frame

        return lz4.frame.decompress(data)
    raise BagError(f"unsupported chunk compression {name!r}")


def message_records(
    channel_id: int,
    log_times: np.ndarray,
    publish_times: np.ndarray,
    payload: np.ndarray,
    first_sequence: int = 0,
) -> np.ndarray:
    """MCAP message records, vectorised: payloads ``(n, L) uint8`` → records ``(n, 31 + L)``."""
    n, length = payload.shape
    dt = np.dtype(
        [
            ("op", "u1"),
            ("len", "<u8"),
            ("ch", "<u2"),
            ("seq", "<u4"),
            ("log", "<u8"),
            ("pub", "<u8"),
            ("data", "u1", (length,)),
        ]
    )
    rec = np.empty(n, dt)
    rec["op"] = OP_MESSAGE
    rec["len"] = MSG_HEAD_LEN - 9 + length
    rec["ch"] = channel_id
    rec["seq"] = np.arange(first_sequence, first_sequence + n, dtype=np.uint64).astype(np.uint32)
    rec["log"] = log_times
    rec["pub"] = publish_times
    rec["data"] = payload
    return rec.view(np.uint8).reshape(n, dt.itemsize)


@dataclass
class _ChannelStat:
    count: int = 0


class McapFileWriter:
    """One .mcap file: header, metadata, schemas, channels, compressed chunks, summary, footer.

    Messages are buffered into the current chunk; :meth:`flush_chunk` writes it (chunk record then
    its message indexes) and flushes the OS file, so a killed process loses only the open chunk.
    """

    def __init__(
        self, path: Path, *, compression: str = "zstd", library: str = "orthoglide_ident"
    ) -> None:
        self.path = Path(path)
        self._fh: IO[bytes] | None = self.path.open("xb")
        self._crc = 0
        self._pos = 0
        self._compress = _compressor(compression)
        self.compression = compression
        self._schemas: dict[int, bytes] = {}
        self._channels: dict[int, bytes] = {}
        self._chunk_indexes: list[bytes] = []
        self._metadata_indexes: list[bytes] = []
        self._stats: dict[int, int] = {}
        self.message_count = 0
        self.start_time = 2**63 - 1
        self.end_time = 0
        self._reset_chunk()
        self._out(MAGIC + _record(OP_HEADER, _s("ros2") + _s(library)))

    # -- low level -----------------------------------------------------------------------------
    def _out(self, data: bytes) -> None:
        assert self._fh is not None, "file closed"
        self._fh.write(data)
        self._crc = zlib.crc32(data, self._crc)
        self._pos += len(data)

    def _reset_chunk(self) -> None:
        self._buf: list[bytes] = []
        self._buf_len = 0
        self._idx: dict[int, list[tuple[int, int]] | list[np.ndarray]] = {}
        self._c_start = 2**63 - 1
        self._c_end = 0

    @property
    def size(self) -> int:
        """Bytes written to the file so far (the open chunk not included)."""
        return self._pos

    @property
    def pending_bytes(self) -> int:
        return self._buf_len

    @property
    def chunk_start_time(self) -> int:
        return self._c_start

    # -- records -------------------------------------------------------------------------------
    def add_metadata(self, name: str, items: dict[str, str]) -> None:
        start = self._pos
        self._out(_record(OP_METADATA, _s(name) + _map(items)))
        self._metadata_indexes.append(_u64.pack(start) + _u64.pack(self._pos - start) + _s(name))

    def add_schema(self, schema_id: int, name: str, encoding: str, data: str) -> None:
        raw = data.encode()
        rec = _record(
            OP_SCHEMA, _u16.pack(schema_id) + _s(name) + _s(encoding) + _u32.pack(len(raw)) + raw
        )
        self._schemas[schema_id] = rec
        self._out(rec)

    def add_channel(
        self, channel_id: int, schema_id: int, topic: str, encoding: str, metadata: dict[str, str]
    ) -> None:
        rec = _record(
            OP_CHANNEL,
            _u16.pack(channel_id)
            + _u16.pack(schema_id)
            + _s(topic)
            + _s(encoding)
            + _map(metadata),
        )
        self._channels[channel_id] = rec
        self._stats.setdefault(channel_id, 0)
        self._out(rec)

    def add_message(
        self,
        channel_id: int,
        sequence: int,
        log_time: int,
        publish_time: int,
        data: bytes | memoryview,
    ) -> None:
        idx = self._idx.setdefault(channel_id, [])
        idx.append((log_time, self._buf_len))  # type: ignore[arg-type]
        head = _msg_head.pack(
            OP_MESSAGE,
            MSG_HEAD_LEN - 9 + len(data),
            channel_id,
            sequence & 0xFFFFFFFF,
            log_time,
            publish_time,
        )
        self._buf.append(head)
        self._buf.append(bytes(data))
        self._buf_len += MSG_HEAD_LEN + len(data)
        self._stats[channel_id] += 1
        self.message_count += 1
        if log_time < self._c_start:
            self._c_start = log_time
        if log_time > self._c_end:
            self._c_end = log_time

    def add_message_block(
        self, channel_ids: np.ndarray, log_times: np.ndarray, records: bytes, offsets: np.ndarray
    ) -> None:
        """Append pre-built message records (``offsets`` relative to ``records``) to the chunk."""
        base = self._buf_len
        for cid in np.unique(channel_ids):
            sel = channel_ids == cid
            pairs = np.empty((int(sel.sum()), 2), np.uint64)
            pairs[:, 0] = log_times[sel]
            pairs[:, 1] = offsets[sel] + base
            self._idx.setdefault(int(cid), []).append(pairs)  # type: ignore[arg-type]
            self._stats[int(cid)] += int(sel.sum())
        self._buf.append(records)
        self._buf_len += len(records)
        self.message_count += len(log_times)
        if len(log_times):
            self._c_start = min(self._c_start, int(log_times.min()))
            self._c_end = max(self._c_end, int(log_times.max()))

    def flush_chunk(self, sync: bool = False) -> None:
        """Write the open chunk and its message indexes; flush to the OS (and fsync if asked)."""
        if self._buf_len == 0:
            return
        raw = b"".join(self._buf)
        comp = self._compress(raw)
        body = (
            _u64.pack(self._c_start)
            + _u64.pack(self._c_end)
            + _u64.pack(len(raw))
            + _u32.pack(zlib.crc32(raw))
            + _s(self.compression)
            + _u64.pack(len(comp))
        )
        chunk_start = self._pos
        # one write call for chunk + indexes, so a kill leaves either all of it or a short tail
        parts = [_rec_head.pack(OP_CHUNK, len(body) + len(comp)), body, comp]
        chunk_len = 9 + len(body) + len(comp)
        offsets = []
        idx_len = 0
        for cid in sorted(self._idx):
            entries = self._idx[cid]
            if entries and isinstance(entries[0], np.ndarray):
                arr = np.concatenate(entries).astype("<u8")  # type: ignore[arg-type]
            else:
                arr = np.asarray(entries, dtype="<u8").reshape(-1, 2)
            blob = arr.tobytes()
            rec = _record(OP_MESSAGE_INDEX, _u16.pack(cid) + _u32.pack(len(blob)) + blob)
            offsets.append((cid, chunk_start + chunk_len + idx_len))
            parts.append(rec)
            idx_len += len(rec)
        self._out(b"".join(parts))
        off_map = b"".join(_u16.pack(c) + _u64.pack(o) for c, o in offsets)
        self._chunk_indexes.append(
            _u64.pack(self._c_start)
            + _u64.pack(self._c_end)
            + _u64.pack(chunk_start)
            + _u64.pack(chunk_len)
            + _u32.pack(len(off_map))
            + off_map
            + _u64.pack(idx_len)
            + _s(self.compression)
            + _u64.pack(len(comp))
            + _u64.pack(len(raw))
        )
        self.start_time = min(self.start_time, self._c_start)
        self.end_time = max(self.end_time, self._c_end)
        self._reset_chunk()
        assert self._fh is not None
        self._fh.flush()
        if sync:
            import os

            os.fsync(self._fh.fileno())

    def close(self, extra_metadata: dict[str, dict[str, str]] | None = None) -> None:
        """Flush the last chunk, write metadata records, data end, summary and footer."""
        if self._fh is None:
            return
        self.flush_chunk()
        for name, items in (extra_metadata or {}).items():
            self.add_metadata(name, items)
        self._out(_record(OP_DATA_END, _u32.pack(self._crc)))
        summary_start = self._pos
        self._crc = 0  # from here on: the summary CRC
        groups: list[tuple[int, int, int]] = []

        def group(op: int, records: list[bytes]) -> None:
            if records:
                start = self._pos
                self._out(b"".join(records))
                groups.append((op, start, self._pos - start))

        group(OP_SCHEMA, list(self._schemas.values()))
        group(OP_CHANNEL, list(self._channels.values()))
        group(OP_CHUNK_INDEX, [_record(OP_CHUNK_INDEX, b) for b in self._chunk_indexes])
        group(OP_METADATA_INDEX, [_record(OP_METADATA_INDEX, b) for b in self._metadata_indexes])
        counts = b"".join(_u16.pack(c) + _u64.pack(n) for c, n in sorted(self._stats.items()))
        start, end = (self.start_time, self.end_time) if self.message_count else (0, 0)
        stats = (
            _u64.pack(self.message_count)
            + _u16.pack(len(self._schemas))
            + _u32.pack(len(self._channels))
            + _u32.pack(0)
            + _u32.pack(len(self._metadata_indexes))
            + _u32.pack(len(self._chunk_indexes))
            + _u64.pack(start)
            + _u64.pack(end)
            + _u32.pack(len(counts))
            + counts
        )
        group(OP_STATISTICS, [_record(OP_STATISTICS, stats)])
        offset_start = self._pos
        self._out(
            b"".join(
                _record(OP_SUMMARY_OFFSET, _u8.pack(op) + _u64.pack(s) + _u64.pack(n))
                for op, s, n in groups
            )
        )
        # summary CRC covers the summary section and the footer up to its summary_crc field
        head = _rec_head.pack(OP_FOOTER, 20) + _u64.pack(summary_start) + _u64.pack(offset_start)
        summary_crc = zlib.crc32(head, self._crc)
        assert self._fh is not None
        self._out(head + _u32.pack(summary_crc) + MAGIC)
        self._fh.close()
        self._fh = None

    def abort(self) -> None:
        """Close the OS file without writing a summary (what is on disk stays readable)."""
        if self._fh is not None:
            try:
                self._fh.close()
            finally:
                self._fh = None


# -- scanning ----------------------------------------------------------------------------------
@dataclass
class Schema:
    id: int
    name: str
    encoding: str
    data: bytes


@dataclass
class Channel:
    id: int
    schema_id: int
    topic: str
    encoding: str
    metadata: dict[str, str]


@dataclass
class ChunkRef:
    """A complete chunk found in the data section, with the message indexes that follow it."""

    start: int
    end: int
    offset: int  # of the compressed payload in the file
    compressed_size: int
    uncompressed_size: int
    crc: int
    compression: str
    indexes: dict[int, tuple[int, int]] = field(default_factory=dict)  # channel -> (offset, length)


@dataclass
class ScanResult:
    path: Path
    size: int
    schemas: dict[int, Schema]
    channels: dict[int, Channel]
    chunks: list[ChunkRef]
    metadata: list[tuple[str, dict[str, str]]]
    loose_messages: list[
        tuple[int, int, int]
    ]  # (channel, record offset, record length), outside chunks
    data_end: bool
    footer: bool
    complete_end: int  # end of the last complete record in the data section
    partial: tuple[int, int] | None  # (opcode, bytes) of a record cut short
    partial_times: tuple[int, int] | None  # message time span of a cut-short chunk, if readable
    buffer: Any  # mmap (or bytes) kept for decoding

    @property
    def closed(self) -> bool:
        return self.data_end and self.footer


def _rs(buf: Any, pos: int) -> tuple[str, int]:
    (n,) = _u32.unpack_from(buf, pos)
    return bytes(buf[pos + 4 : pos + 4 + n]).decode(errors="replace"), pos + 4 + n


def _rmap(buf: Any, pos: int) -> tuple[dict[str, str], int]:
    (n,) = _u32.unpack_from(buf, pos)
    end = pos + 4 + n
    pos += 4
    out = {}
    while pos < end:
        k, pos = _rs(buf, pos)
        v, pos = _rs(buf, pos)
        out[k] = v
    return out, end


def parse_schema(buf: Any, pos: int) -> Schema:
    (sid,) = _u16.unpack_from(buf, pos)
    name, p = _rs(buf, pos + 2)
    enc, p = _rs(buf, p)
    (n,) = _u32.unpack_from(buf, p)
    return Schema(sid, name, enc, bytes(buf[p + 4 : p + 4 + n]))


def parse_channel(buf: Any, pos: int) -> Channel:
    cid, sid = struct.unpack_from("<HH", buf, pos)
    topic, p = _rs(buf, pos + 4)
    enc, p = _rs(buf, p)
    meta, _ = _rmap(buf, p)
    return Channel(cid, sid, topic, enc, meta)


def scan(path: Path) -> ScanResult:
    """Walk the data section of one .mcap file. Raises BagError if it is not MCAP at all."""
    path = Path(path)
    try:
        with path.open("rb") as fh:
            size = fh.seek(0, 2)
            if size == 0:
                raise BagError(f"{path}: empty file, nothing readable")
            buf: Any = mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ)
    except OSError as exc:
        raise BagError(f"{path}: cannot open: {exc.strerror or exc}") from None
    if size < 8 or buf[:8] != MAGIC:
        raise BagError(f"{path}: not an MCAP file (bad magic bytes)")
    res = ScanResult(path, size, {}, {}, [], [], [], False, False, 8, None, None, buf)
    pos = 8
    last_chunk: ChunkRef | None = None
    while pos < size:
        if pos + 9 > size:
            if buf[pos:size] == MAGIC[: size - pos]:
                break
            res.partial = (int(buf[pos]), size - pos)
            break
        op, ln = _rec_head.unpack_from(buf, pos)
        body = pos + 9
        if body + ln > size:
            res.partial = (op, size - pos)
            if op == OP_CHUNK and size - body >= 16:
                res.partial_times = struct.unpack_from("<QQ", buf, body)
            break
        if op == OP_CHUNK:
            c_start, c_end, usize, crc = struct.unpack_from("<QQQI", buf, body)
            comp, p = _rs(buf, body + 28)
            (csize,) = _u64.unpack_from(buf, p)
            last_chunk = ChunkRef(c_start, c_end, p + 8, csize, usize, crc, comp)
            res.chunks.append(last_chunk)
        elif op == OP_MESSAGE_INDEX:
            if last_chunk is not None:
                (cid,) = _u16.unpack_from(buf, body)
                (n,) = _u32.unpack_from(buf, body + 2)
                last_chunk.indexes[cid] = (body + 6, n)
        elif op == OP_SCHEMA:
            s = parse_schema(buf, body)
            res.schemas.setdefault(s.id, s)
        elif op == OP_CHANNEL:
            c = parse_channel(buf, body)
            res.channels.setdefault(c.id, c)
        elif op == OP_METADATA:
            name, p = _rs(buf, body)
            items, _ = _rmap(buf, p)
            res.metadata.append((name, items))
        elif op == OP_MESSAGE:
            (cid,) = _u16.unpack_from(buf, body)
            res.loose_messages.append((cid, pos, 9 + ln))
        elif op == OP_DATA_END:
            res.data_end = True
        elif op == OP_FOOTER:
            res.footer = True
            res.complete_end = body + ln
            break
        if op not in (OP_FOOTER,):
            if not res.data_end:
                res.complete_end = body + ln
            last_chunk = last_chunk if op in (OP_CHUNK, OP_MESSAGE_INDEX) else None
        pos = body + ln
    return res


def chunk_bytes(res: ScanResult, chunk: ChunkRef, validate_crc: bool = True) -> bytes:
    """Decompressed records of one chunk; BagError if the chunk is corrupt."""
    raw = res.buffer[chunk.offset : chunk.offset + chunk.compressed_size]
    try:
        data = _decompress(chunk.compression, raw, chunk.uncompressed_size)
    except BagError:
        raise
    except Exception as exc:
        raise BagError(f"{res.path}: corrupt chunk at byte {chunk.offset}: {exc}") from None
    if len(data) != chunk.uncompressed_size:
        raise BagError(f"{res.path}: chunk at byte {chunk.offset} has the wrong size")
    if validate_crc and chunk.crc and zlib.crc32(data) != chunk.crc:
        raise BagError(f"{res.path}: chunk at byte {chunk.offset} fails its CRC check")
    return data


def chunk_messages(res: ScanResult, chunk: ChunkRef, data: bytes) -> dict[int, np.ndarray]:
    """Record offsets of the messages in a decompressed chunk, per channel.

    Uses the message indexes when they account for every byte of the chunk (the usual case, fully
    vectorised); otherwise walks the records, registering schemas and channels found inside.
    """
    arr = np.frombuffer(data, np.uint8)
    if chunk.indexes and all(c in res.channels for c in chunk.indexes):
        per: dict[int, np.ndarray] = {}
        total = 0
        ok = True
        for cid, (off, n) in chunk.indexes.items():
            pairs = np.frombuffer(res.buffer, "<u8", count=n // 8, offset=off).reshape(-1, 2)
            offs = pairs[:, 1].astype(np.int64)
            if len(offs) and (offs.max() + MSG_HEAD_LEN > len(data) or offs.min() < 0):
                ok = False
                break
            if len(offs) and not (arr[offs] == OP_MESSAGE).all():
                ok = False
                break
            lens = record_lengths(arr, offs)
            total += int(lens.sum())
            per[cid] = np.sort(offs)
        if ok and total == len(data):
            return per
    return _walk(res, data)


def record_lengths(arr: np.ndarray, offs: np.ndarray) -> np.ndarray:
    """Total lengths (opcode + length field + body) of the records at ``offs``."""
    if len(offs) == 0:
        return np.zeros(0, np.int64)
    idx = offs[:, None] + np.arange(1, 9)
    return arr[idx].copy().view("<u8").reshape(-1).astype(np.int64) + 9


def _walk(res: ScanResult, data: bytes) -> dict[int, np.ndarray]:
    per: dict[int, list[int]] = {}
    pos, n = 0, len(data)
    unpack = _rec_head.unpack_from
    while pos + 9 <= n:
        op, ln = unpack(data, pos)
        if op == OP_MESSAGE:
            (cid,) = _u16.unpack_from(data, pos + 9)
            per.setdefault(cid, []).append(pos)
        elif op == OP_SCHEMA:
            s = parse_schema(data, pos + 9)
            res.schemas.setdefault(s.id, s)
        elif op == OP_CHANNEL:
            c = parse_channel(data, pos + 9)
            res.channels.setdefault(c.id, c)
        pos += 9 + ln
    return {c: np.asarray(v, np.int64) for c, v in per.items()}
