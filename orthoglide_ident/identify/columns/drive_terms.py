"""Terms of a real drive the paper's IDIM lacks, added to the model: a position-periodic force,
such as a ball screw's friction ripple at its lead (when the residual calls for it, or at a given
lead), and the current loop's lag (current_lag.py).

The IDIM has no term for a force that varies periodically with an actuator's position, yet a
ball-screw drive has one. Unmodelled, ±1.5 % of fs at a 10 mm lead moved a gain by ~0.5 % on
the simulated realistic drive. The residual says when it is there: its spectrum over position
(uncertainty.py) has a peak at the wavelength λ (uncertainty.spectrum_peaks). Joint j's
equations then get two columns, w cos(2π q_j/λ) and w sin(2π q_j/λ), w = sign(q̇_j) H (a
friction ripple, turning with the velocity) or H (a force ripple), H the decimation filter's gain
at the ripple's frequency in time (|q̇_j| / λ), whose amplitude and phase are identified with
everything else (TLS or WLS): no magnitude is assumed, the wavelength comes from the data.

The ripple found in a first solve's residual and its columns from the folded moments, the
augmented solve's σ and its split into ripples and lags: solve/drive_fit.py.

When the lead is known (``screw_lead_m``, a datasheet value), the column layout (layout.py) has
the columns sign(q̂̇_j) cos(2π q̂_j/λ), sign(q̂̇_j) sin(2π q̂_j/λ) at the sample rate, beside W, and
the decimation filters them with W (the paper's parallel filtering, eqs. 19-20, applied to the
drive term too) instead of weighting the decimated rows by H: no approximation where |q̇|/λ
nears the decimation's cut-off. Measured on a simulated drive whose only departure from the
IDIM is a ±1.5 % fs ripple at 10 mm (noise-free 30 s + 30 s): gain errors +0.11/+0.12/+0.07 %
without a ripple model, -0.03/+0.07/+0.01 % with the columns from the moments, +0.01/-0.02/
-0.02 % with these; README has the noisy figures over 20 seeds.

The current loop's lag is the other drive term in the equations (``lag_model: auto``): one
column per joint, the mean of v̇_τ over the record's other periods (current_lag.py), which the
stream carries beside v_τ and writes into the joint's own rows. (As a column of v_τ's backward
difference it took up friction errors at the velocity reversals instead — 0.3 ms found for a
0.12 ms lag, 0.05 ms on a drive without any; as the derivative filtered and decimated like v_τ,
in a mixed LS-TLS with its noise scaled to v_τ's, it finds 0.117-0.133 ms noise-free but
0.22-0.31 ms with 2 mA: the noise is in the applied current and the controller answers it
within a tick, so the zero-phase derivative of the reference correlates with the equation error.
The other periods' mean is free of the row's own noise.)
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass


@dataclass(frozen=True)
class RippleTerm:
    """Two columns of joint ``joint`` (its index): a ripple of wavelength ``wavelength_m``;
    ``index``
    is its wavelength in the residual's position spectrum (WAVELENGTHS_M) when the columns are
    built from the moments, None when they are in the equations (layout.ColumnLayout)."""

    joint: int
    wavelength_m: float
    friction: bool  # turns with the velocity (sign(q̇) weight) rather than a plain force
    index: int | None = None


@dataclass(frozen=True)
class Terms:
    """The drive terms of a model, in their column order: each joint's current-loop lag (one
    column per joint: ``lag`` is their number, n_j or 0; current_lag.py), then the ripple terms
    (two columns each, at most one per joint). A ripple whose ``index`` is None has its columns
    in the decimated equations (a given lead); the others are built from the moments
    (augmented_factors)."""

    ripples: tuple[RippleTerm, ...] = ()
    lag: int = 0

    @property
    def n_extra(self) -> int:
        return self.lag + 2 * len(self.ripples)

    def __bool__(self) -> bool:
        return self.n_extra > 0

    def names(self, joint_names: Sequence[str]) -> list[str]:
        lag = [f"lag_{j}" for j in joint_names] if self.lag else []
        return lag + [f"ripple_{c}_{joint_names[t.joint]}" for t in self.ripples
                      for c in ("c", "s")]


def screw_joints(model) -> list[int]:
    """The joints a screw's lead applies to: the prismatic ones (ball-screw drives)."""
    return [j for j, joint in enumerate(model.joints) if joint.kind == "prismatic"]


def screw_mask(model) -> tuple[bool, ...]:
    """Per joint, whether its position spectrum is looked at for a screw ripple."""
    return tuple(joint.kind == "prismatic" for joint in model.joints)
