"""The current loop's lag, a drive term the paper's IDIM lacks, identified without the noise bias.

A current loop of time constant τ_j applies g_τj v_τj(t - τ_j) ≈ g_τj (v_τj - τ_j v̇_τj) instead of
the IDIM's g_τj v_τj (eq. 17): unmodelled, 0.12 ms moved the simulated gains by -0.08/+0.11/-0.12 %
(noise-free). Its column v̇_τj, filtered and decimated with W (eqs. 19-20), finds τ noise-free
(0.117/0.118/0.133 ms for 0.12), but not with noise: the current noise is in the applied current
and the position controller answers it within a tick, so the zero-phase derivative of the
recorded reference correlates with the equation error (0.22-0.31 ms found for 0.12; drive_terms.py).

An instrument free of that noise comes from the exciting trajectories themselves (paper Sect.
3.2: periodic Fourier series): the records repeat with the trajectory's period P, and the noise
of one period is independent of the others'. The column of tick k is the mean of v̇_τ over the
*other* periods at the same phase (leave-one-period-out), the first period (the controller's
start transient) left out of the means: it holds the deterministic v̇_τ the lag acts on, with
the noise of n-2 other periods averaged down and none of its own row's. Measured on the
simulated drive (bench/identify_accuracy.py, 30 s + 30 s, 1.983 kg, 20 seeds): τ found
0.099/0.112/0.118 ms (sd 0.025) for 0.12 ms, the reported σ 0.023-0.030 ms; the gains' mean
errors -0.16/+0.17/-0.09 % → -0.08/+0.02/+0.00 %; on the drive without a lag
-0.011/-0.004/+0.007 ms (sd 0.013). Noise-free, the lag-only drive's gains go from
-0.08/+0.11/-0.12 % to +0.00/+0.05/-0.00 % (τ 0.119/0.118/0.131 ms).

When a segment used does not repeat (no period found), the lag is left out of the whole
identification (pipeline._lag_or_paper, the paper's model): a zero column in its rows would leave
the lag's force there and bias τ and the gains (the first 6 s of 30 s records without the
instrument, the rest with it, halved τ on the simulator).

Live (:class:`LiveLagInstrument`), the later periods do not exist yet when a row is folded: each
segment's first ticks are held until its period is found (4 periods), then get the mean over the
other periods held, and every later tick the mean over the periods before its own. On 15 s + 15 s
realistic records the live gains are within 0.05 σ of the offline ones (every parameter within
0.08 σ, τ within 0.013 ms); without holding (a zero instrument until the period is known) τ came
out at half the plant's, for the reason above.
"""
from __future__ import annotations

import numpy as np

MIN_PERIODS = 4  # full periods a segment needs: the first is left out, and one other at least
MAX_REPEAT_ERROR = 0.002  # rms of q(k + P) - q(k) over rms of q, past the first period
MIN_PERIOD_S = 0.2  # s, shortest period looked for
SEARCH_EVERY_S = 1.0  # s, live: the period is searched on the first 1, 2, 3... s of a segment
MAX_SEARCH_S = 30.0  # s, live: longest a segment's ticks are held while its period is searched


def find_period(q: np.ndarray, period_s: float) -> int | None:
    """Samples of the period with which the positions ``q`` (m, n_j) repeat, or None.

    The candidate is the first lag past the first decorrelation where the mean square of
    q(k + P) - q(k) (all lags at once by FFT) comes near its least value; it is kept if it
    repeats within MAX_REPEAT_ERROR after the first period and the segment holds MIN_PERIODS
    of it."""
    n = q.shape[0]
    x = q - q.mean(axis=0)
    p_max = n // MIN_PERIODS
    p_min = max(2, int(round(MIN_PERIOD_S / period_s)))
    if p_max <= p_min:
        return None
    f = np.fft.rfft(np.ascontiguousarray(x.T), 2 * n, axis=1)
    power = (f.real ** 2 + f.imag ** 2).sum(axis=0)  # the joints summed before the inverse
    corr = np.fft.irfft(power, 2 * n)[:p_max + 1]  # Σ_k x_k·x_k+P
    sq = np.cumsum(np.concatenate([[0.0], (x * x).sum(axis=1)]))
    lags = np.arange(p_max + 1)
    head = sq[n - lags]  # Σ_{k < n-P} |x_k|²
    tail = sq[n] - sq[lags]  # Σ_{k >= P} |x_k|²
    d = (head + tail - 2.0 * corr) / (n - lags)
    var = sq[n] / n
    above = np.flatnonzero(d[p_min:] > var)  # past the first decorrelation
    if above.size == 0:
        return None
    lo = p_min + int(above[0])
    if lo >= p_max:
        return None
    near = d[lo:p_max + 1] <= 4.0 * float(np.min(d[lo:p_max + 1])) + 1e-9 * var
    P = lo + int(np.flatnonzero(near)[0])  # the period, not a multiple of it
    while P < p_max and d[P + 1] < d[P]:
        P += 1
    steady = x[P:]  # past the first period
    err = np.sqrt(np.mean((steady[P:] - steady[:-P]) ** 2)) if steady.shape[0] > P else np.inf
    return P if err <= MAX_REPEAT_ERROR * np.sqrt(var) else None


def lag_instrument(q: np.ndarray, v_tau: np.ndarray, period_s: float) -> np.ndarray | None:
    """(m, n_j) A/s: per tick, the mean of v̇_τ over the other periods at its phase (the first
    period left out of every mean); None when ``q`` does not repeat (:func:`find_period`)."""
    P = find_period(q, period_s)
    if P is None:
        return None
    return other_periods_mean(np.gradient(np.asarray(v_tau, float), period_s, axis=0), P)[0]


def other_periods_mean(v_dot: np.ndarray, P: int) -> tuple[np.ndarray, np.ndarray]:
    """Per tick of ``v_dot`` (m, n_j), the mean over the other steady periods at its phase (the
    first period enters no mean; a last partial period gets the mean of the full ones), and
    the (P, n_j) sum over the steady periods."""
    n_full = v_dot.shape[0] // P
    periods = v_dot[:n_full * P].reshape(n_full, P, -1)
    total = periods[1:].sum(axis=0)  # steady periods only
    out = np.empty_like(v_dot)
    out[:P] = total / (n_full - 1)
    out[P:n_full * P] = ((total[None] - periods[1:]) / (n_full - 2)).reshape(-1, v_dot.shape[1])
    out[n_full * P:] = total[:v_dot.shape[0] - n_full * P] / (n_full - 1)
    return out, total


def without_instrument(v_tau: np.ndarray) -> np.ndarray:
    """(m, 2 n_j): v_τ with a zero lag instrument beside it (no period: the lag is left out)."""
    return np.hstack([v_tau, np.zeros_like(v_tau)])


Ticks = tuple  # (stamps_ns (m,), q (m, n_j), v_τ (m, n_j) or (m, 2 n_j) with the instrument)


class RepeatWatch:
    """Live, :func:`find_period`'s repeat criterion kept on the growing segment: at the end of
    every period, the mean square of q(k) - q(k - P) past the first period, so far, within
    MAX_REPEAT_ERROR² of q's variance over the search window (a trajectory switched mid-segment
    fails it within a period; offline, the whole segment would have no period)."""

    def __init__(self, q_window: np.ndarray, P: int):
        x = q_window - q_window.mean(axis=0)
        self.var = float(np.mean((x * x).sum(axis=1)))
        d = q_window[2 * P:] - q_window[P:-P]
        self.P, self.sum, self.count = P, float((d * d).sum()), d.size
        self.n, self.last = q_window.shape[0], q_window[-P:]

    def push(self, q: np.ndarray) -> bool:
        """Ticks after the last ones; False once a period's end broke the criterion."""
        m, P = q.shape[0], self.P
        if m == 0:
            return True
        both = np.concatenate([self.last, q])
        d = both[P:] - both[:-P]
        total = self.sum + np.cumsum((d * d).sum(axis=1))
        count = self.count + d.shape[1] * np.arange(1, m + 1)
        ends = (self.n + np.arange(1, m + 1)) % P == 0  # the last tick of a period
        self.sum, self.count = float(total[-1]), int(count[-1])
        self.n, self.last = self.n + m, both[-P:]
        bar = MAX_REPEAT_ERROR ** 2 * self.var
        return bool(np.all(total[ends] <= bar * count[ends]))


class LiveLagInstrument:
    """The live counterpart of :func:`lag_instrument`, one per segment: ticks pushed in order
    come out, v_τ (m, 2 n_j) with the instrument beside it, once their instrument is known.

    A segment's ticks are held while its period is searched on its first SEARCH_EVERY_S·i s
    (fixed tick counts, so that the batching changes nothing), for at most MAX_SEARCH_S. Found at
    tick ``mark``: with F = (mark - 1) // P whole periods (the tick after them received), the held
    ticks of periods 0..F-1 get lag_instrument's value over those F periods (the mean of v̇_τ
    over the *other* steady periods at their phase, F - 2 ≥ 1 of them); every later tick, of
    period p ≥ F, the mean over the steady periods 1..p-1, all past when it comes. Either way no
    row holds its own period's noise. Not found (``repeats`` False): the held ticks come out with
    a zero instrument, and the identification must leave the lag out (see the module docstring).
    """

    def __init__(self, period_s: float, n_j: int):
        self.T, self.n_j = period_s, n_j
        self.every = max(1, int(round(SEARCH_EVERY_S / period_s)))
        self.max_ticks = int(round(MAX_SEARCH_S / period_s))
        self.n = 0  # ticks received
        self.P: int | None = None
        self.repeats: bool | None = None  # None while searching
        self._held: list[Ticks] = []
        self._sums = np.zeros((0, n_j))  # (P, n_j) Σ v̇_τ over the steady periods 1.._folded
        self._folded = 0
        self._v = np.zeros((0, n_j))  # v_τ from tick _v0 on, for the differences still to take
        self._v0 = 0
        self._watch: RepeatWatch | None = None
        self.why = ""  # when repeats is False: why, for the user

    @property
    def n_held(self) -> int:
        return sum(x[0].shape[0] for x in self._held)

    def push(self, stamps_ns: np.ndarray, q: np.ndarray, v_tau: np.ndarray) -> Ticks | None:
        """The ticks whose instrument became known (None: all held)."""
        k0 = self.n
        self.n += q.shape[0]
        v_tau = np.asarray(v_tau, float)
        if self.repeats is False:
            return stamps_ns, q, without_instrument(v_tau)
        if self.repeats is None:
            self._held.append((stamps_ns, np.asarray(q, float), v_tau))
            mark = self._search(k0)
            if mark is None:
                return self._release_zero() if self.repeats is False else None
            return self._release(mark)
        if not self._watch.push(np.asarray(q, float)):
            return self._stopped(stamps_ns, q, v_tau)
        self._v = np.concatenate([self._v, v_tau])
        return stamps_ns, q, np.hstack([v_tau, self._causal(k0)])

    def _stopped(self, stamps_ns: np.ndarray, q: np.ndarray, v_tau: np.ndarray) -> Ticks:
        self.repeats = False
        self.why = (f"stopped repeating its trajectory (period {self.P * self.T:.3g} s, "
                    f"q(k) - q(k - P) above {100 * MAX_REPEAT_ERROR:g} % of q's rms)")
        return stamps_ns, q, without_instrument(v_tau)

    def finish(self) -> Ticks | None:
        """The segment ended: ticks still held come out with a zero instrument (no period)."""
        if self.repeats is not None or not self._held:
            return None
        self.repeats = False
        self.why = (f"does not repeat a periodic trajectory {MIN_PERIODS} times within its "
                    f"{self.n * self.T:.1f} s")
        return self._release_zero()

    def _release_zero(self) -> Ticks:
        s, q, v = (np.concatenate(x) for x in zip(*self._held))
        self._held = []
        return s, q, without_instrument(v)

    def _search(self, k0: int) -> int | None:
        """The tick count at which the period was found (None: not yet, or given up)."""
        last = min(self.n, self.max_ticks)
        marks = range((k0 // self.every + 1) * self.every, last + 1, self.every)
        if len(marks):
            q = np.concatenate([x[1] for x in self._held])
            for mark in marks:
                P = find_period(q[:mark], self.T)
                if P is not None:
                    self.P, self.repeats = P, True
                    return mark
        if self.n >= self.max_ticks:
            self.repeats = False
            self.why = f"does not repeat a periodic trajectory within {MAX_SEARCH_S:g} s"
        return None

    def _release(self, mark: int) -> Ticks:
        """Every held tick, with lag_instrument over the first F periods, then the causal mean."""
        s, q, v = (np.concatenate(x) for x in zip(*self._held))
        self._held = []
        P, F = self.P, (mark - 1) // self.P
        z = np.empty_like(v)
        v_dot = np.gradient(v[:F * P + 1], self.T, axis=0)[:F * P]  # central inside
        z[:F * P], self._sums = other_periods_mean(v_dot, P)
        self._folded = F - 1
        self._v, self._v0 = v[F * P - 1:], F * P - 1
        z[F * P:] = self._causal(F * P)
        self._watch = RepeatWatch(q[:mark], P)
        if not self._watch.push(q[mark:]):
            return self._stopped(s, q, v)
        return s, q, np.hstack([v, z])

    def _causal(self, k0: int) -> np.ndarray:
        """(n - k0, n_j): ticks k0..n-1, each the mean over the steady periods before its own."""
        P, out, k = self.P, np.empty((self.n - k0, self.n_j)), k0
        while k < self.n:
            p = k // P
            self._fold_upto(p - 1)
            stop = min(self.n, (p + 1) * P)
            out[k - k0:stop - k0] = self._sums[np.arange(k, stop) % P] / self._folded
            k = stop
        keep_from = (self._folded + 1) * P - 1  # the tick before the next period to fold
        if keep_from > self._v0:
            self._v, self._v0 = self._v[keep_from - self._v0:], keep_from
        return out

    def _fold_upto(self, last: int) -> None:
        """Add the steady periods up to ``last`` to the sums (each has the tick after it)."""
        P = self.P
        while self._folded < last:
            p = self._folded + 1
            a = p * P - 1 - self._v0  # central differences: one tick each side
            part = self._v[a:a + P + 2]
            self._sums = self._sums + (part[2:] - part[:-2]) / (2.0 * self.T)
            self._folded = p
