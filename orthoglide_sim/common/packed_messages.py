"""The driver's per-tick messages as ready serialised bytes: built once, patched in place each tick.

A JointState, CurrentReference or JointSetpoint of the driver has the same layout at every tick
(the same joint names, three float64 per array, an empty frame_id): only its stamp and values
change. ``PackedMessage`` serialises one with rclpy (CDR, as ``publish(msg)`` would), finds where
its stamp and float64 values sit, and each tick writes the new ones there (the bags'
``CdrTemplate``, the one CDR template patcher) and hands the bytes to ``Publisher.publish``
(rclpy publishes bytes as a serialised message). The subscribers receive the same bytes as rosbags'
CDR serialisation of the message
(tests/sim/nodes/test_driver.py); the driver saves the Python message objects and their conversion,
~10 us per message.

``rclpy.serialization.serialize_message`` returns a buffer up to 8 bytes longer than the message
(its size estimate; the tail is not initialised). Published as they are, those bytes reach the
bag, where rosbags refuses them ("CDR message size mismatch"): the template is cut to the
message's own length, the shortest prefix that still deserialises.
"""
from __future__ import annotations

import struct
from collections.abc import Sequence
from typing import Any

import numpy as np
from rclpy.serialization import deserialize_message, serialize_message

from orthoglide_ident.bags.encoding import CdrTemplate

_STAMP = struct.Struct("<iI")
_SENTINEL_SEC, _SENTINEL_NSEC = 0x5EC5EC5E, 0x0A5EC0DE  # found once in the serialised template


def _exact(raw: bytes, msg_type: Any) -> bytes:
    """``raw`` without the serialiser's trailing bytes: its shortest prefix that deserialises
    (a CDR message's end is where its last field ends; no more than 8 bytes are cut)."""
    n = len(raw)
    while n > max(len(raw) - 8, 4):
        try:
            deserialize_message(raw[:n - 1], msg_type)
        except Exception:  # too short: n is the message's length
            break
        n -= 1
    return raw[:n]


class PackedMessage:
    """Serialised message of ``msg_type`` with ``name`` (joint names) and float64 arrays
    ``fields`` of len(name) values each; ``pack(sec, nanosec, *values)`` returns its bytes.
    The sentinels place the stamp and the values; the patching is the bags' CdrTemplate."""

    def __init__(self, msg_type: Any, name: Sequence[str], fields: Sequence[str]):
        n = len(name)
        msg = msg_type(name=list(name))
        msg.header.stamp.sec, msg.header.stamp.nanosec = _SENTINEL_SEC, _SENTINEL_NSEC
        sentinels = [
            [1.0e300 + (i * n + j) * 1.0e285 for j in range(n)] for i in range(len(fields))
        ]
        for field, values in zip(fields, sentinels):
            setattr(msg, field, values)
        raw = _exact(serialize_message(msg), msg_type)
        if self._find(raw, _STAMP.pack(_SENTINEL_SEC, _SENTINEL_NSEC), "header.stamp") != 4:
            raise ValueError("header.stamp is not the message's first field")
        values = struct.Struct(f"<{n}d")
        at = [self._find(raw, values.pack(*v), f) for f, v in zip(fields, sentinels)]
        self._cdr = CdrTemplate(raw, [a + 8 * j for a in at for j in range(n)])

    @staticmethod
    def _find(raw: bytes, pattern: bytes, what: str) -> int:
        at = raw.find(pattern)
        if at < 0 or raw.find(pattern, at + 1) >= 0:
            # a layout not handled here
            raise ValueError(f"cannot place {what} in the serialised message")
        return at

    def pack(self, sec: int, nanosec: int, *values: Sequence[float]) -> bytes:
        """The message's bytes with this stamp and these values (one sequence per field)."""
        return self._cdr.pack(sec, nanosec, np.concatenate([np.asarray(v, float) for v in values]))
