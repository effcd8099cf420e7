"""Fixed-layout CDR decoding of the joint-state messages, in bulk with numpy.

``sensor_msgs/JointState`` (header, name[], position[], velocity[], effort[]),
``orthoglide_msgs/CurrentReference`` (header, name[], current[]) and ros2_control's
``control_msgs/DynamicJointState`` (header, joint_names[], interface_values[] each
{interface_names[], values[]}) have a byte layout that is fixed once the frame id, the joint names
(and the interface names) are known: a controller publishes the same names every tick, so the
messages of a topic are equal-length rows whose float64 values sit at fixed offsets.
:func:`layout` reads the layout off one message; :func:`matches` tells which rows share it (every
meaningful byte outside the stamp and the values equal to that message's) and :func:`stamps`,
:func:`values` decode those rows at once. Rows that differ (other names, a frame id, another
length) take another layout or the reader's slower path. Values are labelled by column,
``(joint, field)``: field is ``position``, ``velocity``, ``effort``, ``current``, or a
DynamicJointState interface name.
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ._types import CURRENT_REFERENCE_TYPE, DYNAMIC_JOINT_STATE_TYPE, JOINT_STATE_TYPE

_u32 = struct.Struct("<I")
JOINT_STATE_FIELDS = ("position", "velocity", "effort")
_MAX_ITEMS = 4096  # names or values per array beyond which a message is not taken for a layout
Column = tuple[str, str]  # (joint, field)


@dataclass(frozen=True)
class Layout:
    """Where the values of one message shape are: ``offsets[k]`` is the byte offset of the float64
    of ``columns[k]``; ``const_idx`` the bytes every row of this shape must share."""

    length: int
    names: tuple[str, ...]
    columns: tuple[Column, ...]
    offsets: np.ndarray
    const_idx: np.ndarray


class _Walker:
    """Reads a little-endian CDR message field by field, noting the bytes that must be constant
    (lengths, counts, characters). Padding is never constant: serialisers leave it uninitialised
    (rclpy/Fast CDR does), and a few trailing bytes too."""

    def __init__(self, msg: bytes) -> None:
        self.msg = msg
        self.p = 12  # after the encapsulation (4) and header.stamp (8)
        self.const: list[tuple[int, int]] = []

    def _align(self, a: int) -> None:
        # CDR alignment is relative to the end of the 4-byte encapsulation
        self.p = 4 + ((self.p - 4 + a - 1) // a) * a

    def count(self) -> int:
        self._align(4)
        (n,) = _u32.unpack_from(self.msg, self.p)
        self.const.append((self.p, self.p + 4))
        self.p += 4
        if n > _MAX_ITEMS:
            raise ValueError("implausible count")
        return n

    def string(self) -> str:
        self._align(4)
        (ln,) = _u32.unpack_from(self.msg, self.p)
        end = self.p + 4 + ln
        if ln == 0 or end > len(self.msg) or self.msg[end - 1] != 0:
            raise ValueError("bad string")
        self.const.append((self.p, end))
        text = self.msg[self.p + 4 : end - 1].decode()
        self.p = end
        return text

    def strings(self) -> tuple[str, ...]:
        return tuple(self.string() for _ in range(self.count()))

    def float64s(self) -> tuple[int, int]:
        """(byte offset, count) of a float64[]; the values themselves are not constant."""
        n = self.count()
        if n:
            self._align(8)
        off = self.p
        self.p += 8 * n
        return off, n


def _joint_state(w: _Walker) -> tuple[tuple[str, ...], list[tuple[Column, int]]]:
    names = w.strings()
    cols: list[tuple[Column, int]] = []
    for field in JOINT_STATE_FIELDS:
        off, n = w.float64s()
        if n not in (0, len(names)):
            raise ValueError("array length differs from the names'")
        cols += [((j, field), off + 8 * i) for i, j in enumerate(names) if n]
    return names, cols


def _current_reference(w: _Walker) -> tuple[tuple[str, ...], list[tuple[Column, int]]]:
    names = w.strings()
    off, n = w.float64s()
    if n != len(names):
        raise ValueError("array length differs from the names'")
    return names, [((j, "current"), off + 8 * i) for i, j in enumerate(names)]


def _dynamic_joint_state(w: _Walker) -> tuple[tuple[str, ...], list[tuple[Column, int]]]:
    names = w.strings()
    if w.count() != len(names):
        raise ValueError("interface_values length differs from joint_names'")
    cols: list[tuple[Column, int]] = []
    for joint in names:
        interfaces = w.strings()
        off, n = w.float64s()
        if n != len(interfaces):
            raise ValueError("values length differs from interface_names'")
        cols += [((joint, i), off + 8 * k) for k, i in enumerate(interfaces)]
    return names, cols


_WALKS: dict[str, Callable[[_Walker], tuple[tuple[str, ...], list[tuple[Column, int]]]]] = {
    JOINT_STATE_TYPE: _joint_state,
    CURRENT_REFERENCE_TYPE: _current_reference,
    DYNAMIC_JOINT_STATE_TYPE: _dynamic_joint_state,
}
DECODABLE = tuple(_WALKS)


def layout(msg: bytes, msgtype: str) -> Layout | None:
    """Layout of one little-endian CDR message of ``msgtype``, or None if it has none (another
    encoding, a malformed message, repeated names): such messages take the slow path."""
    walk = _WALKS.get(msgtype)
    if walk is None or len(msg) < 16 or msg[0] != 0 or msg[1] != 1:
        return None
    w = _Walker(msg)
    try:
        w.string()  # header.frame_id
        names, cols = walk(w)
    except (struct.error, UnicodeDecodeError, ValueError):
        return None
    columns = tuple(c for c, _ in cols)
    if w.p > len(msg) or len(msg) - w.p > 16 or len(set(columns)) != len(columns):
        return None
    mask = np.zeros(len(msg), bool)
    for a, b in w.const:
        mask[a:b] = True
    offsets = np.fromiter((o for _, o in cols), np.int64, len(cols))
    return Layout(len(msg), names, columns, offsets, np.flatnonzero(mask))


def stamps(block: np.ndarray) -> np.ndarray:
    """header.stamp in ns of messages stacked as ``(n, L) uint8``."""
    sec = block[:, 4:8].copy().view("<i4").reshape(-1).astype(np.int64)
    nsec = block[:, 8:12].copy().view("<u4").reshape(-1).astype(np.int64)
    return sec * 1_000_000_000 + nsec


def values(block: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """The float64 values at ``offsets`` of every row of ``block``: ``(n, len(offsets))``.

    Columns that are contiguous in the message (one array field) are one slice."""
    n, k = len(block), len(offsets)
    if k == 0:
        return np.zeros((n, 0))
    if k == 1 or (np.diff(offsets) == 8).all():
        a = int(offsets[0])
        return block[:, a : a + 8 * k].copy().view("<f8").reshape(n, k)
    idx = (offsets[:, None] + np.arange(8)).reshape(-1)
    return np.ascontiguousarray(block[:, idx]).view("<f8").reshape(n, k)


def matches(block: np.ndarray, lay: Layout, template: np.ndarray) -> np.ndarray:
    """Which rows of ``(n, L)`` messages have ``template``'s layout: its constant bytes (names,
    frame id, counts). The others must be decoded another way."""
    return (block[:, lay.const_idx] == template[lay.const_idx]).all(axis=1)
