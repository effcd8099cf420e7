"""One message per period of the stamps: a 1 kHz topic at a rate a browser plots.

The choice depends on the stamps only (the first message of each period ``k·T ≤ stamp <
(k+1)·T``), not on how messages arrive in batches, so a topic at any rate comes out at
min(its rate, 1/T) whatever the batching, and the same ticks are picked on every topic that shares
the stamps (joint states, currents and setpoints of one tick together).
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np


def cdr_stamps(raw: Sequence[bytes]) -> np.ndarray:
    """header.stamp (ns) of serialized messages whose first field is a std_msgs/Header (CDR:
    4 bytes of encapsulation, then sec int32, nanosec uint32), without deserializing them."""
    if not raw:
        return np.empty(0, np.int64)
    heads = np.frombuffer(
        b"".join(r[4:12] for r in raw), dtype=np.dtype([("sec", "<i4"), ("nanosec", "<u4")])
    )
    return heads["sec"].astype(np.int64) * 1_000_000_000 + heads["nanosec"].astype(np.int64)


class StampDecimator:
    """Indices of the messages to keep, one per ``period_ns`` of stamps (ns)."""

    def __init__(self, period_ns: int) -> None:
        if period_ns <= 0:
            raise ValueError(f"decimation period must be > 0 ns, got {period_ns}")
        self.period_ns = int(period_ns)
        self.last_bin: int | None = None

    def pick(self, stamps_ns: np.ndarray) -> np.ndarray:
        """Indices into ``stamps_ns`` (in arrival order) of the first message of each new period;
        a stamp of a period already passed (late, or repeated) is not picked."""
        bins = np.asarray(stamps_ns, dtype=np.int64) // self.period_ns
        if bins.size == 0:
            return np.empty(0, dtype=int)
        start = np.iinfo(np.int64).min if self.last_bin is None else self.last_bin
        before = np.maximum.accumulate(np.concatenate([[start], bins]))[:-1]  # newest period so far
        self.last_bin = int(max(start, bins.max()))
        return np.flatnonzero(bins > before)
