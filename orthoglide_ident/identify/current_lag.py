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
"""
from __future__ import annotations

import numpy as np

MIN_PERIODS = 4  # full periods a segment needs: the first is left out, and one other at least
MAX_REPEAT_ERROR = 0.002  # rms of q(k + P) - q(k) over rms of q, past the first period
MIN_PERIOD_S = 0.2  # s, shortest period looked for


def find_period(q: np.ndarray, period_s: float) -> int | None:
    """Samples of the period with which the positions ``q`` (m, 3) repeat, or None.

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
    f = np.fft.rfft(x, 2 * n, axis=0)
    corr = np.fft.irfft(f * np.conj(f), 2 * n, axis=0)[:p_max + 1].sum(axis=1)  # Σ_k x_k·x_k+P
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
    """(m, 3) A/s: per tick, the mean of v̇_τ over the other periods at its phase (the first
    period left out of every mean); None when ``q`` does not repeat (:func:`find_period`)."""
    P = find_period(q, period_s)
    if P is None:
        return None
    v_dot = np.gradient(np.asarray(v_tau, float), period_s, axis=0)
    n_full = v_dot.shape[0] // P
    periods = v_dot[:n_full * P].reshape(n_full, P, -1)
    total = periods[1:].sum(axis=0)  # steady periods only
    out = np.empty_like(v_dot)
    for k in range(n_full):
        own, count = (periods[k], n_full - 2) if k >= 1 else (0.0, n_full - 1)
        out[k * P:(k + 1) * P] = (total - own) / count
    rest = v_dot.shape[0] - n_full * P  # a last partial period: the mean of the full ones
    out[n_full * P:] = total[:rest] / (n_full - 1)
    return out
