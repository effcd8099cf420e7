"""Cross-validation: model torque against g_τ·v_τ on a record not used for identification.

This is the paper's Fig. 5: τ = v_τ ĝ_τ (eq. 17) against τ_idm = IDM χ̂ (eq. 21) on a different
trajectory. Reported per joint: rms of the residual (N), rms of the measured force, their ratio,
and the ratio to the identification residual (the noise floor the model reached on its own data).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from orthoglide_ident.identify.observations import Observations


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

    def to_json(self, joint_names: tuple[str, ...]) -> dict:
        out = {
            "bag": self.source,
            "joints": [
                {"joint": j, "residual_rms": float(self.residual_rms[i]),
                 "measured_rms": float(self.measured_rms[i]),
                 "relative_error": float(self.relative_error[i]),
                 "noise_ratio": None if self.noise_ratio is None else float(self.noise_ratio[i])}
                for i, j in enumerate(joint_names)
            ],
            "warnings": list(self.warnings),
        }
        return out


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
    # figures over the rows the identification would use (not at unbridged velocity reversals)
    rms = np.array([np.sqrt(np.mean(res[j][keep[j]] ** 2)) for j in range(res.shape[0])])
    mrms = np.array([np.sqrt(np.mean(tau_meas[j][keep[j]] ** 2)) for j in range(res.shape[0])])
    rel = rms / np.where(mrms > 0, mrms, np.inf)
    ratio = None if identification_rms is None else rms / np.asarray(identification_rms)
    warns = []
    for i, j in enumerate(joint_names or [f"joint {k + 1}" for k in range(res.shape[0])]):
        if rel[i] > max_relative_error:
            warns.append(f"{block.source}: {j} model torque misses the measured force by "
                         f"{100 * rel[i]:.0f} % rms: poor excitation or an unmodelled effect")
        elif ratio is not None and ratio[i] > max_noise_ratio:
            warns.append(f"{block.source}: {j} validation residual is {ratio[i]:.1f}x the "
                         "identification residual: the model does not generalise well")
    t = block.t if block.t is not None else np.arange(block.n_samples, dtype=float)
    return ValidationResult(block.source, rms, mrms, rel, ratio, t, tau_meas, tau_model, warns)
