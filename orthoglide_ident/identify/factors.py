"""Decimated equations kept as per-joint R factors: bounded memory whatever the record length.

IDIM-TLS (eq. 33) and IDIM-WLS (eq. 28) only need, for each joint j, the Gram matrix of the
columns of its equations, which a QR factorisation holds exactly: with the joint-j rows of
X_j = [W_j | W_kl,j | v_τ,j] (r_j × (n_b + 2), every record with the same payload stacked)
factored as X_j = Q_j R_j, any matrix of the form X_j·T (the weighted W_tot rows of eq. 33, or
[A_j | Y_j] of eq. 28 with given gains) has the R factor of R_j·T. New rows are folded in as
they come (R_j ← R of [R_j; X_new]), so the live identification's memory and cost per second
of data stay constant, and the offline pipeline solves from the same factors.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from orthoglide_ident.identify.observations import Observations

FOLD_ROWS = 8192  # equations factored at once: a few MB whatever the record length


@dataclass
class RecordFactors:
    """R factors of the equations of the records taken with one payload (or none).

    ``R[j]``: (≤ n_b + 2, n_b + 2) upper triangular, columns [W (n_b) | W_kl | v_τ];
    ``rows[j]``: equations of joint j folded in; ``n_samples``: decimated samples (before the
    reversal selection); ``sources``: the records (bags) folded in.
    """

    condition: str  # "loaded" | "unloaded"
    payload_mass: float  # kg, 0 when unloaded
    n_b: int
    sources: list[str] = field(default_factory=list)
    R: list[np.ndarray] = field(default_factory=list)
    rows: np.ndarray = field(default_factory=lambda: np.zeros(3, dtype=int))
    n_samples: int = 0

    def __post_init__(self) -> None:
        if not self.R:
            self.R = [np.zeros((0, self.n_b + 2)) for _ in range(3)]

    @property
    def loaded(self) -> bool:
        return self.condition == "loaded"

    @property
    def source(self) -> str:
        return ", ".join(self.sources)

    def rows_per_joint(self) -> list[int]:
        return [int(x) for x in self.rows]

    @property
    def n_rows(self) -> int:
        return int(self.rows.sum())

    def fold(self, X: np.ndarray, keep: np.ndarray | None = None) -> None:
        """Fold decimated equations ``X: (n_b + 2, 3, r)`` (rows kept where ``keep: (3, r)``)."""
        self.n_samples += int(X.shape[2])
        for j in range(3):
            self.fold_joint(j, (X[:, j, :] if keep is None else X[:, j, keep[j]]).T)

    def fold_joint(self, j: int, rows: np.ndarray) -> None:
        """Fold joint j's equations ``rows: (r, n_b + 2)``, FOLD_ROWS at a time (bounded memory)."""
        for a in range(0, rows.shape[0], FOLD_ROWS):
            part = rows[a:a + FOLD_ROWS]
            self.rows[j] += part.shape[0]
            self.R[j] = np.linalg.qr(np.vstack([self.R[j], part]), mode="r")

    def add_source(self, source: str) -> None:
        if source not in self.sources:
            self.sources.append(source)

    @classmethod
    def from_observations(cls, obs: Observations) -> "RecordFactors":
        """The factors of one record's decimated equations."""
        n_b = obs.W.shape[2]
        f = cls(obs.condition, float(obs.payload_mass), n_b, [obs.source])
        f.n_samples = obs.n_samples
        for j in range(3):
            sel = slice(None) if obs.keep is None else obs.keep[j]
            f.fold_joint(j, np.column_stack([obs.W[j][sel], obs.w_m[j][sel], obs.v_tau[j][sel]]))
        return f

    def joint_r(self, j: int, T: np.ndarray) -> np.ndarray:
        """R_j·T: the triangular factor's rows mapped to another column layout (same Gram)."""
        return self.R[j] @ T


def as_factors(blocks: list) -> list[RecordFactors]:
    """Observations (one per record) or factors, as factors."""
    return [b if isinstance(b, RecordFactors) else RecordFactors.from_observations(b)
            for b in blocks]
