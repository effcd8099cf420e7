"""The drive gains ± σ as the records get longer: how an identification converged.

At each step of ``step_s`` seconds, IDIM-TLS (eqs. 33-39, identify/tls.py) is solved on the
decimated equations of the first ``τ`` seconds of every record (the unloaded and the loaded ones
together: TLS needs both), τ = step, 2 step, ... up to the longest record. The curve answers "how
long must I record?": with records of τ seconds each the gains would have been these, ± σ. Each
record's equations are folded into its R factors once, in time order (identify/factors.py), so a
step costs one small solve, not a new factorisation. A step whose solution the excitation checks
refuse (too few equations, the gains not yet standing out; identify/tls.check_excitation) has no
point.

The last point is IDIM-TLS on all the equations of the identification's model (base parameters
and the drive terms already in its rows); a ripple found in the residual and added afterwards
(identify/drive_terms.py) is not in these rows, so the result's gains may differ from it by a
fraction of their σ.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from orthoglide_ident.errors import OrthoglideError
from orthoglide_ident.identify.observe.equations import Observations
from orthoglide_ident.identify.solve.factors import RecordFactors
from orthoglide_ident.identify.solve.tls import ExcitationLimits, check_excitation, idim_tls

MAX_POINTS = 60  # steps at most (longer records: longer steps; each costs a solve)


@dataclass
class GainPoint:
    """IDIM-TLS on the first ``seconds`` of every record (``unloaded_seconds`` and
    ``loaded_seconds`` of data in all): gains (n,) N/A, rel_std (n,) fractions."""

    seconds: float
    unloaded_seconds: float
    loaded_seconds: float
    gains: np.ndarray
    rel_std: np.ndarray


def record_seconds(obs: Observations) -> float:
    """Duration of a record's decimated rows, s (from its first state instant)."""
    if obs.t is None or not len(obs.t):
        return 0.0
    return float(obs.t[-1]) + float(obs.row_period_s or 0.0)


def _rows(obs: Observations, sel: np.ndarray) -> np.ndarray:
    """[W | W_kl | v_τ] of the selected rows: (n_b + 2, n_joints, r)."""
    return np.concatenate(
        [obs.W[:, sel].transpose(2, 0, 1), obs.w_m[None, :, sel], obs.v_tau[None, :, sel]]
    )


def _fold_upto(f: RecordFactors, obs: Observations, done: int, tau: float) -> int:
    """Fold the rows of ``obs`` from ``done`` up to the instant ``tau`` s; the new ``done``."""
    t = obs.t if obs.t is not None else np.zeros(obs.n_samples)
    upto = int(np.searchsorted(t, tau, side="right"))
    if upto > done:
        sel = np.arange(done, upto)
        f.fold(_rows(obs, sel), None if obs.keep is None else obs.keep[:, sel], t[sel], obs.source,
               obs.row_period_s, None if obs.q is None else obs.q[sel],
               None if obs.qd is None else obs.qd[sel], obs.decimation, obs.screws)
    return max(upto, done)


def gain_convergence(observations: list[Observations], step_s: float = 0.5, weighting: bool = True,
                     noisy_columns: str = "all", limits: ExcitationLimits | None = None,
                     joint_names: Sequence[str] = ()) -> list[GainPoint]:
    """The gains with the first τ s of every record, every ``step_s`` (see the module doc);
    ``weighting``, ``noisy_columns`` and ``limits`` as the identification's options
    (``weighting``, ``tls_noisy_columns``, the excitation limits: ``SolveOptions.limits``
    of the robot's nominal gains)."""
    limits = limits or ExcitationLimits()
    names = tuple(joint_names) or tuple(f"joint {k + 1}" for k in
                                        range(observations[0].W.shape[0] if observations else 0))
    durations = [record_seconds(o) for o in observations]
    longest = max(durations, default=0.0)
    step = max(step_s, longest / MAX_POINTS)
    factors = [RecordFactors(o.condition, float(o.payload_mass), o.W.shape[2], [o.source],
                             n_joints=o.W.shape[0]) for o in observations]
    done = [0] * len(observations)  # rows folded per record
    points: list[GainPoint] = []
    for tau in np.append(np.arange(step, longest - 1e-9, step), longest):
        for i, obs in enumerate(observations):
            done[i] = _fold_upto(factors[i], obs, done[i], tau)
        seconds = {c: sum(min(tau, d) for o, d in zip(observations, durations) if o.condition == c)
                   for c in ("unloaded", "loaded")}
        point = _solve([f for f in factors if f.n_rows], weighting, noisy_columns, limits, names)
        if point is not None:
            points.append(GainPoint(float(tau), seconds["unloaded"], seconds["loaded"], *point))
    return points


def _solve(
    factors: list[RecordFactors],
    weighting: bool,
    noisy_columns: str,
    limits: ExcitationLimits,
    joint_names: tuple[str, ...],
) -> tuple[np.ndarray, np.ndarray] | None:
    try:
        sol = idim_tls(factors, weighting, noisy_columns=noisy_columns)
        check_excitation(sol, limits, None, joint_names)
    except (OrthoglideError, np.linalg.LinAlgError):
        return None  # not solvable yet, or not the gains yet: no point
    n = sol.chi.shape[0]
    return sol.g_tau.copy(), np.asarray(sol.rel_std[n:n + sol.g_tau.shape[0]], float)
