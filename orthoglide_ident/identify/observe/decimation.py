"""Parallel decimation of Y and of every column of W (paper eqs. (19)-(20)).

The same zero-phase low-pass filter, cut-off 0.8·f_m/(2·n_d), is applied to the force signal and
to each column of the observation matrix, joint by joint and segment by segment, then one sample
in n_d is kept. Filtering is linear, so W·χ = Y holds after decimation exactly as before (eq. 20).

Two filters, both zero phase:

- ``fir`` (default): a symmetric (linear-phase, centred, hence zero-phase) windowed-sinc FIR of
  8·n_d + 1 taps, like MATLAB ``decimate(x, r, 'fir')`` but longer. It is evaluated only at the
  kept samples (polyphase, a few BLAS calls), and each output depends on a known window of
  inputs, so chunked evaluation is exact. Outputs whose window would cross a segment end are
  not produced (4 n_d samples lost at each end of a segment).
- ``cheby1``: MATLAB ``decimate``'s default IIR, Chebyshev I order 8, 0.05 dB, run forward and
  backward (``sosfiltfilt``); chunks overlap by the filter's settling length (~1e-13).

W at the full rate is large (120k samples × 3 joints × n_b columns), so it is never built whole:
:func:`decimate_chunked` asks a producer for chunks along time and keeps only what each chunk
determines, so peak memory is set by the chunk length, not the record length.
"""
from __future__ import annotations

from collections.abc import Callable, Mapping
from functools import lru_cache

import numpy as np

from orthoglide_ident.errors import DataError

Producer = Callable[[int, int], Mapping[str, np.ndarray]]


@lru_cache(maxsize=16)
def decimation_sos(n_d: int) -> np.ndarray:
    """Chebyshev I low-pass of MATLAB ``decimate``: order 8, 0.05 dB, cut-off 0.8/n_d of Nyquist."""
    if n_d < 1:
        raise DataError(f"decimation factor must be >= 1, not {n_d}")
    from scipy import signal  # imported on demand: scipy.signal takes ~0.5 s to import

    return signal.cheby1(8, 0.05, 0.8 / n_d, output="sos")


@lru_cache(maxsize=16)
def settling_samples(n_d: int, tol: float = 1e-13) -> int:
    """Samples after which the decimation filter's impulse response stays below ``tol``."""
    from scipy import signal

    sos = decimation_sos(n_d)
    n = 200 * n_d + 200
    x = np.zeros(n)
    x[0] = 1.0
    h = np.abs(signal.sosfilt(sos, x))
    above = np.flatnonzero(h > tol * h.max())
    return int(above[-1]) + 1 if above.size else 1


def decimate(x: np.ndarray, n_d: int, axis: int = 0) -> np.ndarray:
    """Zero-phase low-pass then keep samples 0, n_d, 2 n_d, ... along ``axis``."""
    if n_d == 1:
        return np.asarray(x)
    from scipy import signal

    y = signal.sosfiltfilt(decimation_sos(n_d), x, axis=axis)
    idx = [slice(None)] * y.ndim
    idx[axis] = slice(0, None, n_d)
    return np.ascontiguousarray(y[tuple(idx)])


@lru_cache(maxsize=16)
def fir_taps(n_d: int) -> np.ndarray:
    """Zero-phase FIR low-pass: 8·n_d + 1 taps, cut-off 0.8/n_d of Nyquist, unit DC gain."""
    if n_d < 1:
        raise DataError(f"decimation factor must be >= 1, not {n_d}")
    # windowed sinc (= scipy.signal.firwin(8 n_d + 1, 0.8 / n_d, window="hamming"))
    L = 8 * n_d + 1
    k = np.arange(L) - (L - 1) / 2
    fc = 0.8 / n_d  # of Nyquist
    h = fc * np.sinc(fc * k) * np.hamming(L)
    return h / h.sum()


def fir_output_range(n: int, n_d: int) -> tuple[int, int]:
    """First input index and count of the FIR outputs of a segment of ``n`` samples."""
    h = 4 * n_d
    if n < 2 * h + 1:
        return h, 0
    return h, (n - 2 * h - 1) // n_d + 1


def decimated_count(n: int, n_d: int) -> int:
    """Decimated samples the FIR gives for a segment of ``n`` states (all of them if n_d = 1)."""
    return max(n, 0) if n_d == 1 else fir_output_range(n, n_d)[1]


def _fir_block(x: np.ndarray, taps: np.ndarray, n_d: int, r: int) -> np.ndarray:
    """y[i] = Σ_l taps[l] x[i n_d + l], i < r (x holds at least (r - 1) n_d + len(taps) samples)."""
    L = taps.shape[0]
    n_blocks = -(-L // n_d)  # ceil
    need = (r - 1 + n_blocks) * n_d
    if x.shape[0] < need:
        pad = np.zeros((need - x.shape[0],) + x.shape[1:])
        x = np.concatenate([x, pad], axis=0)
    xb = x[:need].reshape((r - 1 + n_blocks, n_d) + x.shape[1:])
    h = np.zeros(n_blocks * n_d)
    h[:L] = taps
    h = h.reshape(n_blocks, n_d)
    flat = xb.reshape(xb.shape[0], n_d, -1)  # (blocks, n_d, C)
    y = np.zeros((r, flat.shape[2]))
    for b in range(n_blocks):
        y += np.matmul(h[b], flat[b:b + r])  # (n_d,) @ (r, n_d, C) -> (r, C)
    return y.reshape((r,) + x.shape[1:])


def fir_decimate_last(x: np.ndarray, n_d: int, r: int, taps: np.ndarray | None = None
                      ) -> np.ndarray:
    """y[..., i] = Σ_l taps[l] x[..., i n_d + l], i < r: the FIR outputs along the last axis.

    Polyphase: ``x`` (..., m) with m ≥ (r - 1) n_d + 8 n_d + 1 is viewed as blocks of n_d
    samples; one matrix product per row multiplies the 8 full blocks of taps by every block,
    output i sums the partial products of blocks i..i+7, plus the last tap: only the kept
    samples are computed (~9 multiply-adds per input sample and column). Each row of ``x``
    must be contiguous in time (a slice of a (rows, capacity) buffer is); no copy is made.
    """
    taps = fir_taps(n_d) if taps is None else taps  # another filter of the same length
    nb = (taps.shape[0] - 1) // n_d  # full blocks: 8
    lead = x.shape[:-1]
    x2 = x.reshape(-1, x.shape[-1])
    xb = x2[:, :(r - 1 + nb) * n_d].reshape(x2.shape[0], r - 1 + nb, n_d)
    Z = np.matmul(taps[:nb * n_d].reshape(nb, n_d), xb.transpose(0, 2, 1))  # (rows, nb, blocks)
    y = taps[-1] * x2[:, nb * n_d:nb * n_d + (r - 1) * n_d + 1:n_d]
    for b in range(nb):
        y += Z[:, b, b:b + r]
    return y.reshape(lead + (r,))


def decimate_fir(x: np.ndarray, n_d: int) -> np.ndarray:
    """Zero-phase FIR decimation along axis 0: outputs at samples 4 n_d, 5 n_d, ... (see above)."""
    if n_d == 1:
        return np.asarray(x)
    first, r = fir_output_range(x.shape[0], n_d)
    if r == 0:
        return np.zeros((0,) + x.shape[1:])
    return _fir_block(np.asarray(x, float), fir_taps(n_d), n_d, r)


def decimate_chunked(
    n: int, n_d: int, producer: Producer, chunk: int = 16384, method: str = "fir",
    out: dict[str, np.ndarray] | None = None,
) -> dict[str, np.ndarray]:
    """Decimate signals of ``n`` samples produced chunk by chunk.

    ``fir``: outputs at input samples 4 n_d + i n_d (i = 0 .. r-1, see :func:`fir_output_range`);
    ``cheby1``: outputs at samples i n_d over the whole segment.

    ``producer(a, b)`` returns a mapping of arrays with time on axis 0, holding samples a..b-1.
    Returns the same keys with samples 0, n_d, 2 n_d, ... of the zero-phase filtered signals, as
    if the whole segment had been filtered at once. Peak memory ~ (chunk + 2·overlap) samples.
    ``out`` (FIR): preallocated outputs (r, ...) to write into, e.g. views of a larger array.
    """
    if n_d == 1:
        return {k: np.asarray(v) for k, v in producer(0, n).items()}
    if method == "fir":
        return _decimate_chunked_fir(n, n_d, producer, chunk, out)
    if method != "cheby1":
        raise DataError(f"unknown decimation filter {method!r}: use fir or cheby1")
    from scipy import signal

    sos = decimation_sos(n_d)
    overlap = settling_samples(n_d) + 6 * sos.shape[0] + n_d
    chunk = max(n_d, (chunk // n_d) * n_d)
    if n <= chunk + 2 * overlap:
        return {k: decimate(v, n_d) for k, v in producer(0, n).items()}
    parts: dict[str, list[np.ndarray]] = {}
    for c0 in range(0, n, chunk):
        c1 = min(n, c0 + chunk)
        a = max(0, c0 - overlap)
        b = min(n, c1 + overlap)
        data = producer(a, b)
        for k, v in data.items():
            y = signal.sosfiltfilt(sos, v, axis=0)
            # keep global samples c0, c0 + n_d, ... < c1 (c0 is a multiple of n_d)
            parts.setdefault(k, []).append(y[c0 - a:c1 - a:n_d])
    return {k: np.concatenate(v, axis=0) for k, v in parts.items()}


def _decimate_chunked_fir(n: int, n_d: int, producer: Producer, chunk: int,
                          out: dict[str, np.ndarray] | None = None) -> dict[str, np.ndarray]:
    taps = fir_taps(n_d)
    L = taps.shape[0]
    first, r_total = fir_output_range(n, n_d)
    if r_total == 0:
        raise DataError(f"segment of {n} samples is shorter than the decimation filter ({L} taps)")
    per = max(1, chunk // n_d)  # outputs per chunk
    res: dict[str, np.ndarray] = dict(out or {})
    for i0 in range(0, r_total, per):
        r = min(per, r_total - i0)
        a = i0 * n_d  # window of output i0 starts at input i0 n_d (centre + 4 n_d)
        b = min(n, a + (r - 1) * n_d + L)
        for k, v in producer(a, b).items():
            y = _fir_block(np.asarray(v, float), taps, n_d, r)
            if k not in res:  # written in place chunk by chunk: no list, no concatenation
                res[k] = np.empty((r_total,) + y.shape[1:])
            res[k][i0:i0 + r] = y
    return res
