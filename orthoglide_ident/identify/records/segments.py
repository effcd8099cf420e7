"""Pair joint positions with current references by stamp and split the record at gaps
(docs/design/method.md).

The controller publishes q (``/orthoglide/joint_states``) and v_tau
(``/orthoglide/current_reference``) with the same header stamp for the same tick, as ros2_control's
joint_state_broadcaster stamps ``/joint_states`` and ``/dynamic_joint_states`` from one update.
Samples are paired by stamp: equal stamps, or, when the current comes from another publisher that
stamps with its own clock (a controller's ``now()``), the nearest stamp within half a tick
(:func:`nearest_pairs`); the pair takes the position's stamp. A missing tick on either topic is a
gap. Derivative filtering and decimation never run across a gap, so the record is
split into continuous segments and segments too short for the filters are dropped. Everything that
was dropped is counted in a :class:`SegmentReport` for the log.

Non-finite samples (NaN, inf) raise :class:`DataError` by default; with ``nonfinite="drop"`` the
ticks holding them are removed and become gaps like any other missing tick.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from orthoglide_ident.errors import DataError
from orthoglide_ident.ticks import StepStats, find_breaks_local, step_stats


@dataclass
class Segment:
    """A run of consecutive controller ticks with no sample missing.

    ``stamps_ns: (n,)`` int64, ``q: (n, n_j)`` in m or rad, ``v_tau: (n, n_j)`` in A, columns in
    the robot's joint order (RobotModel.joint_names).
    """

    stamps_ns: np.ndarray
    q: np.ndarray
    v_tau: np.ndarray
    qd: np.ndarray | None = None  # (n, n_j) rad/s or m/s, a recorded joint velocity if used

    def __len__(self) -> int:
        return int(self.stamps_ns.shape[0])


@dataclass
class SegmentReport:
    """What pairing and segmenting kept and dropped (counts of samples, i.e. controller ticks)."""

    period_s: float = 0.0  # mean step of the continuous runs (the median on a steady clock)
    steps: StepStats | None = None  # the paired stamps' step distribution
    velocity: str = "derived from q"  # where q̂̇ came from (time_base.choose_velocity)
    current_sampling: str = "held"  # the current against its stamps (observe/sampling.py)
    current_sampling_why: str = ""  # who said it
    current_shift_ms: float = 0.0  # sampled: the states this long after the stamps
    filter_cutoff_hz: float = 0.0  # the cut-offs used at this record's rate (options.at_rate)
    decimation: int = 0
    decimation_cutoff_hz: float = 0.0
    n_joint_states: int = 0
    n_current_reference: int = 0
    n_paired: int = 0
    n_unpaired_joint_states: int = 0
    n_unpaired_current_reference: int = 0
    n_duplicate_stamps: int = 0
    n_nonfinite_dropped: int = 0
    n_missing_ticks: int = 0
    n_gaps: int = 0
    n_segments: int = 0
    n_short_segments_dropped: int = 0
    n_samples_in_short_segments: int = 0
    n_used: int = 0
    n_reversal_bridged: int = 0  # joint samples bridged at velocity reversals (reversals.py)
    n_reversal_unbridged: int = 0  # joint samples in runs too long to bridge (rows left out)
    n_not_repeating: int = 0  # segments used without a period: no current-loop lag instrument
    reordered: list[str] = field(default_factory=list)

    def time_base(self) -> str:
        """One line: the step distribution and what identification does with it."""
        if self.steps is None:
            return ""
        if not self.steps.uneven:
            return f"{self.steps.describe()}: a steady clock"
        return (f"{self.steps.describe()}: uneven steps, so derivatives, filters and the "
                "zero-order hold use each sample's own stamp (time_base.py), none is invented")

    def summary(self) -> str:
        """One line for the log."""
        return (
            f"{self.n_paired} paired samples at {1.0 / self.period_s:.0f} Hz, "
            f"{self.n_missing_ticks} missing ticks in {self.n_gaps} gaps, "
            f"{self.n_unpaired_joint_states + self.n_unpaired_current_reference} unpaired, "
            f"{self.n_nonfinite_dropped} non-finite dropped, {self.n_segments} segments used "
            f"({self.n_short_segments_dropped} too short dropped, "
            f"{self.n_samples_in_short_segments} samples), {self.n_used} samples used"
        )


def column_order(names: Sequence[str], topic: str, expected: Sequence[str]) -> np.ndarray | None:
    """Columns of ``names`` that hold the joints ``expected``, in that order; None when ``names``
    are exactly ``expected``. Joints are matched by name: any order, extra joints (a gripper)
    ignored; a missing or repeated one is a DataError."""
    names = [str(n) for n in names]
    if names == list(expected):
        return None
    missing = [j for j in expected if j not in names]
    repeated = sorted({j for j in expected if names.count(j) > 1})
    if missing or repeated:
        what = f"lack {missing}" if missing else f"repeat {repeated}"
        # a gripper's joint in a bare URDF is taken as actuated: say how to leave it out
        fix = " (a robot file whose actuated_joints leave out the joints the controller does " \
            "not drive, or whose locked_joints fix them)" if missing else ""
        raise DataError(
            f"{topic} joint names {names} {what} of the robot's actuated joints "
            f"{list(expected)}; record the topics of this robot's controller, or give "
            f"--robot{fix}")
    return np.array([names.index(n) for n in expected])


def unique_sorted(stamps: np.ndarray) -> tuple[np.ndarray, int]:
    """Indices of the first sample of each distinct stamp (in stamp order), duplicate count."""
    order = np.argsort(stamps, kind="stable")
    s = stamps[order]
    keep = np.ones(s.shape[0], dtype=bool)
    keep[1:] = s[1:] != s[:-1]
    return order[keep], int(s.shape[0] - np.count_nonzero(keep))


def _checked_columns(arr: np.ndarray, stamps: np.ndarray, names: Sequence[str], topic: str,
                     joint_names: Sequence[str], rep: SegmentReport) -> np.ndarray:
    """``arr`` (n, n_j) with its columns in ``joint_names`` order; DataError on a wrong shape or
    names (``arr`` has one column per name in ``names``)."""
    if arr.ndim != 2 or arr.shape[0] != stamps.shape[0] or arr.shape[1] != len(names):
        raise DataError(
            f"{topic} holds an array of shape {arr.shape} for {stamps.shape[0]} stamps; "
            f"expected ({stamps.shape[0]}, {len(names)})"
        )
    perm = column_order(names, topic, joint_names)
    if perm is None:
        return arr
    rep.reordered.append(topic.rsplit(": ", 1)[-1])
    return arr[:, perm]


def pairing_tolerance_ns(stamps_q: np.ndarray) -> int:
    """Largest stamp difference that still pairs two samples: under half the median tick (so a
    neighbouring tick never pairs), from the positions' sorted distinct stamps."""
    dt = np.diff(stamps_q)
    return max(int((float(np.median(dt)) - 1) // 2), 0) if dt.size else 0


def nearest_pairs(sq: np.ndarray, sv: np.ndarray, tol_ns: int) -> tuple[np.ndarray, np.ndarray]:
    """Indices (iq, iv) pairing stamps of ``sq`` with the nearest of ``sv`` within ``tol_ns``
    (both sorted, distinct; one to one, the nearer wins a shared partner; equal stamps always
    pair). With tol_ns = 0 it is the intersection of the two."""
    if sq.size == 0 or sv.size == 0:
        return np.zeros(0, np.intp), np.zeros(0, np.intp)
    right = np.clip(np.searchsorted(sv, sq), 0, sv.size - 1)
    left = np.clip(right - 1, 0, sv.size - 1)
    d_left, d_right = np.abs(sq - sv[left]), np.abs(sv[right] - sq)
    j = np.where(d_right < d_left, right, left)
    d = np.minimum(d_left, d_right)
    ok = np.flatnonzero(d <= tol_ns)
    if ok.size == 0:
        return ok, ok
    # a partner claimed twice (adjacent in q order): the nearer claim keeps it
    order = ok[np.lexsort((d[ok], j[ok]))]
    first = np.ones(order.size, bool)
    first[1:] = j[order[1:]] != j[order[:-1]]
    iq = np.sort(order[first])
    return iq, j[iq]


def _pair(stamps_q: np.ndarray, q: np.ndarray, stamps_v: np.ndarray, v_tau: np.ndarray,
          rep: SegmentReport, source: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Samples of both topics paired by stamp (equal, or nearest within half a tick), in stamp
    order, with the positions' stamps (duplicates keep the first): the stamps and the indices
    of the paired samples in q and in v_tau."""
    iq, dq = unique_sorted(stamps_q)
    iv, dv = unique_sorted(stamps_v)
    rep.n_duplicate_stamps = dq + dv
    sq, sv = stamps_q[iq], stamps_v[iv]
    jq, jv = nearest_pairs(sq, sv, pairing_tolerance_ns(sq))
    stamps = sq[jq]
    rep.n_paired = int(stamps.shape[0])
    rep.n_unpaired_joint_states = int(iq.shape[0] - stamps.shape[0])
    rep.n_unpaired_current_reference = int(iv.shape[0] - stamps.shape[0])
    if rep.n_paired < 2:
        raise DataError(f"{source}: only {rep.n_paired} joint_states/current_reference samples "
                        "pair by header stamp (equal, or within half a tick); both topics must "
                        "carry the controller tick as stamp")
    return stamps, iq[jq], iv[jv]


def _breaks(stamps: np.ndarray, finite: np.ndarray, rep: SegmentReport, source: str) -> np.ndarray:
    """Where the record splits: a missing tick, a non-nominal step, or a non-finite tick."""
    dt = np.diff(stamps)
    period_ns = float(np.median(dt))
    if period_ns <= 0:
        raise DataError(f"{source}: cannot infer the sampling period from the stamps")
    brk, rep.n_missing_ticks = find_breaks_local(dt, period_ns)
    rep.steps = step_stats(stamps, mean_over=~brk)
    # the mean step of the continuous runs: the time base's T̄ (the median on a steady clock,
    # where it is kept exactly so that uniform records give the same numbers as before)
    rep.period_s = period_ns * 1e-9 if not rep.steps.uneven else rep.steps.mean_s
    n_bad = int(finite.shape[0] - np.count_nonzero(finite))
    if n_bad:  # non-finite ticks are removed: they split the record where they sit
        brk = brk | ~finite[:-1] | ~finite[1:]
        rep.n_missing_ticks += n_bad
    rep.n_gaps = int(np.count_nonzero(brk))
    return brk


def _segments(
    stamps: np.ndarray,
    qp: np.ndarray,
    vp: np.ndarray,
    finite: np.ndarray,
    brk: np.ndarray,
    min_samples: int,
    rep: SegmentReport,
    qdp: np.ndarray | None = None,
) -> list[Segment]:
    starts = np.concatenate(([0], np.flatnonzero(brk) + 1))
    ends = np.concatenate((np.flatnonzero(brk) + 1, [stamps.shape[0]]))
    segments: list[Segment] = []
    for a, b in zip(starts, ends):
        while a < b and not finite[a]:  # a boundary sits on each side of a bad tick: skip it
            a += 1
        if a < b and not finite[b - 1]:
            b -= 1
        n = b - a
        if n <= 0:
            continue
        if n < min_samples:
            rep.n_short_segments_dropped += 1
            rep.n_samples_in_short_segments += int(n)
            continue
        segments.append(Segment(stamps[a:b].copy(), qp[a:b].copy(), vp[a:b].copy(),
                                None if qdp is None else qdp[a:b].copy()))
    rep.n_segments = len(segments)
    rep.n_used = int(sum(len(s) for s in segments))
    return segments


def split_record(
    stamps_q_ns: np.ndarray,
    names_q: Sequence[str],
    q: np.ndarray,
    stamps_v_ns: np.ndarray,
    names_v: Sequence[str],
    v_tau: np.ndarray,
    min_samples: int,
    nonfinite: str = "error",
    source: str = "record",
    joint_names: Sequence[str] = (),
    qd: np.ndarray | None = None,
) -> tuple[list[Segment], SegmentReport]:
    """Pair q and v_tau by exact stamp, find missing ticks and split into continuous segments.

    ``q: (N_q, len(names_q))`` and ``v_tau: (N_v, len(names_v))`` (m or rad, A) with their int64
    stamps in ns; the segments hold the robot's ``joint_names`` (default ``names_q``), in that
    order. The tick period is
    the median difference of the paired stamps; a stamp difference outside (0.5, 1.5) periods is a
    gap. Segments shorter than ``min_samples`` are dropped (counted in the report).
    Raises :class:`DataError` on mismatched joint names, non-finite data (``nonfinite="error"``),
    or when fewer than two samples pair up. ``qd`` (like ``q``): a recorded joint velocity
    carried into the segments beside q (its non-finite values are the caller's to check).
    """
    if nonfinite not in ("error", "drop"):
        raise DataError(f"nonfinite must be 'error' or 'drop', not {nonfinite!r}")
    rep = SegmentReport()
    stamps_q_ns = np.asarray(stamps_q_ns, dtype=np.int64)
    stamps_v_ns = np.asarray(stamps_v_ns, dtype=np.int64)
    rep.n_joint_states = int(stamps_q_ns.shape[0])
    rep.n_current_reference = int(stamps_v_ns.shape[0])
    joint_names = tuple(joint_names) or tuple(str(n) for n in names_q)
    q = _checked_columns(
        np.asarray(q, dtype=float),
        stamps_q_ns,
        names_q,
        f"{source}: joint_states",
        joint_names,
        rep,
    )
    v_tau = _checked_columns(np.asarray(v_tau, dtype=float), stamps_v_ns, names_v,
                             f"{source}: current_reference", joint_names, rep)
    iq = None
    if qd is not None:
        qd = _checked_columns(np.asarray(qd, dtype=float), stamps_q_ns, names_q,
                              f"{source}: joint_states velocity", joint_names, SegmentReport())
    stamps, iq, iv = _pair(stamps_q_ns, q, stamps_v_ns, v_tau, rep, source)
    qp, vp = q[iq], v_tau[iv]
    finite = np.isfinite(qp).all(axis=1) & np.isfinite(vp).all(axis=1)
    n_bad = int(finite.shape[0] - np.count_nonzero(finite))
    if n_bad and nonfinite == "error":
        first = (stamps[~finite][0] - stamps[0]) * 1e-9
        raise DataError(
            f"{source}: {n_bad} samples hold NaN or inf (first at t = {first:.3f} s into the "
            "record); fix the recording or set nonfinite: drop to treat them as gaps"
        )
    rep.n_nonfinite_dropped = n_bad
    segments = _segments(stamps, qp, vp, finite, _breaks(stamps, finite, rep, source), min_samples,
                         rep, None if qd is None else qd[iq])
    if not segments:
        raise DataError(f"{source}: no continuous run of at least {min_samples} samples "
                        f"({min_samples * rep.period_s:.2f} s) without a gap; {rep.summary()}")
    return segments, rep
