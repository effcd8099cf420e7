"""CDR bytes of many joint-state messages at once (the writer's and the simulators' side).

One message is serialised by rosbags as a template; its layout (``_cdr.layout``) says where the
stamp and every float64 sit, and N messages are that template tiled with the stamps and values
written in as numpy columns. The bytes are those rosbags (and rclpy) would produce one by one.
"""

from __future__ import annotations

import functools
import struct
from collections.abc import Mapping, Sequence

import numpy as np

from orthoglide_ident.errors import DataError

from . import _cdr
from ._cdr import JOINT_STATE_FIELDS
from ._types import CURRENT_REFERENCE_TYPE, DYNAMIC_JOINT_STATE_TYPE, JOINT_STATE_TYPE, typestore

_STAMP = struct.Struct("<iI")  # header.stamp after the 4-byte encapsulation


@functools.lru_cache(maxsize=64)
def _template(msgtype: str, names: tuple[str, ...], shape: tuple) -> tuple[np.ndarray, _cdr.Layout]:
    """A message with zero values: JointState ``shape`` = the fields it carries; CurrentReference
    ``()``; DynamicJointState ``shape`` = each joint's interface names."""
    store = typestore()
    T, H = store.types["builtin_interfaces/msg/Time"], store.types["std_msgs/msg/Header"]
    hdr = H(stamp=T(sec=0, nanosec=0), frame_id="")
    n = len(names)
    if msgtype == JOINT_STATE_TYPE:
        arrays = {f: np.zeros(n if f in shape else 0) for f in JOINT_STATE_FIELDS}
        msg = store.types[msgtype](header=hdr, name=list(names), **arrays)
    elif msgtype == CURRENT_REFERENCE_TYPE:
        msg = store.types[msgtype](header=hdr, name=list(names), current=np.zeros(n))
    else:
        iv = store.types["control_msgs/msg/InterfaceValue"]
        msg = store.types[msgtype](header=hdr, joint_names=list(names), interface_values=[
            iv(interface_names=list(i), values=np.zeros(len(i))) for i in shape])
    raw = bytes(store.serialize_cdr(msg, msgtype))
    lay = _cdr.layout(raw, msgtype)
    if lay is None:
        raise DataError(f"cannot encode {msgtype} for joints {names}: empty or repeated names")
    return np.frombuffer(raw, np.uint8), lay


class CdrTemplate:
    """A serialised message whose header.stamp (bytes 4..12, after the 4-byte encapsulation)
    and float64 values (at ``offsets``, 8 bytes each) are written into a copy of ``raw``: the
    one CDR template patcher (the bags' encoders, the broadcasters' and the simulated driver's
    per-tick messages)."""

    def __init__(self, raw: bytes | np.ndarray, offsets: Sequence[int]) -> None:
        self.raw = np.frombuffer(bytes(raw), np.uint8)
        self.offsets = np.asarray(offsets, np.int64)
        self._idx = (self.offsets[:, None] + np.arange(8)).reshape(-1)

    def pack(self, sec: int, nanosec: int, values: Sequence[float] | np.ndarray) -> bytes:
        """One message: stamp (sec, nanosec) and ``values`` (len(offsets),) in offsets' order."""
        out = self.raw.copy()
        out[4:12] = np.frombuffer(_STAMP.pack(sec, nanosec), np.uint8)
        out[self._idx] = np.ascontiguousarray(values, "<f8").view(np.uint8)
        return out.tobytes()

    def pack_many(self, stamps_ns: np.ndarray, values: np.ndarray) -> np.ndarray:
        """``(N, L) uint8``: one message per stamp (ns), row k of ``values`` (N, len(offsets))."""
        stamps_ns = np.asarray(stamps_ns, np.int64)
        n = len(stamps_ns)
        out = np.tile(self.raw, (n, 1))
        sec, nsec = np.divmod(stamps_ns, 1_000_000_000)
        out[:, 4:8] = sec.astype("<i4").view(np.uint8).reshape(-1, 4)
        out[:, 8:12] = nsec.astype("<u4").view(np.uint8).reshape(-1, 4)
        if len(self.offsets):
            vals = np.ascontiguousarray(values, "<f8").reshape(n, len(self.offsets))
            out[:, self._idx] = vals.view(np.uint8).reshape(n, -1)
        return out


def _encode(msgtype: str, names: Sequence[str], shape: tuple, stamps_ns: np.ndarray,
            columns: Mapping[tuple[str, str], np.ndarray]) -> np.ndarray:
    """``(N, L) uint8``: one message per stamp, column ``(joint, field)`` from ``columns``."""
    tpl, lay = _template(msgtype, tuple(names), shape)
    n = len(np.asarray(stamps_ns))
    vals = np.empty((n, len(lay.columns)), "<f8")
    for k, col in enumerate(lay.columns):
        vals[:, k] = columns[col]
    return CdrTemplate(tpl, lay.offsets).pack_many(stamps_ns, vals)


def _by_joint(names: Sequence[str], field: str, values: np.ndarray
              ) -> dict[tuple[str, str], np.ndarray]:
    values = np.asarray(values, float)
    if values.ndim != 2 or values.shape[1] != len(names):
        raise DataError(f"{field} must be (N, {len(names)}); got {values.shape}")
    return {(j, field): values[:, i] for i, j in enumerate(names)}


def encode_messages(
    msgtype: str, names: Sequence[str], stamps_ns: np.ndarray, values: np.ndarray
) -> np.ndarray:
    """CDR bytes of many JointState (position) or CurrentReference (current) messages at once.

    ``stamps_ns`` (N,) header stamps, ``values`` (N, len(names)); returns ``(N, L) uint8``, one
    serialized message per row (empty frame id; JointState velocity and effort empty).
    """
    field = "position" if msgtype == JOINT_STATE_TYPE else "current"
    shape = ("position",) if msgtype == JOINT_STATE_TYPE else ()
    return _encode(msgtype, names, shape, stamps_ns, _by_joint(names, field, values))


def encode_joint_states(names: Sequence[str], stamps_ns: np.ndarray, position: np.ndarray,
                        velocity: np.ndarray | None = None,
                        effort: np.ndarray | None = None) -> np.ndarray:
    """JointState messages with position and, when given, velocity and effort, each (N, n) by
    ``names`` (m or rad, /s, and the effort's unit: A when it carries the current)."""
    columns = _by_joint(names, "position", position)
    shape = ["position"]
    for f, v in (("velocity", velocity), ("effort", effort)):
        if v is not None:
            columns.update(_by_joint(names, f, v))
            shape.append(f)
    return _encode(JOINT_STATE_TYPE, names, tuple(shape), stamps_ns, columns)


def encode_dynamic_joint_states(names: Sequence[str], interfaces: Sequence[Sequence[str]],
                                stamps_ns: np.ndarray,
                                values: Mapping[str, np.ndarray]) -> np.ndarray:
    """DynamicJointState messages: joint ``names[j]`` carries ``interfaces[j]``; ``values[i]``
    (N, n) holds interface ``i`` by ``names`` (columns of joints without ``i`` are ignored)."""
    if len(interfaces) != len(names):
        raise DataError(f"{len(names)} joints but {len(interfaces)} interface lists")
    columns: dict[tuple[str, str], np.ndarray] = {}
    for i, v in values.items():
        columns.update(_by_joint(names, i, v))
    missing = [(j, i) for j, ifs in zip(names, interfaces) for i in ifs if (j, i) not in columns]
    if missing:
        raise DataError(f"no values for interface {missing[0][1]!r} of joint {missing[0][0]!r}")
    shape = tuple(tuple(i) for i in interfaces)
    return _encode(DYNAMIC_JOINT_STATE_TYPE, names, shape, stamps_ns, columns)


class MessageTemplate:
    """One joint-state message shape, for encoding single messages fast (a publisher's tick:
    a few µs instead of the ~100 µs of building and serialising the message).

    ``columns`` are the (joint, field) of the values in the order :meth:`encode` takes them;
    the bytes equal :func:`encode_joint_states` / :func:`encode_dynamic_joint_states`'."""

    def __init__(self, msgtype: str, names: Sequence[str], shape: tuple) -> None:
        tpl, lay = _template(msgtype, tuple(names), shape)
        self.columns = lay.columns
        self._cdr = CdrTemplate(tpl, lay.offsets)

    @classmethod
    def joint_state(cls, names: Sequence[str], fields: Sequence[str] = JOINT_STATE_FIELDS
                    ) -> MessageTemplate:
        return cls(JOINT_STATE_TYPE, names, tuple(fields))

    @classmethod
    def dynamic_joint_state(cls, names: Sequence[str], interfaces: Sequence[Sequence[str]]
                            ) -> MessageTemplate:
        if len(interfaces) != len(names):
            raise DataError(f"{len(names)} joints but {len(interfaces)} interface lists")
        return cls(DYNAMIC_JOINT_STATE_TYPE, names, tuple(tuple(i) for i in interfaces))

    def encode(self, stamp_ns: int, values: np.ndarray) -> bytes:
        """CDR bytes of the message stamped ``stamp_ns`` with ``values`` (len(columns),)."""
        return self._cdr.pack(*divmod(int(stamp_ns), 1_000_000_000), values)
