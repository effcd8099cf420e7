"""A recording in progress: callbacks queue serialized messages, a writer thread writes them.

No rclpy here: the recorder node's subscription callbacks call ``queue.append((topic, cdr_bytes,
receive_time_ns, publish_time_ns))``; the thread parses the header stamp of the stamped topics (for
the live count of missing samples, against each source's own step: info.TickCounter), writes
through :class:`BagWriter`, flushes chunks that are older than the chunk duration, and on a
write error (disk full) stops with a clear message, keeping what was written.
"""

from __future__ import annotations

import collections
import os
import re
import struct
import threading
import time
from datetime import datetime
from pathlib import Path
from typing import Any

from orthoglide_ident.errors import BagError, ConfigError, OrthoglideError

from ._tags import BagTags
from .info import TickCounter
from .writer import BagWriter

_STAMP = struct.Struct("<iI")


BAG_NAME = re.compile(r"^[A-Za-z0-9_.+-]+$")


def open_bag(
    output_dir: str | Path,
    name: str,
    tags: BagTags,
    compression: str = "zstd",
    chunk_duration_s: float = 0.5,
    split_duration_s: float = 0.0,
    split_size_bytes: int = 0,
) -> BagWriter:
    """The writer of a new recording ``output_dir/name`` (name "" = <condition>_<date>_<time>).

    Checks the name and that the folder is writable before anything is created, so that a refused
    start leaves nothing behind; ConfigError / BagError with a one-line reason.
    """
    name = name or f"{tags.condition}_{datetime.now():%Y%m%d_%H%M%S}"
    if not BAG_NAME.match(name) or name in (".", ".."):
        raise ConfigError(f"bad bag name {name!r}: use letters, digits, '_', '-', '.', '+'")
    out = Path(output_dir).expanduser()
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ConfigError(
            f"output folder {out} is not writable: cannot create it ({exc.strerror or exc})"
        ) from None
    if not os.access(out, os.W_OK | os.X_OK):
        raise ConfigError(f"output folder {out} is not writable")
    writer = BagWriter(
        out / name,
        tags,
        compression="" if compression in ("none", "") else compression,
        chunk_duration_s=chunk_duration_s,
        split_duration_s=split_duration_s or None,
        split_size_bytes=split_size_bytes or None,
    )
    try:
        return writer.open()
    except OSError as exc:
        raise BagError(f"cannot open {out / name}: {exc.strerror or exc}") from None


class TickAligner:
    """Keeps the stamped topics of a recording on the same ticks, in arrival order.

    The controller publishes the two messages of a tick one after the other, so a recording that
    starts or stops between them would hold one topic's tick without the other's. Messages are
    released in arrival order once every stamped topic has reached their stamp; the first tick
    is the first one every stamped topic delivered, and ``finish()`` ends all of them on the last
    tick they all delivered. Messages of other topics go through, in order.
    """

    def __init__(self, stamped: set[str]) -> None:
        self.stamped = stamped
        self.first: dict[str, int] = {}
        self.latest: dict[str, int] = {}
        self.start: int | None = None
        self.held: collections.deque[tuple] = collections.deque()

    def push(self, item: tuple, stamp: int | None) -> list[tuple]:
        """Queue ``item`` (stamp: its header stamp when its topic is stamped); what may be
        written."""
        if stamp is not None:
            topic = item[0]
            self.first.setdefault(topic, stamp)
            self.latest[topic] = max(stamp, self.latest.get(topic, stamp))
            if self.start is None and len(self.first) == len(self.stamped):
                self.start = max(self.first.values())
        self.held.append((item, stamp))
        return self._release(None)

    def finish(self) -> list[tuple]:
        """Everything still held, cut at the last tick every stamped topic delivered."""
        end = min(self.latest.values()) if len(self.latest) == len(self.stamped) else None
        return self._release(end, final=True)

    def _release(self, end: int | None, final: bool = False) -> list[tuple]:
        if self.start is None and not final:
            return []
        common = min(self.latest.values()) if self.latest else None
        out = []
        while self.held:
            item, stamp = self.held[0]
            if stamp is not None and not final and stamp > common:
                break  # another stamped topic has not reached this tick yet
            self.held.popleft()
            if stamp is None or (self.start is not None and stamp >= self.start
                                 and (end is None or stamp <= end)):
                out.append(item)
        return out


class Recording:
    """One bag being written: a queue filled by the callbacks, drained by a writer thread."""

    def __init__(self, writer: BagWriter, stamped: set[str], rate_hz: float, log: Any) -> None:
        self.writer = writer
        self.queue: collections.deque[tuple] = collections.deque()
        self.channels: dict[str, int] = {}
        self.counters = {t: TickCounter(rate_hz) for t in stamped}
        self.registered: set[str] = set()
        self.stamped = stamped
        self.aligner = TickAligner(stamped)
        self._log_time = 0  # last log time written (ns)
        self.error = ""
        self.alive = True
        self._stop = threading.Event()
        self._log = log
        self._thread = threading.Thread(target=self._run, name="bag-writer", daemon=True)
        self._thread.start()

    def add_topic(self, topic: str, msgtype: str, qos: list[dict[str, Any]]) -> None:
        self.queue.append((topic, None, msgtype, qos))

    def _run(self) -> None:
        w, q = self.writer, self.queue
        try:
            while True:
                stopping = self._stop.is_set()
                while q:
                    item = q.popleft()
                    topic, data, a, b = item
                    if data is None:  # a topic to register: (topic, None, msgtype, qos)
                        try:
                            self.channels[topic] = w.add_topic(topic, a, qos=b)
                        except OrthoglideError as exc:
                            self._log.warning(f"not recording {topic}: {exc}")
                        continue
                    stamp = None
                    if topic in self.stamped and len(data) >= 12:
                        sec, nsec = _STAMP.unpack_from(data, 4)
                        stamp = sec * 1_000_000_000 + nsec
                    self._write(self.aligner.push(item, stamp))
                if stopping:
                    self._write(self.aligner.finish())
                    break
                w.flush_if_due(time.time_ns())
                self._stop.wait(0.02)
            w.close()
        except (OSError, OrthoglideError) as exc:
            self._fail(
                f"recording to {w.path} ended by a write error: {exc}; what was written is kept"
            )
        except Exception as exc:  # a bug must not lose the bag: keep what is on disk, say why
            self._fail(
                f"recording to {w.path} ended by an internal error ({type(exc).__name__}: {exc}); "
                "what was written is kept"
            )

    def _write(self, items: list[tuple]) -> None:
        """Write in arrival order; log times never decrease in a file (MCAP tools check it), so a
        message received a moment before the previous one written is logged at that one's time."""
        for topic, data, received, published in items:
            cid = self.channels.get(topic)
            if cid is None:
                continue
            if topic in self.stamped:
                sec, nsec = _STAMP.unpack_from(data, 4)
                self.counters[topic].add(sec * 1_000_000_000 + nsec)
            self._log_time = max(self._log_time, received)
            self.writer.write(cid, data, self._log_time, published)

    def _fail(self, message: str) -> None:
        self.alive = False
        self.error = message
        self._log.error(message)
        self.writer.abort()

    def stop(self, incomplete: str = "") -> str:
        """Drain the queue, close the bag (tagged incomplete with the reason when ``incomplete``
        is given); returns the summary line (or the error)."""
        if incomplete:
            self.writer.mark_incomplete(incomplete)
        self.alive = False
        self._stop.set()
        self._thread.join()
        # by topic name: channels register in arrival order and ``stamped`` is a set
        counts = ", ".join(f"{n} {t}" for t, n in sorted(self.writer.counts.items()))
        for c in self.counters.values():
            c.finish()
        missing = ", ".join(f"{c.missing} missing on {t} ({c.describe()})"
                            for t, c in sorted(self.counters.items()))
        tail = f"; tagged incomplete: {incomplete}" if incomplete else ""
        return self.error or f"{self.writer.path}: wrote {counts}; samples missing: {missing}{tail}"
