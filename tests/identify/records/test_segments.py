"""Pairing by stamp, gaps and segments (identify/segments.py)."""
from __future__ import annotations

import numpy as np
import pytest

from orthoglide_ident.errors import DataError
from orthoglide_ident.identify.records.segments import split_record

NAMES = ("q11", "q12", "q13")
T_NS = 1_000_000


def _data(n: int = 5000, t0: int = 10**18):
    stamps = t0 + np.arange(n, dtype=np.int64) * T_NS
    q = np.cumsum(np.ones((n, 3)), axis=0) * 1e-6
    v = np.ones((n, 3)) * 0.1
    return stamps, q, v


def test_continuous_record_is_one_segment():
    s, q, v = _data()
    segs, rep = split_record(s, NAMES, q, s, NAMES, v, min_samples=100)
    assert len(segs) == 1 and len(segs[0]) == 5000
    assert rep.period_s == pytest.approx(1e-3)
    assert rep.n_missing_ticks == 0 and rep.n_gaps == 0 and rep.n_used == 5000


def test_gaps_split_and_short_segments_are_dropped_and_counted():
    s, q, v = _data()
    keep = np.ones(5000, bool)
    keep[1000:1003] = False  # 3 missing ticks
    keep[4950:4952] = False  # leaves a 48-sample tail: too short
    sq, qq = s[keep], q[keep]
    # the current reference misses one more tick of its own
    kv = keep.copy()
    kv[3000] = False
    segs, rep = split_record(sq, NAMES, qq, s[kv], NAMES, v[kv], min_samples=100)
    assert [len(x) for x in segs] == [1000, 1997, 1949]
    assert rep.n_missing_ticks == 3 + 2 + 1
    assert rep.n_gaps == 3
    assert rep.n_unpaired_joint_states == 1
    assert rep.n_short_segments_dropped == 1 and rep.n_samples_in_short_segments == 48
    # never across a gap: each segment is consecutive ticks
    for seg in segs:
        assert np.all(np.diff(seg.stamps_ns) == T_NS)


def test_duplicates_and_unsorted_stamps():
    s, q, v = _data(1000)
    perm = np.random.default_rng(0).permutation(1000)
    sq = np.concatenate([s[perm], s[:5]])
    qq = np.concatenate([q[perm], q[:5]])
    segs, rep = split_record(sq, NAMES, qq, s, NAMES, v, min_samples=100)
    assert len(segs) == 1 and np.array_equal(segs[0].q, q)
    assert rep.n_duplicate_stamps == 5


def test_nan_raises_with_reason_or_becomes_a_gap():
    s, q, v = _data()
    v[2500, 1] = np.nan
    with pytest.raises(DataError, match="NaN"):
        split_record(s, NAMES, q, s, NAMES, v, min_samples=100)
    segs, rep = split_record(s, NAMES, q, s, NAMES, v, min_samples=100, nonfinite="drop")
    assert [len(x) for x in segs] == [2500, 2499]
    assert rep.n_nonfinite_dropped == 1


def test_joint_names_mismatch_and_permutation():
    s, q, v = _data(1000)
    with pytest.raises(DataError, match="joint names"):
        split_record(s, ("a", "b", "c"), q, s, NAMES, v, min_samples=100)
    with pytest.raises(DataError, match="joint names"):
        split_record(s, NAMES, q, s, ("q11", "q12", "q14"), v, min_samples=100)
    v2 = v.copy()
    v2[:, 0] = 7.0
    segs, rep = split_record(s, NAMES, q, s, ("q12", "q11", "q13"), v2, min_samples=100)
    assert np.all(segs[0].v_tau[:, 1] == 7.0) and rep.reordered == ["current_reference"]


def test_currents_of_another_publisher_pair_by_nearest_stamp():
    """A controller stamping with its own clock (offset, jitter under half a tick) pairs as if
    it shared the stamps; the pairs keep the positions' stamps."""
    s, q, v = _data(1000)
    same, _ = split_record(s, NAMES, q, s, NAMES, v, min_samples=100)
    jitter = np.random.default_rng(0).integers(-150_000, 150_000, s.shape[0])
    drop = np.ones(1000, bool)
    drop[500] = False  # one current lost: a gap, as with equal stamps
    segs, rep = split_record(s, NAMES, q, (s + 300_000 + jitter)[drop], NAMES, v[drop],
                             min_samples=100)
    assert rep.n_paired == 999 and rep.n_gaps == 1 and rep.n_unpaired_joint_states == 1
    assert np.array_equal(np.concatenate([g.stamps_ns for g in segs]), s[drop])
    assert np.array_equal(np.concatenate([g.v_tau for g in segs]), v[drop])
    assert np.array_equal(same[0].q, q)


def test_no_common_stamps_and_all_too_short():
    s, q, v = _data(1000)
    with pytest.raises(DataError, match="pair by header stamp"):
        split_record(s, NAMES, q, s + T_NS // 2, NAMES, v, min_samples=100)  # half a tick off
    keep = np.ones(1000, bool)
    keep[::50] = False
    with pytest.raises(DataError, match="no continuous run"):
        split_record(s[keep], NAMES, q[keep], s[keep], NAMES, v[keep], min_samples=100)
