"""A recording in progress: callbacks queue serialized messages, a writer thread writes them.

No rclpy here: the recorder node's subscription callbacks call ``queue.append((topic, cdr_bytes,
receive_time_ns, publish_time_ns))``; the thread parses the header stamp of the stamped topics (for
the live count of missing ticks), writes through :class:`BagWriter`, flushes chunks that are older
than the chunk duration, and on a write error (disk full) stops with a clear message, keeping what
was written.
"""

from __future__ import annotations

import collections
import struct
import threading
import time
from typing import Any

from orthoglide_ident.errors import OrthoglideError

from .info import TickCounter
from .writer import BagWriter

_STAMP = struct.Struct("<iI")


class Recording:
    """One bag being written: a queue filled by the callbacks, drained by a writer thread."""

    def __init__(self, writer: BagWriter, stamped: set[str], rate_hz: float, log: Any) -> None:
        self.writer = writer
        self.queue: collections.deque[tuple] = collections.deque()
        self.channels: dict[str, int] = {}
        self.counters = {t: TickCounter(rate_hz) for t in stamped}
        self.registered: set[str] = set()
        self.stamped = stamped
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
                    topic, data, a, b = q.popleft()
                    if data is None:  # a topic to register: (topic, None, msgtype, qos)
                        try:
                            self.channels[topic] = w.add_topic(topic, a, qos=b)
                        except OrthoglideError as exc:
                            self._log.warning(f"not recording {topic}: {exc}")
                        continue
                    cid = self.channels.get(topic)
                    if cid is None:
                        continue
                    if topic in self.stamped and len(data) >= 12:
                        sec, nsec = _STAMP.unpack_from(data, 4)
                        self.counters[topic].add(sec * 1_000_000_000 + nsec)
                    w.write(cid, data, a, b)
                if stopping:
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

    def _fail(self, message: str) -> None:
        self.alive = False
        self.error = message
        self._log.error(message)
        self.writer.abort()

    def stop(self) -> str:
        """Drain the queue, close the bag; returns the summary line (or the error)."""
        self.alive = False
        self._stop.set()
        self._thread.join()
        counts = ", ".join(f"{n} {t}" for t, n in self.writer.counts.items())
        missing = ", ".join(f"{c.missing} missing on {t}" for t, c in self.counters.items())
        return self.error or f"{self.writer.path}: wrote {counts}; samples missing: {missing}"
