"""Velocity reversals: where the model's sign() Coulomb friction and the drive disagree.

At a reversal of joint j the model switches fs_j·sign(q̇_j) in one sample, while the drive's
friction turns smoothly (and the zero-order hold averages the switch over a tick). The mismatch
is up to 2·fs (tens of N) on one or two samples — tens of times the current noise — and the
decimation filter would spread it over its window. docs/design/method.md: it biases the payload mass
by
~1.5 % when ignored.

Cure without losing the high-acceleration samples that sit at reversals: for each joint, the
short run of samples with |q̂̇_j| below a dead band (or straddling a sign change) is **bridged**:
the joint-j equation (its W row, W_kl and v_τ) is replaced by the straight line between the clean
samples on either side. W·χ = Y holds at both ends, so it holds exactly on the bridge, and the
sign() step disappears. Runs too long to bridge (slow reversals, pauses) or touching a segment
end are reported in a mask; rows whose decimation window meets them are left out.

:func:`find_reversals` decides on a whole segment; :class:`ReversalTracker` takes the same
decisions on a stream of blocks (stream.py, offline FIR path and live), where the bridges are
applied in order, each reading its anchors as the previous bridges left them. :func:`bridge`
applies them chunk by chunk for the chunked cheby1 path.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from orthoglide_ident.identify.observe.joint_units import transmission_scale


def velocity_deadband(model, deadband: float) -> float | np.ndarray:
    """The dead band of ``model``'s velocities: ``deadband`` (m/s or rad/s of a joint), or per
    motor of a robot identified in actuator space (model/actuator_space.py) that joint band
    times the motor's largest reduction s_a = max_j |N_aj| (joint_units.transmission_scale),
    so a motor's reversals are bridged as its joint's would be."""
    s = transmission_scale(model)
    return deadband if s is None else deadband * s


@dataclass
class ReversalZones:
    """Per joint, bridgeable runs ``starts[j], ends[j]`` (samples s..e-1, clean s-1 and e) and
    the full-rate ``drop`` mask (n, n_j) of runs that could not be bridged."""

    starts: list[np.ndarray]
    ends: list[np.ndarray]
    drop: np.ndarray
    max_bridge: int
    anchor: int = 30  # samples averaged on each side of a bridge (anchor_samples)

    @property
    def n(self) -> int:
        return int(self.drop.shape[0])

    @property
    def margin_needed(self) -> int:
        """Samples a chunk needs on each side so that its bridges have both anchors."""
        return self.max_bridge + self.anchor + 1

    @property
    def n_bridged(self) -> int:
        return int(sum(int(np.sum(e - s)) for s, e in zip(self.starts, self.ends)))

    @property
    def n_dropped(self) -> int:
        return int(self.drop.sum())


def find_reversals(qd: np.ndarray, deadband: float, max_bridge: int, margin: int = 0
                   ) -> ReversalZones:
    """Runs of |q̂̇_j| < ``deadband`` or sign changes, per joint; ``qd: (n, n_j)`` in m/s or rad/s.

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


# Samples averaged on each side of a bridge (the per-sample equation is noisy). 30 rather than 10:
# over 5 seeds x {nominal, realistic} x {30, 60 s} (bench/identify_accuracy.py) the rms gain error
# fell from 0.20 to 0.17 % and the gains within 2 honest σ rose from 87 to 92 %. Above 1 kHz in
# time, 30 ms (ANCHOR_S), so that a 5 kHz record and the same at 1 kHz bridge alike (the largest
# base-parameter difference fell from 4.3 to 2.0 σ); never fewer than 30 samples, for the noise:
# on the UR5 at 91 Hz, 3 samples (30 ms) put a gain 3.2 σ off, 10 samples 2.2 σ, 30 samples 1.9 σ.
ANCHOR = 30
ANCHOR_S = 0.03


def anchor_samples(period_s: float) -> int:
    """Samples averaged on each side of a bridge: max(ANCHOR, ANCHOR_S / period_s)."""
    return max(ANCHOR, int(round(ANCHOR_S / period_s)))


def bridge(zones: ReversalZones, a: int, arrays: dict[str, np.ndarray], anchor: int | None = None
           ) -> None:
    """Bridge the runs in ``arrays`` (samples a.., time on axis 0, joints on axis 1), in place.

    The straight line joins the means of ``anchor`` samples on each side (at their mean
    instants): one sample's equation carries the encoder's quantisation noise, amplified by the
    differentiation, which a two-point line would copy along the whole bridge. Only runs whose
    anchors lie inside the arrays are bridged; callers give ``margin_needed`` samples of margin.
    """
    anchor = zones.anchor if anchor is None else anchor
    m = next(iter(arrays.values())).shape[0]
    for j, (s_all, e_all) in enumerate(zip(zones.starts, zones.ends)):
        lo_a = np.maximum(s_all - anchor, 0)
        hi_a = np.minimum(e_all + anchor, zones.n)
        sel = (lo_a >= a) & (hi_a <= a + m)
        for s, e, l0, h0 in zip(s_all[sel] - a, e_all[sel] - a, lo_a[sel] - a, hi_a[sel] - a):
            alpha = bridge_weights(s, e, l0, h0)
            for x in arrays.values():
                lo = x[l0:s, j].mean(axis=0)
                hi = x[e:h0, j].mean(axis=0)
                shape = (-1,) + (1,) * (lo.ndim)
                x[s:e, j] = lo + alpha.reshape(shape) * (hi - lo)


def bridge_weights(s: int, e: int, lo: int, hi: int) -> np.ndarray:
    """Position (0..1) of samples s..e-1 on the line between the anchor means [lo, s), [e, hi)."""
    t_lo = 0.5 * (lo + s - 1)
    t_hi = 0.5 * (e + hi - 1)
    return (np.arange(s, e) - t_lo) / (t_hi - t_lo)


@dataclass
class _Group:
    """Raw runs of one joint merged once widened: first raw start, last raw end (exclusive)."""

    s_raw: int
    e_raw: int
    run_start: int  # start of the last raw run (for its length)
    long: bool = False
    raw_open: bool = False  # the last raw run reaches the newest sample


@dataclass
class Decision:
    """A finished group of joint j: bridge samples s..e-1 (``ok``) or drop them."""

    j: int
    s: int
    e: int
    ok: bool


class ReversalTracker:
    """:func:`find_reversals` on a stream of q̂̇ blocks, with the same runs and decisions.

    ``update(qd_block)`` takes the next states (n_new, n_j), m/s or rad/s; ``update(None, n_total)``
    ends the
    segment. Decided groups come out in order (``pop_decisions``); ``final_upto(j)`` is the state
    index below which joint j's bridges and drops are all known (what a consumer may use now).
    """

    def __init__(self, deadband: float, max_bridge: int, margin: int, n_j: int):
        self.deadband = deadband
        self.max_bridge = max_bridge
        self.margin = margin
        self.pos = 0  # states whose dead-band flag is final
        self.n: int | None = None  # states in the segment, once it has ended
        self._tail_qd: np.ndarray | None = None  # last state: its flag waits for the next sign
        self._tail_bad: np.ndarray | None = None
        self._open: list[_Group | None] = [None] * n_j
        self.decisions: list[Decision] = []

    def update(self, qd: np.ndarray | None, n_total: int | None = None) -> None:
        """Feed states (``qd: (m, n_j)``); with ``n_total`` the segment ends after them."""
        if qd is not None and qd.shape[0]:
            bad = np.abs(qd) < self.deadband
            if self._tail_qd is not None:
                qd = np.concatenate([self._tail_qd, qd])
                bad = np.concatenate([self._tail_bad, bad])
            flip = np.signbit(qd[1:]) != np.signbit(qd[:-1])
            bad[1:] |= flip
            bad[:-1] |= flip
            self._tail_qd, self._tail_bad = qd[-1:].copy(), bad[-1:].copy()
            self._scan(bad[:-1])
        if n_total is not None:
            if self._tail_bad is not None:
                self._scan(self._tail_bad)
                self._tail_qd = self._tail_bad = None
            self.n = n_total
            for j in range(len(self._open)):
                g = self._open[j]
                if g is not None:
                    self._decide(j, g)
                    self._open[j] = None

    def _scan(self, bad: np.ndarray) -> None:
        """Runs of the final flags of states pos .. pos + len(bad) - 1, joint by joint."""
        p0, m = self.pos, bad.shape[0]
        self.pos += m
        for j in range(bad.shape[1]):
            d = np.diff(np.concatenate(([0], bad[:, j].astype(np.int8), [0])))
            g = self._open[j]
            for s, e in zip(np.flatnonzero(d == 1) + p0, np.flatnonzero(d == -1) + p0):
                if g is not None and g.raw_open and s == p0:  # the open raw run goes on
                    g.e_raw = e
                elif g is not None and s - g.e_raw <= 2 * self.margin:  # merges once widened
                    g.e_raw, g.run_start = e, s
                else:
                    if g is not None:
                        self._decide(j, g)
                    g = _Group(s, e, s)
                g.long |= g.e_raw - g.run_start > self.max_bridge
                g.raw_open = e == self.pos
            if g is not None:
                g.raw_open = g.e_raw == self.pos
                if self.pos - g.e_raw > 2 * self.margin:
                    self._decide(j, g)  # no later run can reach it once widened
                    g = None
            self._open[j] = g

    def _decide(self, j: int, g: _Group) -> None:
        s = max(g.s_raw - self.margin, 0)
        e = g.e_raw + self.margin if self.n is None else min(g.e_raw + self.margin, self.n)
        ok = s >= 1 and not g.long and (self.n is None or e <= self.n - 1)
        self.decisions.append(Decision(j, int(s), int(e), bool(ok)))

    def final_upto(self, j: int) -> int:
        """States below this index have their joint-j decision made (or lie in no run)."""
        if self.n is not None:
            return self.n
        g = self._open[j]
        if g is None:
            return max(self.pos - self.margin, 0)
        s = max(g.s_raw - self.margin, 0)
        if g.long:  # dropped whatever follows: final up to its known widened end
            return max(s, min(g.e_raw + self.margin, self.pos))
        return s

    def open_drop(self, j: int) -> tuple[int, int] | None:
        """Samples already known to be dropped in joint j's open (long) group."""
        g = self._open[j]
        if self.n is not None or g is None or not g.long:
            return None
        return max(g.s_raw - self.margin, 0), self.final_upto(j)


def rows_clear(drop: np.ndarray, n_d: int, r: int, method: str) -> np.ndarray:
    """(r, n_j) bool: decimated rows whose filter window meets no dropped sample."""
    if method != "fir":
        return ~drop[0::n_d][:r]
    L = 8 * n_d + 1
    cs = np.concatenate([np.zeros((1, drop.shape[1]), dtype=np.int64),
                         np.cumsum(drop, axis=0, dtype=np.int64)])
    start = np.arange(r) * n_d
    return (cs[start + L] - cs[start]) == 0
