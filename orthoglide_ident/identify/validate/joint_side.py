"""The residual seen from the joints when a transmission sits between them and the motors.

The equations are written per motor (τ_m = N⁻ᵀ τ_j, model/actuator_space.py), so the solve's
residual ε is motor-side. A joint's force is τ_j = Nᵀ τ_m: its residual is (Nᵀ ε)_j, sample by
sample over the samples every motor keeps (DESIGN §10: ``residual_rms_per_joint`` joint-side,
``residual_rms_per_actuator`` motor-side beside it).
"""
from __future__ import annotations

import numpy as np

from orthoglide_ident.identify.observe.equations import Observations


def motor_residuals(block: Observations, chi: np.ndarray, g_tau: np.ndarray,
                    payload_mass: float) -> np.ndarray:
    """ε (n_a, r) = g_τ v_τ − (W χ + W_kl m) of one record, N·m or N, motor by motor."""
    model = np.einsum("jrn,n->jr", block.W, chi)
    if block.loaded:
        model = model + block.w_m * payload_mass
    return block.v_tau * np.asarray(g_tau, float)[:, None] - model


def joint_side_rms(blocks: list[Observations], chi: np.ndarray, g_tau: np.ndarray,
                   masses: list[float], N: np.ndarray) -> tuple[list[float], list[float]]:
    """(joint-side rms of Nᵀ ε per joint, motor-side rms of ε per motor) over the samples every
    motor keeps, all records together; ``masses``: each record's payload mass (kg)."""
    eps = []
    for b, m in zip(blocks, masses):
        e = motor_residuals(b, chi, g_tau, m)
        keep = np.ones(e.shape[1], bool) if b.keep is None else np.all(b.keep, axis=0)
        eps.append(e[:, keep])
    e = np.concatenate(eps, axis=1)
    if not e.shape[1]:
        nan = [float("nan")] * e.shape[0]
        return nan, nan
    N = np.asarray(N, float)
    lost = ~np.all(np.isfinite(e), axis=1)  # a motor whose gain is not determined
    joint = N.T @ np.where(lost[:, None], 0.0, e)  # τ_j = Nᵀ τ_m, sample by sample
    joint[(N[lost] != 0).any(axis=0)] = np.nan  # the joints such a motor drives
    return ([float(x) for x in np.sqrt(np.mean(joint ** 2, axis=1))],
            [float(x) for x in np.sqrt(np.mean(e ** 2, axis=1))])


# A motor whose residual is this many times what its current's noise leaves after the
# decimation filter: the model misses a force there (behind a transmission: most often a row of
# the reduction typed wrong, issue 43: [0,0,0,0,0,32] for [0,0,0,0,32,32] gave wrist_2 -10.7 %
# at a stated 3.3 %). The right drive chain: about 1x on the inverse-model records of the tests.
MISFIT = 10.0
LONGER = "; record longer or more exciting motion of that joint"  # partial.weak_gain's advice


def current_noise(v_tau: np.ndarray, stamps_ns: np.ndarray) -> tuple[np.ndarray, float]:
    """(σ of each current column's white noise, A, from its second differences; the rate, Hz).
    A smooth current's second difference at the log rate is its noise's (variance 6 σ²)."""
    d2 = np.diff(np.asarray(v_tau, float), 2, axis=0)
    with np.errstate(invalid="ignore"):
        sigma = np.sqrt(np.nanmean(d2 ** 2, axis=0) / 6.0) if d2.shape[0] else \
            np.full(v_tau.shape[1], np.nan)
    steps = np.diff(np.asarray(stamps_ns, np.int64))
    return sigma, (1e9 / float(np.median(steps)) if steps.size else float("nan"))


def misfit(residual_rms: list[float], g_tau: np.ndarray, noise_a: np.ndarray, rate_hz: float,
           cutoff_hz: float) -> np.ndarray:
    """Per motor, its equations' residual rms over what its white current noise leaves after
    the decimation filter (the variance share 2 f_c / f_s of an ideal low-pass at f_c)."""
    floor = np.abs(np.asarray(g_tau, float)) * noise_a * np.sqrt(2.0 * cutoff_hz / rate_hz)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.asarray(residual_rms, float) / floor


def misfit_lines(ratio: np.ndarray, names: list[str]) -> tuple[list[str], str]:
    """The warning per motor fitted far worse than its noise, and the advice that replaces
    "record longer" in the reasons of gains left undetermined (empty when none)."""
    bad = [k for k, r in enumerate(ratio) if np.isfinite(r) and r > MISFIT]
    lines = [f"the residual of {names[k]} is {ratio[k]:.3g} times what its current's noise "
             f"leaves (> {MISFIT:g}): the model misses a force on that motor; check its row and "
             "column of the transmission's reduction (a coupling typed wrong or left out) "
             "before recording more" for k in bad]
    worst = ", ".join(f"{names[k]} ({ratio[k]:.3g}x)" for k in bad)
    advice = (f"; the fit is far worse than the current noise on {worst}: check the "
              "transmission's reduction, not the motion") if bad else ""
    return lines, advice
