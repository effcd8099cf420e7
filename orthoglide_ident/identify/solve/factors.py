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

from orthoglide_ident.identify.observe.equations import Observations
from orthoglide_ident.identify.solve.uncertainty import SPARSE_COLUMNS, ResidualMoments

FOLD_ROWS = 8192  # equations factored at once: a few MB whatever the record length


def qr_r(X: np.ndarray) -> np.ndarray:
    """The R factor of ``X`` (m, n): ``np.linalg.qr(X, mode="r")``, or, when X has few non-zero
    columns (a serial arm's joint: SPARSE_COLUMNS), theirs put back in place, (k, n) with k
    their count: still upper triangular (their indices grow at least as fast as the rows'),
    the same Gram Rᵀ R = Xᵀ X, at a quarter of the cost on the UR5."""
    c = np.flatnonzero(np.any(X != 0.0, axis=0))
    if c.size > SPARSE_COLUMNS * X.shape[1]:
        return np.linalg.qr(X, mode="r")
    Rc = np.linalg.qr(X[:, c], mode="r")
    R = np.zeros((Rc.shape[0], X.shape[1]))
    R[:, c] = Rc
    return R


@dataclass
class RecordFactors:
    """R factors of the equations of the records taken with one payload (or none).

    ``R[j]``: (≤ n_b + 2, n_b + 2) upper triangular, columns [W (n_b) | W_kl | v_τ], one per
    actuated joint; ``rows[j]``: equations of joint j folded in; ``n_samples``: decimated samples
    (before the reversal selection); ``sources``: the records (bags) folded in; ``moments``: per
    record, what the honest σ and the residual diagnostics need (uncertainty.py), when the rows
    have instants. ``n_joints`` is taken from ``R`` or ``rows`` when they are given.
    """

    condition: str  # "loaded" | "unloaded"
    payload_mass: float  # kg, 0 when unloaded
    n_b: int
    sources: list[str] = field(default_factory=list)
    R: list[np.ndarray] = field(default_factory=list)
    rows: np.ndarray | None = None
    n_samples: int = 0
    moments: dict[str, ResidualMoments] = field(default_factory=dict)
    n_joints: int = 0
    observations: Observations | None = None  # the rows themselves, offline (IDIM-IV needs them)
    # joints whose current chattered at its limit in these records, with why (their rows and
    # gains are left out of IDIM-TLS: records/robot_checks.current_at_limit)
    at_limit: dict[int, str] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not self.n_joints:
            self.n_joints = len(self.R) or (0 if self.rows is None else len(self.rows))
        if not self.n_joints:
            raise ValueError("RecordFactors needs n_joints (or R / rows to take it from)")
        if not self.R:
            self.R = [np.zeros((0, self.n_b + 2)) for _ in range(self.n_joints)]
        if self.rows is None:
            self.rows = np.zeros(self.n_joints, dtype=int)

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

    def fold(self, X: np.ndarray, keep: np.ndarray | None = None, t: np.ndarray | None = None,
             source: str | None = None, row_period_s: float | None = None,
             q: np.ndarray | None = None, qd: np.ndarray | None = None,
             decimation: int = 1, screws: tuple[bool, ...] | None = None) -> None:
        """Fold decimated equations ``X: (n_b + 2, n_j, r)`` (rows kept where ``keep: (n_j, r)``).

        With the rows' instants ``t: (r,)`` s (and ``source``, the record they belong to, the row
        period, the rows' positions and velocities (r, n_j) and the decimation factor), the residual
        moments are folded too; rows of one record must come in time order.
        """
        self.n_samples += int(X.shape[2])
        for j in range(self.n_joints):
            self.fold_joint(j, (X[:, j, :] if keep is None else X[:, j, keep[j]]).T)
        if t is not None:
            key = source if source is not None else (self.sources[-1] if self.sources else "")
            mom = self.moments.get(key)
            if mom is None:
                mom = self.moments[key] = ResidualMoments(self.n_b + 2, self.n_joints, row_period_s,
                                                          decimation, screws=screws)
            mom.fold(X, keep, np.asarray(t, float), q, qd)

    def fold_joint(self, j: int, rows: np.ndarray) -> None:
        """Fold joint j's equations ``rows: (r, n_b + 2)``, FOLD_ROWS at a time (bounded memory)."""
        for a in range(0, rows.shape[0], FOLD_ROWS):
            part = rows[a:a + FOLD_ROWS]
            self.rows[j] += part.shape[0]
            self.R[j] = qr_r(np.vstack([self.R[j], part]))

    def add_source(self, source: str) -> None:
        if source not in self.sources:
            self.sources.append(source)

    @classmethod
    def from_observations(cls, obs: Observations) -> RecordFactors:
        """The factors of one record's decimated equations."""
        n_j, _, n_b = obs.W.shape
        f = cls(obs.condition, float(obs.payload_mass), n_b, [obs.source], n_joints=n_j,
                observations=obs)
        f.n_samples = obs.n_samples
        for j in range(n_j):
            sel = slice(None) if obs.keep is None else obs.keep[j]
            f.fold_joint(j, np.column_stack([obs.W[j][sel], obs.w_m[j][sel], obs.v_tau[j][sel]]))
        if obs.t is not None:
            mom = f.moments[obs.source] = ResidualMoments(n_b + 2, n_j, obs.row_period_s,
                                                          obs.decimation, screws=obs.screws)
            for a in range(0, obs.n_samples, FOLD_ROWS):  # in pieces: bounded temporary memory
                b = min(a + FOLD_ROWS, obs.n_samples)
                Z = np.empty((n_j, b - a, n_b + 2))  # (n_j, r, n_c): one copy of the rows
                Z[:, :, :n_b] = obs.W[:, a:b]
                Z[:, :, n_b] = obs.w_m[:, a:b]
                Z[:, :, n_b + 1] = obs.v_tau[:, a:b]
                mom.fold_rows(Z, None if obs.keep is None else obs.keep[:, a:b], obs.t[a:b],
                              None if obs.q is None else obs.q[a:b],
                              None if obs.qd is None else obs.qd[a:b])
        return f

    def without_columns(self, cols: np.ndarray) -> RecordFactors:
        """These factors without the columns ``cols`` (the lag's, when a segment used has no
        instrument): R[:, keep]ᵀ R[:, keep] is the Gram of the columns left, exactly, whatever
        the dropped ones held; same rows, and the moments of the columns left."""
        keep = np.setdiff1d(np.arange(self.n_b + 2), cols)
        return RecordFactors(self.condition, self.payload_mass, self.n_b - len(cols),
                             list(self.sources),
                             [np.linalg.qr(R[:, keep], mode="r") for R in self.R],
                             self.rows.copy(), self.n_samples,
                             {k: m.without_columns(keep) for k, m in self.moments.items()})

    def only_joints(self, idx: np.ndarray) -> RecordFactors:
        """These factors with the equations of the joints ``idx`` only (a partial answer: the
        rows of a joint whose gain the data do not fix are left out with that gain)."""
        idx = np.asarray(idx, dtype=int)
        return RecordFactors(self.condition, self.payload_mass, self.n_b, list(self.sources),
                             [self.R[j] for j in idx], self.rows[idx].copy(), self.n_samples,
                             {k: m.only_joints(idx) for k, m in self.moments.items()},
                             n_joints=len(idx))

    def joint_r(self, j: int, T: np.ndarray) -> np.ndarray:
        """R_j·T: the triangular factor's rows mapped to another column layout (same Gram)."""
        return self.R[j] @ T


def as_factors(blocks: list) -> list[RecordFactors]:
    """Observations (one per record) or factors, as factors."""
    return [b if isinstance(b, RecordFactors) else RecordFactors.from_observations(b)
            for b in blocks]
