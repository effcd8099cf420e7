"""Cross-validation: model torque against g_τ·v_τ on a record not used for identification.

This is the paper's Fig. 5: τ = v_τ ĝ_τ (eq. 17) against τ_idm = IDM χ̂ (eq. 21) on a different
trajectory. Reported per joint: rms of the residual (N), rms of the measured force, their ratio,
and the ratio to the identification residual (the noise floor the model reached on its own data).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from orthoglide_ident.identify.observe.equations import Observations
from orthoglide_ident.results import ValidationJoint, ValidationRow

MIN_ROWS = 20  # decimated samples of a joint above the velocity dead band worth a figure


def _num(x: float) -> float | None:
    x = float(x)
    return x if np.isfinite(x) else None


@dataclass
class ValidationResult:
    """Per-joint figures of one validation record; forces in N or N·m, ``tau_*: (n_j, r)``."""

    source: str
    residual_rms: np.ndarray
    measured_rms: np.ndarray
    relative_error: np.ndarray
    noise_ratio: np.ndarray | None
    t: np.ndarray
    tau_measured: np.ndarray
    tau_model: np.ndarray
    warnings: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)  # per joint: why it has no figure ("" if it has)

    def row(self, joint_names: tuple[str, ...]) -> ValidationRow:
        """The result's row of this record (results.ValidationRow, the JSON's ``validation``)."""
        return ValidationRow(self.source, tuple(
            ValidationJoint(j, _num(self.residual_rms[i]), _num(self.measured_rms[i]),
                            _num(self.relative_error[i]),
                            None if self.noise_ratio is None else _num(self.noise_ratio[i]),
                            self.notes[i] if self.notes else "")
            for i, j in enumerate(joint_names)), tuple(self.warnings))


def cross_validate(
    block: Observations, chi: np.ndarray, g_tau: np.ndarray, payload_mass: float = 0.0,
    identification_rms: np.ndarray | None = None, max_relative_error: float = 0.2,
    max_noise_ratio: float = 1.5, joint_names: tuple[str, ...] = (),
) -> ValidationResult:
    """Compare τ_idm = W χ (+ W_kl m_7) with g_τ v_τ on ``block``; ``chi`` over all n_b."""
    tau_model = np.einsum("jrn,n->jr", block.W, chi)
    if block.loaded:
        tau_model = tau_model + block.w_m * payload_mass
    tau_meas = block.v_tau * np.asarray(g_tau, dtype=float)[:, None]
    res = tau_meas - tau_model
    keep = block.keep if block.keep is not None else np.ones(res.shape, dtype=bool)
    # figures over the rows the identification would use (not at unbridged velocity reversals);
    # none for a joint that hardly moves or whose gain is not determined (NaN): said in notes
    n_j = res.shape[0]
    names = joint_names or [f"joint {k + 1}" for k in range(n_j)]
    g = np.asarray(g_tau, dtype=float)
    counts = keep.sum(axis=1)
    notes = ["its drive gain is not determined: no measured torque to compare with"
             if not np.isfinite(g[i]) else
             f"hardly moves in this record ({counts[i]} of {keep.shape[1]} samples above the "
             "velocity dead band): nothing to validate on" if counts[i] < MIN_ROWS else ""
             for i in range(n_j)]
    with np.errstate(invalid="ignore", divide="ignore"):
        rms = np.array([np.sqrt(np.mean(res[j][keep[j]] ** 2)) if not notes[j] else np.nan
                        for j in range(n_j)])
        mrms = np.array([np.sqrt(np.mean(tau_meas[j][keep[j]] ** 2)) if not notes[j] else np.nan
                         for j in range(n_j)])
        rel = rms / np.where(mrms > 0, mrms, np.inf)
        ratio = None if identification_rms is None else rms / np.asarray(identification_rms)
    warns = [f"{block.source}: {j} {notes[i]}" for i, j in enumerate(names) if notes[i]]
    for i, j in enumerate(names):
        if notes[i]:
            continue
        if rel[i] > max_relative_error:
            warns.append(f"{block.source}: {j} model torque misses the measured force by "
                         f"{100 * rel[i]:.0f} % rms: poor excitation or an unmodelled effect")
        elif ratio is not None and ratio[i] > max_noise_ratio:
            warns.append(f"{block.source}: {j} validation residual is {ratio[i]:.1f}x the "
                         "identification residual: the model does not generalise well")
    t = block.t if block.t is not None else np.arange(block.n_samples, dtype=float)
    return ValidationResult(block.source, rms, mrms, rel, ratio, t, tau_meas, tau_model, warns,
                            notes)
