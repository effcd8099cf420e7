"""The joint-state topics of a bag decoded into one table each: stamps and labelled columns.

A :class:`TopicSeries` gathers one topic's messages as blocks (stamps, columns, values) and
:meth:`TopicSeries.finish` joins them, sorted by stamp. A :class:`Decoder` fills it: equal-length
messages with one layout in bulk (``_cdr``), the others one by one with rosbags from the bag's
own schema (``_types.schema_store``), so the result never depends on which path was taken.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from orthoglide_ident.errors import BagError, DataError

from . import _cdr
from ._cdr import JOINT_STATE_FIELDS, Column
from ._types import CURRENT_REFERENCE_TYPE, DYNAMIC_JOINT_STATE_TYPE, schema_store

Block = tuple[np.ndarray, tuple[Column, ...], np.ndarray]  # stamps (n,), columns, values (n, k)


@dataclass
class TopicSeries:
    """One topic's messages. After :meth:`finish`: ``stamps_ns`` (N,) int64 header stamps sorted,
    ``values`` (N, len(columns)) float64, NaN where a message lacked a column; ``names`` the
    joints in the order first published."""

    topic: str
    msgtype: str
    schema_encoding: str = ""
    schema: str = ""  # the channel's definition text, for decoding without compiled types
    count: int = 0
    log_start: int = 2**63 - 1
    log_end: int = 0
    names: tuple[str, ...] | None = None
    blocks: list[Block] = field(default_factory=list)
    stamps_ns: np.ndarray | None = None
    columns: tuple[Column, ...] = ()
    values: np.ndarray | None = None

    @property
    def decoded(self) -> bool:
        return self.stamps_ns is not None

    def add(self, stamps: np.ndarray, names: tuple[str, ...], columns: tuple[Column, ...],
            values: np.ndarray) -> None:
        """Keep a block; DataError when the set of joints changes within the topic."""
        if self.names is None:
            self.names = names
        elif names != self.names and sorted(names) != sorted(self.names):
            raise DataError(f"{self.topic}: joint names change from {self.names} to {names}")
        if len(stamps):
            self.blocks.append((stamps, columns, values))

    def finish(self, sort: bool = True) -> None:
        """Join the blocks into ``stamps_ns``/``columns``/``values``, sorted by stamp (stable)
        unless ``sort`` is False (arrival order)."""
        blocks, self.blocks = self.blocks, []
        cols: dict[Column, int] = {}
        for _, c, _ in blocks:
            for col in c:
                cols.setdefault(col, len(cols))
        self.columns = tuple(cols)
        if not blocks:
            st, vals = np.zeros(0, np.int64), np.zeros((0, len(cols)))
        elif all(c == self.columns for _, c, _ in blocks):
            st = np.concatenate([b[0] for b in blocks])
            vals = np.concatenate([b[2] for b in blocks]) if len(blocks) > 1 else blocks[0][2]
        else:  # blocks with other columns (reordered joints, a field only some messages carry)
            st = np.concatenate([b[0] for b in blocks])
            vals = np.full((len(st), len(cols)), np.nan)
            row = 0
            for s, c, v in blocks:
                vals[row : row + len(s), [cols[x] for x in c]] = v
                row += len(s)
        if sort and len(st) > 1 and np.any(np.diff(st) < 0):
            order = np.argsort(st, kind="stable")
            st, vals = st[order], vals[order]
        self.stamps_ns, self.values = st, vals

    def take(self, name: str, joints: Sequence[str] | None = None
             ) -> tuple[tuple[str, ...], np.ndarray]:
        """(joints, values (N, k)) of one field, for ``joints`` (default: every joint that has
        it, in the topic's order). A joint without it is left out: the caller says why."""
        assert self.values is not None, "finish() first"
        index = {c: k for k, c in enumerate(self.columns)}
        wanted = joints if joints is not None else (self.names or ())
        have = tuple(j for j in wanted if (j, name) in index)
        return have, self.values[:, [index[(j, name)] for j in have]]


def _columns_of(msg: Any, msgtype: str, topic: str) -> tuple[tuple[str, ...], list[tuple[Column, float]]]:
    """Joint names and labelled values of one deserialised message; DataError if malformed."""
    if msgtype == DYNAMIC_JOINT_STATE_TYPE:
        names = tuple(msg.joint_names)
        if len(msg.interface_values) != len(names):
            raise DataError(f"{topic}: message with {len(names)} joint_names but "
                            f"{len(msg.interface_values)} interface_values")
        out = []
        for joint, iv in zip(names, msg.interface_values):
            if len(iv.values) != len(iv.interface_names):
                raise DataError(f"{topic}: joint {joint} has {len(iv.interface_names)} "
                                f"interface_names but {len(iv.values)} values")
            out += [((joint, i), float(v)) for i, v in zip(iv.interface_names, iv.values)]
        return names, out
    names = tuple(msg.name)
    fields = ("current",) if msgtype == CURRENT_REFERENCE_TYPE else JOINT_STATE_FIELDS
    out = []
    for f in fields:
        v = getattr(msg, f)
        if len(v) == len(names):
            out += [((j, f), float(x)) for j, x in zip(names, v)]
        elif len(v) or f in ("position", "current"):
            raise DataError(f"{topic}: message with {len(names)} names but {len(v)} {f} values")
    return names, out


def decode_rows(series: TopicSeries, rows: Iterable[bytes]) -> None:
    """Slow path: rosbags' deserialiser, from the bag's schema, one message at a time; messages
    with the same names and columns are kept as one block."""
    store = schema_store(series.msgtype, series.schema_encoding, series.schema)
    run: list[tuple[int, list[float]]] = []
    key: tuple[tuple[str, ...], tuple[Column, ...]] | None = None

    def flush() -> None:
        if run and key is not None:
            st = np.fromiter((s for s, _ in run), np.int64, len(run))
            series.add(st, key[0], key[1], np.array([v for _, v in run], float).reshape(len(run), -1))
        run.clear()

    for raw in rows:
        try:
            msg = store.deserialize_cdr(raw, series.msgtype)
        except Exception as exc:  # rosbags raises several types for malformed bytes
            raise BagError(f"{series.topic}: undecodable {series.msgtype} message: {exc}") from None
        names, labelled = _columns_of(msg, series.msgtype, series.topic)
        cols = tuple(c for c, _ in labelled)
        if len(set(cols)) != len(cols):
            raise DataError(f"{series.topic}: a joint or interface name repeats in {names}")
        if (names, cols) != key:
            flush()
            key = (names, cols)
        run.append((msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec,
                    [v for _, v in labelled]))
    flush()


MAX_LAYOUTS = 8  # message shapes per length decoded in bulk; beyond: one by one


class Decoder:
    """Bulk decoding of one topic's messages, with a cache of layouts per message length.

    Rows that match none of the cached layouts of their length (a new frame id, joints in
    another order) get a layout of their own, up to :data:`MAX_LAYOUTS` per length, so a topic
    with a few shapes still decodes in bulk; the rest (and messages with no fixed layout) are
    deserialised one by one."""

    def __init__(self, series: TopicSeries) -> None:
        self.series = series
        self.cache: dict[int, list[tuple[_cdr.Layout, np.ndarray]]] = {}
        self.no_layout: set[int] = set()  # lengths whose messages have none

    def add(self, arr: np.ndarray, data_offs: np.ndarray, data_lens: np.ndarray) -> None:
        """Decode the messages whose CDR bytes start at ``data_offs`` in ``arr`` (uint8)."""
        for length in np.unique(data_lens):
            length = int(length)
            rest = _rows(arr, data_offs[data_lens == length], length)
            layouts = self.cache.setdefault(length, [])
            for lay, tpl in layouts:
                rest = self._take(rest, lay, tpl)
                if not len(rest):
                    break
            while len(rest) and len(layouts) < MAX_LAYOUTS and length not in self.no_layout:
                lay = _cdr.layout(rest[0].tobytes(), self.series.msgtype)
                if lay is None:
                    self.no_layout.add(length)
                    break
                layouts.append((lay, rest[0].copy()))
                rest = self._take(rest, lay, layouts[-1][1])
            if len(rest):
                decode_rows(self.series, (r.tobytes() for r in rest))

    def _take(self, rows: np.ndarray, lay: _cdr.Layout, tpl: np.ndarray) -> np.ndarray:
        """Decode the rows of ``lay``; return the others."""
        ok = _cdr.matches(rows, lay, tpl)
        if ok.all():
            self.series.add(_cdr.stamps(rows), lay.names, lay.columns, _cdr.values(rows, lay.offsets))
            return rows[:0]
        if ok.any():
            mine = rows[ok]
            self.series.add(_cdr.stamps(mine), lay.names, lay.columns, _cdr.values(mine, lay.offsets))
        return rows[~ok]


def _rows(arr: np.ndarray, sel: np.ndarray, length: int) -> np.ndarray:
    """The messages at ``sel`` as ``(n, length)`` rows: a strided view when they are evenly
    spaced (the usual interleaving of a tick's topics), a gather otherwise."""
    steps = np.diff(sel)
    if len(sel) > 1 and steps[0] >= length and (steps == steps[0]).all():
        return np.lib.stride_tricks.as_strided(
            arr[sel[0]:], shape=(len(sel), length), strides=(int(steps[0]), 1), writeable=False)
    return arr[sel[:, None] + np.arange(length)]
