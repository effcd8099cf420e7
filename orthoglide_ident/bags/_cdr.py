"""Fixed-layout CDR decoding of header-stamped messages made of string[] and float64[] fields.

``sensor_msgs/JointState`` (header, name, position, velocity, effort) and
``orthoglide_msgs/CurrentReference`` (header, name, current) have a byte layout that is fixed once
the frame id and the joint names are known. :func:`layout` reads it off one message;
:func:`decode_group` then decodes many equal-length messages with numpy, after checking that every
byte outside the stamp and the float data equals the first message's.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

import numpy as np

_u32 = struct.Struct("<I")

# message type -> number of float64[] fields after `string[] name`
FLOAT_ARRAYS = {"sensor_msgs/msg/JointState": 3, "orthoglide_msgs/msg/CurrentReference": 1}


@dataclass(frozen=True)
class Layout:
    length: int
    names: tuple[str, ...]
    arrays: tuple[tuple[int, int], ...]  # (byte offset, count) of each float64[] field
    const_idx: np.ndarray  # byte positions that must equal the template


def _align(p: int, a: int) -> int:
    return (
        4 + ((p - 4 + a - 1) // a) * a
    )  # CDR alignment is relative to the end of the 4-byte encapsulation


def layout(msg: bytes, n_arrays: int) -> Layout | None:
    """Layout of one little-endian CDR message, or None if it does not have the expected shape.

    Only meaningful bytes are constant (lengths, counts, characters): serialisers leave padding
    bytes and a few trailing bytes uninitialised (rclpy/Fast CDR does), so those are ignored.
    """
    const: list[tuple[int, int]] = []
    try:
        if len(msg) < 16 or msg[0] != 0 or msg[1] != 1:
            return None
        p = 12
        (flen,) = _u32.unpack_from(msg, p)
        const.append((p, p + 4 + flen))
        p += 4 + flen
        p = _align(p, 4)
        (n,) = _u32.unpack_from(msg, p)
        const.append((p, p + 4))
        p += 4
        if n > 64:
            return None
        names = []
        for _ in range(n):
            p = _align(p, 4)
            (ln,) = _u32.unpack_from(msg, p)
            const.append((p, p + 4 + ln))
            p += 4
            names.append(msg[p : p + ln - 1].decode())
            p += ln
        arrays = []
        for _ in range(n_arrays):
            p = _align(p, 4)
            (c,) = _u32.unpack_from(msg, p)
            const.append((p, p + 4))
            p += 4
            if c:
                p = _align(p, 8)
            arrays.append((p, c))
            p += 8 * c
        if p > len(msg) or len(msg) - p > 16:
            return None
    except (struct.error, UnicodeDecodeError):
        return None
    mask = np.zeros(len(msg), bool)
    for a, b in const:
        mask[a:b] = True
    return Layout(len(msg), tuple(names), tuple(arrays), np.flatnonzero(mask))


def stamps(block: np.ndarray) -> np.ndarray:
    """header.stamp in ns of messages stacked as ``(n, L) uint8``."""
    sec = block[:, 4:8].copy().view("<i4").reshape(-1).astype(np.int64)
    nsec = block[:, 8:12].copy().view("<u4").reshape(-1).astype(np.int64)
    return sec * 1_000_000_000 + nsec


def decode_group(
    block: np.ndarray, lay: Layout, template: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Decode ``(n, L)`` messages: (ok mask, stamps ns, first float array ``(n, count)``).

    Rows whose constant bytes differ from ``template`` (other names, other frame id) are marked
    not ok and must be decoded another way.
    """
    ok = (block[:, lay.const_idx] == template[lay.const_idx]).all(axis=1)
    off, c = lay.arrays[0]
    values = block[:, off : off + 8 * c].copy().view("<f8").reshape(len(block), c)
    return ok, stamps(block), values
