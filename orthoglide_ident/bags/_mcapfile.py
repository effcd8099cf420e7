"""One .mcap file being written, through the official MCAP library (``mcap.writer.Writer``).

Laid out as rosbag2's MCAP storage plugin lays out its files: profile ``ros2``; metadata records
first (``orthoglide`` tag, ``rosbag2`` bag metadata); schemas (ros2msg) and channels (CDR, offered
QoS in their metadata) inside the chunks, so that ``mcap recover`` finds them in a file cut short;
log times non-decreasing (checked here); chunk + message indexes, statistics, summary offsets and
every CRC (chunks, data section, summary). The caller decides when a chunk ends (time-bounded
chunks: :meth:`McapFile.flush_chunk`); the library never closes one on its own.
"""

from __future__ import annotations

import fcntl
import os
from collections.abc import Sequence
from pathlib import Path
from typing import IO

from mcap.writer import LIBRARY_IDENTIFIER, CompressionType, IndexType, Writer

from orthoglide_ident import __version__
from orthoglide_ident.errors import BagError, DataError

LIBRARY = f"orthoglide_ident/{__version__} {LIBRARY_IDENTIFIER}"
PROFILE = "ros2"
COMPRESSIONS = {"zstd": CompressionType.ZSTD, "lz4": CompressionType.LZ4, "": CompressionType.NONE,
                "none": CompressionType.NONE}
MESSAGE_OVERHEAD = 31  # bytes of a message record besides its data (opcode, length, header)
_NEVER = 1 << 62  # chunk size given to the library: chunks end only when we say so


def compression_type(name: str) -> CompressionType:
    """``zstd`` | ``lz4`` | ``''`` (or ``none``) → the library's chunk compression."""
    try:
        return COMPRESSIONS[name]
    except KeyError:
        raise BagError(f"unknown chunk compression {name!r}: use zstd, lz4 or none") from None


def _lock(fh: IO[bytes]) -> None:
    """Hold an exclusive advisory lock on a file being written, released when it is closed or the
    process dies: a recorder starting later takes a locked file that is not closed for one still
    being written, not for a killed recorder's (reindex.left_open)."""
    try:
        fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        pass  # a file system without locks: left_open then cannot tell


class _Sink:
    """The stream handed to the library: counts bytes, sends them through ``McapFile._out``."""

    def __init__(self, owner: McapFile) -> None:
        self.owner = owner
        self.pos = 0

    def write(self, data: bytes) -> int:
        self.owner._out(data)
        self.pos += len(data)
        return len(data)

    def tell(self) -> int:
        return self.pos

    def flush(self) -> None:
        self.owner._flush_os()


class McapFile:
    """One .mcap file: ``add_*`` while open, ``flush_chunk`` to end a chunk, then ``close``.

    ``compression``: ``zstd``, ``lz4`` or ``''``; ``check_order``: DataError when a log time goes
    back (off only to copy another writer's file as it is). Times in ns. Messages are held in the
    open chunk (``pending_bytes``, first log time ``chunk_start_time``) until :meth:`flush_chunk`
    writes it and flushes the OS file, so a killed process loses only the open chunk.
    """

    def __init__(
        self,
        path: Path,
        *,
        compression: str = "zstd",
        library: str = LIBRARY,
        profile: str = PROFILE,
        check_order: bool = True,
    ) -> None:
        kind = compression_type(compression)
        self.check_order = check_order
        self.path = Path(path)
        self._fh: IO[bytes] | None = self.path.open("xb")
        _lock(self._fh)
        self._sink = _Sink(self)
        self._writer = Writer(
            self._sink,  # type: ignore[arg-type]
            chunk_size=_NEVER,
            compression=kind,
            index_types=IndexType.ALL,
            enable_crcs=True,
            enable_data_crcs=True,
        )
        self._writer.start(profile, library)
        self.message_count = 0
        self.last_log_time = 0
        self.pending_bytes = 0
        self.chunk_start_time = 0

    # -- the OS file (all bytes go through _out) ----------------------------------------------
    def _out(self, data: bytes) -> None:
        if self._fh is None:
            raise BagError(f"{self.path} is closed")
        self._fh.write(data)

    def _flush_os(self) -> None:
        if self._fh is not None:
            self._fh.flush()

    @property
    def size(self) -> int:
        """Bytes written to the file so far (the open chunk not included)."""
        return self._sink.pos

    # -- records -------------------------------------------------------------------------------
    def add_metadata(self, name: str, items: dict[str, str]) -> None:
        """An MCAP metadata record (written at once, outside the chunks)."""
        self._writer.add_metadata(name, dict(items))

    def add_schema(self, name: str, encoding: str, data: str | bytes) -> int:
        """Register a schema (written in the open chunk); returns its id in this file."""
        raw = data.encode() if isinstance(data, str) else bytes(data)
        return self._writer.register_schema(name, encoding, raw)

    def add_channel(
        self, schema_id: int, topic: str, encoding: str, metadata: dict[str, str]
    ) -> int:
        """Register a channel (written in the open chunk); returns its id in this file."""
        return self._writer.register_channel(topic, encoding, schema_id, dict(metadata))

    def add_message(self, channel_id: int, sequence: int, log_time: int, publish_time: int,
                    data: bytes | memoryview) -> None:
        """Add a message to the open chunk. DataError if ``log_time`` goes back in this file."""
        if log_time < self.last_log_time and self.check_order:
            raise DataError(
                f"{self.path.name}: log time {log_time} ns is before the previous message's "
                f"{self.last_log_time} ns; log times must not decrease within a file")
        if not self.pending_bytes:
            self.chunk_start_time = log_time
        self._writer.add_message(channel_id, log_time, data, publish_time,  # type: ignore[arg-type]
                                 sequence & 0xFFFFFFFF)
        self.last_log_time = log_time
        self.pending_bytes += MESSAGE_OVERHEAD + len(data)
        self.message_count += 1

    # -- chunks and closing --------------------------------------------------------------------
    def flush_chunk(self, sync: bool = False) -> None:
        """Write the open chunk and its message indexes, flush to the OS (and fsync if asked)."""
        self.pending_bytes = 0
        self._writer.flush()
        if sync and self._fh is not None:
            os.fsync(self._fh.fileno())

    def close(self, closing_metadata: Sequence[tuple[str, dict[str, str]]] = ()) -> None:
        """Write the last chunk, ``closing_metadata`` records, data end, summary and footer."""
        if self._fh is None:
            return
        self.flush_chunk()
        for name, items in closing_metadata:
            self.add_metadata(name, items)
        self._writer.finish()
        fh, self._fh = self._fh, None
        fh.close()

    def abort(self) -> None:
        """Close the OS file without a summary (what is on disk stays readable)."""
        fh, self._fh = self._fh, None
        if fh is not None:
            try:
                fh.close()
            except OSError:
                pass  # the disk is full: what reached it stays readable
