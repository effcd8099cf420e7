"""The decimated inverse dynamic identification model of one record (eq. 20), joint by joint.

One :class:`Observations` per bag: ``W: (3, r, n_b)`` (joint j's r decimated equations in
``W[j]``), the decimated current references ``v_tau: (3, r)`` and the decimated column of the
payload mass ``w_m: (3, r)`` (W_kl of eq. 29 for m_7; the other nine payload parameters have no
effect on the translating platform, so χ_ul is empty). Stacking ``W[j]`` over j gives the paper's
``(3 r, n_b)`` layout, rows grouped joint by joint.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class Observations:
    """Decimated IDIM of one record. Forces are g_tau·v_tau (N), v_tau in A, W in model units."""

    source: str
    condition: str  # "loaded" | "unloaded"
    payload_mass: float  # kg (0 when unloaded); for WLS the tagged value, estimated again
    W: np.ndarray  # (3, r, n_b)
    v_tau: np.ndarray  # (3, r)
    w_m: np.ndarray  # (3, r)
    t: np.ndarray | None = None  # (r,) s since the record's first stamp (state instants)
    keep: np.ndarray | None = None  # (3, r) bool: rows used (e.g. away from velocity reversal)
    q: np.ndarray | None = None  # (r, 3) m, filtered positions at the rows' instants
    qd: np.ndarray | None = None  # (r, 3) m/s, filtered velocities at the rows' instants
    row_period_s: float | None = None  # s between consecutive decimated rows of a segment
    decimation: int = 1  # n_d of the rows (the decimation filter's gain, uncertainty.py)

    @property
    def n_samples(self) -> int:
        """Decimated samples per joint (r), before the ``keep`` selection."""
        return int(self.v_tau.shape[1])

    def rows_per_joint(self) -> list[int]:
        """Equations kept for each joint."""
        if self.keep is None:
            return [self.n_samples] * self.v_tau.shape[0]
        return [int(k.sum()) for k in self.keep]

    @property
    def n_rows(self) -> int:
        return int(sum(self.rows_per_joint()))

    @property
    def loaded(self) -> bool:
        return self.condition == "loaded"
