"""Stamps of a source at the rates real robots log at, with known drops (issue 47): a 1 kHz
controller, a 500 Hz one, and a ~83 Hz logger on its own clock (10/12/14 ms steps), each with
single, double and triple drops whose count is the truth the missing-sample counts must give."""
from __future__ import annotations

import numpy as np

T0_NS = 1_796_000_000 * 10**9
RATES = {"1kHz": (1_000_000,), "500Hz": (2_000_000,), "uneven_83Hz": (10_000_000, 12_000_000,
                                                                       14_000_000)}
DROPS = ((100, 1), (240, 2), (377, 3), (505, 1))  # (first sample dropped, how many)


def stamps(rate: str, n: int = 600, drops=DROPS) -> tuple[np.ndarray, int]:
    """``n`` stamps (ns) of ``rate``'s step cycle with ``drops`` taken out; (stamps, truth)."""
    cycle = np.asarray(RATES[rate], np.int64)
    steps = np.resize(cycle, n - 1)
    st = T0_NS + np.concatenate([[0], np.cumsum(steps)])
    keep = np.ones(n, bool)
    for i, k in drops:
        keep[i:i + k] = False
    return st[keep], int(n - keep.sum())
