"""Velocity reversals: where the model's sign() Coulomb friction and the drive disagree.

At a reversal of joint j the model switches fs_j·sign(q̇_j) in one sample, while the drive's
friction turns smoothly (and the zero-order hold averages the switch over a tick). The mismatch
is up to 2·fs (tens of N) on one or two samples — tens of times the current noise — and the
decimation filter would spread it over its window. DESIGN §6: it biases the payload mass by
~1.5 % when ignored.

Cure without losing the high-acceleration samples that sit at reversals: for each joint, the
short run of samples with |q̂̇_j| below a dead band (or straddling a sign change) is **bridged**:
the joint-j equation (its W row, W_kl and v_τ) is replaced by the straight line between the clean
samples on either side. W·χ = Y holds at both ends, so it holds exactly on the bridge, and the
sign() step disappears. Runs too long to bridge (slow reversals, pauses) or touching a segment
end are reported in a mask; rows whose decimation window meets them are left out.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class ReversalZones:
    """Per joint, bridgeable runs ``starts[j], ends[j]`` (samples s..e-1, clean s-1 and e) and
    the full-rate ``drop`` mask (n, 3) of runs that could not be bridged."""

    starts: list[np.ndarray]
    ends: list[np.ndarray]
    drop: np.ndarray
    max_bridge: int

    @property
    def n(self) -> int:
        return int(self.drop.shape[0])

    @property
    def margin_needed(self) -> int:
        """Samples a chunk needs on each side so that its bridges have both anchors."""
        return self.max_bridge + ANCHOR + 1

    @property
    def n_bridged(self) -> int:
        return int(sum(int(np.sum(e - s)) for s, e in zip(self.starts, self.ends)))

    @property
    def n_dropped(self) -> int:
        return int(self.drop.sum())


def find_reversals(qd: np.ndarray, deadband: float, max_bridge: int, margin: int = 0
                   ) -> ReversalZones:
    """Runs of |q̂̇_j| < ``deadband`` or sign changes, per joint; ``qd: (n, 3)`` in m/s.

    Each run is widened by ``margin`` samples on both sides: the friction step at a reversal is
    an acceleration step that the derivative filter smears over a few milliseconds, so the
    samples next to the dead band do not satisfy the model either. Runs (before widening) longer
    than ``max_bridge`` samples, or touching a segment end, are dropped instead of bridged.
    """
    n, nj = qd.shape
    bad = np.abs(qd) < deadband
    flip = np.signbit(qd[1:]) != np.signbit(qd[:-1])
    bad[1:] |= flip
    bad[:-1] |= flip
    starts, ends = [], []
    drop = np.zeros_like(bad)
    for j in range(nj):
        d = np.diff(np.concatenate(([0], bad[:, j].astype(np.int8), [0])))
        s = np.flatnonzero(d == 1)
        e = np.flatnonzero(d == -1)
        long_run = e - s > max_bridge
        s = np.maximum(s - margin, 0)
        e = np.minimum(e + margin, n)
        if s.size > 1:  # merge runs that overlap once widened
            new = np.concatenate(([True], s[1:] > e[:-1]))
            s = s[new]
            e = np.maximum.reduceat(e, np.flatnonzero(new))
            long_run = np.logical_or.reduceat(long_run, np.flatnonzero(new))
        ok = (s >= 1) & (e <= n - 1) & ~long_run  # both sides have at least one clean sample
        for a, b in zip(s[~ok], e[~ok]):
            drop[a:b, j] = True
        starts.append(s[ok])
        ends.append(e[ok])
    return ReversalZones(starts, ends, drop, max_bridge + 2 * margin)


ANCHOR = 10  # samples averaged on each side of a bridge (the per-sample equation is noisy)


def bridge(zones: ReversalZones, a: int, arrays: dict[str, np.ndarray], anchor: int = ANCHOR
           ) -> None:
    """Bridge the runs in ``arrays`` (samples a.., time on axis 0, joints on axis 1), in place.

    The straight line joins the means of ``anchor`` samples on each side (at their mean
    instants): one sample's equation carries the encoder's quantisation noise, amplified by the
    differentiation, which a two-point line would copy along the whole bridge. Only runs whose
    anchors lie inside the arrays are bridged; callers give ``margin_needed`` samples of margin.
    """
    m = next(iter(arrays.values())).shape[0]
    for j, (s_all, e_all) in enumerate(zip(zones.starts, zones.ends)):
        lo_a = np.maximum(s_all - anchor, 0)
        hi_a = np.minimum(e_all + anchor, zones.n)
        sel = (lo_a >= a) & (hi_a <= a + m)
        for s, e, l0, h0 in zip(s_all[sel] - a, e_all[sel] - a, lo_a[sel] - a, hi_a[sel] - a):
            t_lo = 0.5 * (l0 + s - 1)
            t_hi = 0.5 * (e + h0 - 1)
            alpha = (np.arange(s, e) - t_lo) / (t_hi - t_lo)
            for x in arrays.values():
                lo = x[l0:s, j].mean(axis=0)
                hi = x[e:h0, j].mean(axis=0)
                shape = (-1,) + (1,) * (lo.ndim)
                x[s:e, j] = lo + alpha.reshape(shape) * (hi - lo)


def rows_clear(drop: np.ndarray, n_d: int, r: int, method: str) -> np.ndarray:
    """(r, 3) bool: decimated rows whose filter window meets no dropped sample."""
    if method != "fir":
        return ~drop[0::n_d][:r]
    L = 8 * n_d + 1
    cs = np.concatenate([np.zeros((1, drop.shape[1]), dtype=np.int64),
                         np.cumsum(drop, axis=0, dtype=np.int64)])
    start = np.arange(r) * n_d
    return (cs[start + L] - cs[start]) == 0
