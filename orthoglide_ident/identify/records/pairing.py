"""The two recorded topics as they arrive, checked on arrival and paired by stamp
(docs/design/method.md).

``/orthoglide/joint_states`` (q) and ``/orthoglide/current_reference`` (v_tau) carry the same
header stamp for the same controller tick but arrive independently, a few ticks apart, in
batches of any length. A :class:`TopicBuffer` holds each topic's samples until both topics have
gone past their stamp; :func:`pair_upto` then pairs them by stamp as ``segments.split_record``
does — equal stamps, or the nearest within half a tick for a current published by another node
(duplicates: the first received is kept). Whatever cannot be used
is said the moment it arrives (``TopicBuffer.add`` returns one-line warnings): wrong joint names,
NaN/inf, lost ticks, samples out of order or too late, currents near saturation.
"""
from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from orthoglide_ident.errors import DataError
from orthoglide_ident.identify.records.segments import column_order, nearest_pairs, unique_sorted


@dataclass
class TopicCounts:
    """What a topic lost on arrival (samples)."""

    received: int = 0
    wrong_names: int = 0
    bad_shape: int = 0
    nonfinite: int = 0
    late: int = 0  # arrived after their tick had been paired


@dataclass
class TopicBuffer:
    """Samples of one topic waiting to be paired: stamps (ns) and values (n, n_j), the robot's
    ``joint_names`` in order (a topic's columns are matched by name: any order, extras ignored).

    ``to_model``: maps the ordered columns to the model's (a transmission's joint-side channels
    to its motors, ``live_recording.channel_maps``), sample by sample; stamps, NaN and
    saturation are checked on the mapped values."""

    topic: str
    joint_names: tuple[str, ...]
    limit: float = 0.0  # |value| that warns of saturation (0: no check)
    to_model: Callable[[np.ndarray], np.ndarray] | None = None
    counts: TopicCounts = field(default_factory=TopicCounts)
    max_ns: int | None = None  # newest stamp received
    horizon_ns: int | None = None  # stamps up to this one have been paired
    period_ns: float | None = None  # this topic's own tick estimate, for the lost-tick warnings
    t0_ns: int | None = None  # first stamp of the recording, for the messages
    _stamps: list[np.ndarray] = field(default_factory=list)
    _values: list[np.ndarray] = field(default_factory=list)
    _names: tuple[str, ...] | None = None  # last accepted names and their permutation
    _perm: np.ndarray | None = None
    _warned_names: set[tuple[str, ...]] = field(default_factory=set)
    _last_saturation_ns: dict[int, int] = field(default_factory=dict)
    _first: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    # every sample taken for pairing, when not None (an uneven clock's recording is rebuilt
    # from them by the offline rules at its end: live_recording.LiveRecording.close)
    kept: list[tuple[np.ndarray, np.ndarray]] | None = None

    def add(self, stamps_ns: Sequence[int] | np.ndarray, names: Sequence[str],
            values: np.ndarray) -> list[str]:
        """Check and keep a batch; returns the warnings it raised (one line each)."""
        stamps = np.atleast_1d(np.asarray(stamps_ns, dtype=np.int64))
        x = np.asarray(values, dtype=float)
        if x.ndim == 1 and stamps.shape[0] == 1:
            x = x[None, :]
        n = stamps.shape[0]
        self.counts.received += n
        if x.ndim != 2 or x.shape != (n, len(names)):
            self.counts.bad_shape += n
            return [f"{self.topic}: {n} sample(s) with values of shape {x.shape} for {n} stamps "
                    f"(expected ({n}, {len(names)}), one column per joint name): dropped"]
        if self.t0_ns is None and n:
            self.t0_ns = int(stamps.min())
        out: list[str] = []
        perm = self._permutation(names, stamps, out)
        if perm is False or n == 0:
            return out
        if perm is not None:
            x = x[:, perm]
        if self.to_model is not None:
            x = self.to_model(x)
        stamps, x = self._drop_nonfinite(stamps, x, out)
        stamps, x = self._drop_late(stamps, x, out)
        self._check_ticks(stamps, out)
        if self.limit > 0:
            self._check_saturation(stamps, x, out)
        if stamps.shape[0]:
            self._stamps.append(stamps)
            self._values.append(x)
            top = int(stamps.max())
            self.max_ns = top if self.max_ns is None else max(self.max_ns, top)
        return out

    def _t(self, stamp_ns: int) -> float:
        return (int(stamp_ns) - (self.t0_ns or 0)) * 1e-9

    def _permutation(self, names: Sequence[str], stamps: np.ndarray, out: list[str]):
        """Columns for ``names`` (None: already the robot's joints in order; False: unusable)."""
        key = tuple(str(s) for s in names)
        if key == self._names:
            return self._perm
        try:
            perm = column_order(key, self.topic, self.joint_names)
        except DataError:
            self.counts.wrong_names += stamps.shape[0]
            if key not in self._warned_names:
                self._warned_names.add(key)
                out.append(f"{self.topic}: joint names {list(key)} do not hold the robot's "
                           f"{list(self.joint_names)}: samples dropped (first at t = "
                           f"{self._t(stamps[0]):.3f} s)")
            return False
        self._names, self._perm = key, perm
        return perm

    def _drop_nonfinite(self, stamps: np.ndarray, x: np.ndarray, out: list[str]):
        finite = np.isfinite(x).all(axis=1)
        if finite.all():
            return stamps, x
        bad = int((~finite).sum())
        self.counts.nonfinite += bad
        out.append(f"{self.topic}: {bad} sample(s) hold NaN or inf (first at t = "
                   f"{self._t(stamps[~finite][0]):.3f} s): dropped, the record is split there "
                   "(as offline with nonfinite: drop)")
        return stamps[finite], x[finite]

    def _drop_late(self, stamps: np.ndarray, x: np.ndarray, out: list[str]):
        if self.horizon_ns is None:
            return stamps, x
        late = stamps <= self.horizon_ns
        if not late.any():
            return stamps, x
        k = int(late.sum())
        self.counts.late += k
        out.append(f"{self.topic}: {k} sample(s) arrived after their tick had been paired "
                   f"(up to {(self.horizon_ns - int(stamps[late].min())) * 1e-6:.1f} ms late): "
                   "dropped; raise live_pairing_slack_s")
        return stamps[~late], x[~late]

    def _check_ticks(self, stamps: np.ndarray, out: list[str]) -> None:
        """Lost ticks (steps > 1.5 periods) and repeated/out-of-order stamps, on arrival (a
        batch may come in any order: it is checked sorted, after the newest stamp before it)."""
        prev = [] if self.max_ns is None else [self.max_ns]
        s = np.concatenate([np.asarray(prev, np.int64), np.sort(stamps)])
        if self.period_ns is None:
            self._estimate_period(s)
            return
        dt = np.diff(s)
        ratio = dt / self.period_ns
        lost = ratio > 1.5
        if lost.any():
            n = int(np.sum(np.rint(ratio[lost]) - 1))
            out.append(f"{self.topic}: {n} tick(s) lost in {int(lost.sum())} gap(s), first "
                       f"before t = {self._t(s[1:][lost][0]):.3f} s")
        back = ratio < 0.5
        if back.any():
            out.append(f"{self.topic}: {int(back.sum())} sample(s) repeated or out of order "
                       f"(first at t = {self._t(s[1:][back][0]):.3f} s)")

    def _estimate_period(self, s: np.ndarray) -> None:
        self._first = np.concatenate([self._first, s])
        if self._first.shape[0] >= 12:
            dt = np.diff(np.unique(self._first))
            if dt.size:
                self.period_ns = float(np.median(dt))

    def _check_saturation(self, stamps: np.ndarray, x: np.ndarray, out: list[str]) -> None:
        """At most one warning per joint and second while |v_tau| ≥ the saturation threshold."""
        hot = np.abs(x) >= self.limit
        for j in np.flatnonzero(hot.any(axis=0)):
            k = int(np.flatnonzero(hot[:, j])[0])
            last = self._last_saturation_ns.get(int(j))
            if last is not None and stamps[k] - last < 1_000_000_000:
                continue
            self._last_saturation_ns[int(j)] = int(stamps[k])
            out.append(f"{self.topic}: {self.joint_names[j]} at {x[k, j]:+.3g} A, beyond "
                       f"{self.limit:.3g} A, near the drive's current limit at t = "
                       f"{self._t(stamps[k]):.3f} s: the drive may saturate (slow the trajectory)")

    def take_upto(self, horizon_ns: float) -> tuple[np.ndarray, np.ndarray, int]:
        """Stamps ≤ ``horizon_ns`` in order, one sample per stamp (the first received): stamps,
        values and the duplicates dropped; later stamps stay."""
        if not self._stamps:
            return np.zeros(0, np.int64), np.zeros((0, len(self.joint_names))), 0
        s = np.concatenate(self._stamps)
        x = np.concatenate(self._values)
        keep, n_dup = unique_sorted(s)
        s, x = s[keep], x[keep]
        k = int(np.searchsorted(s, horizon_ns, side="right")) if np.isfinite(horizon_ns) \
            else s.shape[0]
        self._stamps, self._values = ([s[k:]], [x[k:]]) if k < s.shape[0] else ([], [])
        if self.kept is not None and k:
            self.kept.append((s[:k], x[:k]))
        if k:
            top = int(s[k - 1])
            self.horizon_ns = top if self.horizon_ns is None else max(self.horizon_ns, top)
        return s[:k], x[:k], n_dup

    def put_back(self, stamps_ns: np.ndarray, values: np.ndarray) -> None:
        """Return samples taken but not used (past the pairing horizon) to the buffer."""
        if stamps_ns.shape[0]:
            self._stamps.insert(0, stamps_ns)
            self._values.insert(0, values)

    def kept_samples(self) -> tuple[np.ndarray, np.ndarray] | None:
        """Every sample kept (see ``kept``), one per stamp in stamp order (a sample put back
        and taken again counts once), or None when not kept."""
        if self.kept is None:
            return None
        if not self.kept:
            return np.zeros(0, np.int64), np.zeros((0, len(self.joint_names)))
        s = np.concatenate([a for a, _ in self.kept])
        x = np.concatenate([b for _, b in self.kept])
        keep, _ = unique_sorted(s)
        return s[keep], x[keep]

    @property
    def pending(self) -> int:
        return int(sum(s.shape[0] for s in self._stamps))


@dataclass
class Paired:
    """Ticks present on both topics, in stamp order; counts of what did not pair."""

    stamps_ns: np.ndarray
    q: np.ndarray  # (n, n_j) m or rad
    v_tau: np.ndarray  # (n, n_j) A
    unpaired_q: int = 0
    unpaired_v: int = 0
    duplicates: int = 0


def pair_upto(q: TopicBuffer, v: TopicBuffer, horizon_ns: float, tol_ns: int = 0) -> Paired:
    """Pair every position tick up to ``horizon_ns`` (both topics must be past it by more than
    ``tol_ns``, or have ended) with the current of the same stamp or the nearest within
    ``tol_ns`` (segments.nearest_pairs); currents past the horizon that did not pair stay."""
    before = [x for x in (q.horizon_ns, v.horizon_ns) if x is not None]
    sq, xq, dq = q.take_upto(horizon_ns)
    sv, xv, dv = v.take_upto(horizon_ns + tol_ns)
    iq, iv = nearest_pairs(sq, sv, tol_ns)
    later = np.ones(sv.shape[0], bool)
    later[iv] = False
    later &= sv > horizon_ns  # unpaired, and a position tick after the horizon may still claim it
    v.put_back(sv[later], xv[later])
    # a tick up to the horizon is settled on both topics: later arrivals there are late
    done = before + ([int(horizon_ns)] if np.isfinite(horizon_ns) else
                     [int(x[-1]) for x in (sq, sv) if x.shape[0]])
    q.horizon_ns = v.horizon_ns = max(done) if done else None
    n_v = int(sv.shape[0] - later.sum())
    return Paired(sq[iq], xq[iq], xv[iv], sq.shape[0] - iq.shape[0], n_v - iv.shape[0], dq + dv)
