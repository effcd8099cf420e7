"""The decimated inverse dynamic identification model of one record (eq. 20), joint by joint.

One :class:`Observations` per bag: ``W: (n_j, r, n_b)`` for the robot's n_j actuated joints
(joint j's r decimated equations in ``W[j]``), the decimated current references ``v_tau: (n_j,
r)`` and the decimated column of the known payload ``w_m: (n_j, r)`` (W_kl of eq. 33 per kg: the
payload's efforts for its known centre of mass and inertia, RobotModel.with_payload; for the
Orthoglide's translating platform only its mass acts, so χ_ul is empty). Stacking ``W[j]`` over j
gives the paper's ``(n_j r, n_b)`` layout, rows grouped joint by joint.
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
    W: np.ndarray  # (n_j, r, n_b), n_j actuated joints
    v_tau: np.ndarray  # (n_j, r)
    w_m: np.ndarray  # (n_j, r)
    t: np.ndarray | None = None  # (r,) s since the record's first stamp (state instants)
    keep: np.ndarray | None = None  # (n_j, r) bool: rows used (e.g. away from velocity reversal)
    q: np.ndarray | None = None  # (r, n_j) m or rad, filtered positions at the rows' instants
    qd: np.ndarray | None = None  # (r, n_j) m/s or rad/s, filtered velocities there
    row_period_s: float | None = None  # s between consecutive decimated rows of a segment
    decimation: int = 1  # n_d of the rows (the decimation filter's gain, uncertainty.py)
    screws: tuple[bool, ...] | None = None  # joints whose position spectrum is looked at

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
