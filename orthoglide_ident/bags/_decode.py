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
    """One topic's messages. After :meth:`finish`: ``stamps_ns`` (N,) int64 header stamps (sorted
    unless asked otherwise), ``columns`` every (joint, field) seen, and :meth:`take` the (N, k)
    values of one field; ``names`` the joints in the order first published."""

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
    _order: np.ndarray | None = None  # stamp order of the joined blocks, None when sorted

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
        """Join the stamps (sorted, stably, unless ``sort`` is False: arrival order) and the runs
        of blocks that share their columns; values stay by block until :meth:`take`, so a field
        that few messages carry costs no (N, all columns) table."""
        runs: list[list[Block]] = []
        for b in self.blocks:
            if runs and runs[-1][0][1] == b[1]:
                runs[-1].append(b)
            else:
                runs.append([b])
        self.blocks = [r[0] if len(r) == 1 else (np.concatenate([b[0] for b in r]), r[0][1],
                                                 np.concatenate([b[2] for b in r])) for r in runs]
        cols: dict[Column, None] = {}
        for _, c, _ in self.blocks:
            cols.update(dict.fromkeys(c))
        self.columns = tuple(cols)
        st = (np.concatenate([b[0] for b in self.blocks]) if self.blocks
              else np.zeros(0, np.int64))
        self._order = None
        if sort and len(st) > 1 and np.any(np.diff(st) < 0):
            self._order = np.argsort(st, kind="stable")
            st = st[self._order]
        self.stamps_ns = st

    def take(self, name: str, joints: Sequence[str] | None = None
             ) -> tuple[tuple[str, ...], np.ndarray]:
        """(joints, values (N, k)) of one field, for ``joints`` (default: every joint that has
        it, in the topic's order), NaN where a message lacked it. A joint without it anywhere is
        left out: the caller says why."""
        assert self.stamps_ns is not None, "finish() first"
        seen = set(self.columns)
        wanted = joints if joints is not None else (self.names or ())
        have = tuple(j for j in wanted if (j, name) in seen)
        want = [(j, name) for j in have]
        if len(self.blocks) == 1:
            _, c, v = self.blocks[0]
            index = {x: k for k, x in enumerate(c)}
            if all(w in index for w in want):
                out = v[:, [index[w] for w in want]]
                return have, out if self._order is None else out[self._order]
        out = np.full((len(self.stamps_ns), len(want)), np.nan)
        row = 0
        for st, c, v in self.blocks:
            index = {x: k for k, x in enumerate(c)}
            pairs = [(k, index[w]) for k, w in enumerate(want) if w in index]
            if pairs:
                dst, src = zip(*pairs)
                out[row : row + len(st), list(dst)] = v[:, list(src)]
            row += len(st)
        return have, out if self._order is None else out[self._order]


def _columns_of(msg: Any, msgtype: str, topic: str
                ) -> tuple[tuple[str, ...], list[tuple[Column, float]]]:
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
            values = np.array([v for _, v in run], float).reshape(len(run), -1)
            series.add(st, key[0], key[1], values)
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
        if not ok.any():
            return rows
        mine = rows if ok.all() else rows[ok]
        if len(mine):
            self.series.add(_cdr.stamps(mine), lay.names, lay.columns,
                            _cdr.values(mine, lay.offsets))
        return rows[:0] if len(mine) == len(rows) else rows[~ok]


def _rows(arr: np.ndarray, sel: np.ndarray, length: int) -> np.ndarray:
    """The messages at ``sel`` as ``(n, length)`` rows: a strided view when they are evenly
    spaced (the usual interleaving of a tick's topics), a gather otherwise."""
    steps = np.diff(sel)
    if len(sel) > 1 and steps[0] >= length and (steps == steps[0]).all():
        return np.lib.stride_tricks.as_strided(
            arr[sel[0]:], shape=(len(sel), length), strides=(int(steps[0]), 1), writeable=False)
    return arr[sel[:, None] + np.arange(length)]
