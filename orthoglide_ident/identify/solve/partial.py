"""Partial answers: the drive gains the data fix, and why the others are not determined.

In W_tot (eq. 33) the scale of a joint's gain comes from the known payload's torque on that joint
(its rows of -W_kl χ_kl) and, through the base parameters its rows share with the other joints,
from theirs. A joint that hardly moves has no rows; a joint the payload adds (almost) no torque to
has rows its own parameters (friction, rotor inertia, its last body) fit at any scale together
with its gain: the TLS then returns a number with a small σ that is not the gain (a UR5 wrist
axis with a payload on it: 22 % off at 0.6 %σ). Such a joint's rows and gain are left out and
IDIM-TLS solves the rest (the base-parameter columns only those rows held go with them); the
answer is then judged on that subsystem as a full one is (eq. 37's separation, the condition,
the honest σ, the signs). A gain whose honest σ stays above ``max_gain_rel_std`` is left out the
same way, one at a time, the worst first, as long as another one is left.

Not determined, with the reason and what to record:
- its current chattered at its limit in a record (``at_limit``);
- the joint hardly moved: fewer equations above the velocity dead band than min_rows;
- the payload adds little torque on its axis: the rms payload torque of the loaded records below
  ``min_payload_share`` of the joint's measured torque;
- its honest σ is above ``max_gain_rel_std`` in the subsystem;
- the full set of gains is not separated (eq. 37: s_c/s_(c-1) above ``max_singular_ratio``, or
  the scaled regressor's condition too large): the largest subset of the gains whose subsystem
  is separated and passes every check above is answered (:func:`search_subsets`: every subset
  for up to ``EXACT_SEARCH_MAX`` free gains, largest first; beyond, the gain whose removal most
  lowers s_c/s_(c-1) dropped one at a time); each gain left out says what goes wrong with it
  added to the answered ones. A subset's σ is honest only if its gains stay within noise of
  two other consistent estimates of them (:func:`shift_beyond_noise`): the subset without one
  more gain, and the same rows unweighted. A smaller system amplifies what the model misses
  (e.g. positions printed to 1e-4 rad at ~90 Hz: UR10 subsets 3-5 σ off before this check).
"""
from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from itertools import combinations
from typing import Any

import numpy as np

from orthoglide_ident.identify.columns.drive_terms import Terms
from orthoglide_ident.identify.columns.layout import ColumnLayout
from orthoglide_ident.identify.solve.factors import RecordFactors

RANK_TOL = 1e-9  # column-scaled R: a diagonal below this times the largest is a lost column
EXACT_SEARCH_MAX = 7  # free gains up to which every subset is tried (at most 2^7 - 2 solves)
NESTED_Z = 3.0  # a gain's shift between nested answers, in σ of their difference, beyond noise


def hardly_moved(factors: list[RecordFactors], model, opts, min_rows: int) -> dict[int, str]:
    """Joints with fewer than ``min_rows`` equations above the velocity dead band."""
    total = sum(f.n_samples for f in factors)
    out = {}
    for j, joint in enumerate(model.joints):
        rows = sum(int(f.rows[j]) for f in factors)
        if rows < min_rows:
            out[j] = (f"{joint.name} hardly moved ({rows} of {total} equations above the "
                      "velocity dead band, "
                      f"{opts.observe.velocity_deadband_mps:g} {joint.unit}/s): "
                      "record more motion of that joint")
    return out


def payload_shares(factors: list[RecordFactors], g_tau: np.ndarray,
                   unknown: tuple[slice, np.ndarray] | None = None) -> np.ndarray:
    """Per joint, rms payload torque / rms measured torque g_τ v_τ over the loaded records
    (norms of the R factors' columns W_kl m_7 and v_τ: ‖R c‖ = ‖X c‖). ``unknown``: the columns
    of a payload known by its mass (Sect. 4.3) and their identified χ_ul, whose torque
    W_ul χ_ul is the payload's too (its CoM off an axis loads that joint)."""
    n_b = factors[0].n_b
    n_j = len(g_tau)
    pay, cur = np.zeros(n_j), np.zeros(n_j)
    for f in factors:
        if not f.loaded:
            continue
        for j in range(n_j):
            tau = f.payload_mass * f.R[j][:, n_b]
            if unknown is not None:
                tau = tau + f.R[j][:, unknown[0]] @ unknown[1]
            pay[j] += float(np.sum(tau ** 2))
            cur[j] += float(np.sum(f.R[j][:, n_b + 1] ** 2))
    return payload_share(pay, np.asarray(g_tau, float) ** 2 * cur)


def payload_share(payload_sq: np.ndarray, torque_sq: np.ndarray) -> np.ndarray:
    """Per joint, rms payload torque / rms joint torque over the same loaded rows, from their
    sums of squares Σ τ_payload² and Σ τ² (the identification's records, or a design's
    predicted loaded run: excite/design.py)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.sqrt(np.asarray(payload_sq, float)) / np.sqrt(np.asarray(torque_sq, float))


def payload_too_small(share: np.ndarray, min_share: float) -> np.ndarray:
    """The rule of ``min_payload_share``: the joints whose gain the payload does not scale
    (a share below it, or none: no loaded rows)."""
    return ~(np.asarray(share, float) >= min_share)


def at_limit(factors: list[RecordFactors], model) -> dict[int, str]:
    """Every joint, when a current chattered at its limit in some record
    (records/robot_checks.py): the dither smooths the Coulomb friction of the chattering joint
    and, through the mass matrix, of the others (a simulated UR10, shoulder and elbow chattering:
    their gains 4-7 σ off, wrist 2's 3.2 σ with their rows left out); the first reason."""
    out: dict[int, str] = {}
    for f in factors:
        for j, why in f.at_limit.items():
            out.setdefault(j, why)
    if out:
        names = ", ".join(model.joints[j].name for j in sorted(out))
        for j, joint in enumerate(model.joints):
            out.setdefault(j, f"{joint.name}'s velocity is dithered through the arm's coupling "
                              f"by the current of {names} chattering at its limit in a record: "
                              "its friction is outside the model too")
    return out


def little_payload(factors: list[RecordFactors], g_tau: np.ndarray, names: Sequence[str],
                   min_share: float, unknown: tuple[slice, np.ndarray] | None = None
                   ) -> dict[int, str]:
    """Joints the payload adds less than ``min_share`` of their torque to."""
    share = payload_shares(factors, g_tau, unknown)
    low = payload_too_small(share, min_share)
    return {j: (f"the payload adds almost no torque on that axis ({100 * share[j]:.2g} % of its "
                f"torque, below min_payload_share {100 * min_share:g} %): record with the "
                "payload offset from that axis (or heavier), so that it loads that joint")
            for j, name in enumerate(names) if low[j]}


def weak_gain(rel_std: np.ndarray, names: Sequence[str], limit: float) -> dict[int, str]:
    """The worst gain whose honest σ is above ``limit`` (one at a time: the rest re-solved)."""
    if not np.any(rel_std > limit):
        return {}
    j = int(np.argmax(np.where(np.isfinite(rel_std), rel_std, np.inf)))
    return {j: (f"its honest σ is {100 * rel_std[j]:.2g} % (> max_gain_rel_std "
                f"{100 * limit:g} %): the records do not separate its gain from its own "
                "parameters; record longer or more exciting motion of that joint")}


def lost_columns(factors: list[RecordFactors]) -> np.ndarray:
    """Base-parameter columns the kept rows no longer determine (pivoted QR of the stacked,
    column-scaled W factors): those only the left-out joints' rows held."""
    from scipy.linalg import qr

    n_b = factors[0].n_b
    R = np.vstack([f.R[j][:, :n_b] for f in factors for j in range(f.n_joints)])
    norms = np.linalg.norm(R, axis=0)
    scaled = R / np.where(norms > 0, norms, 1.0)
    _, r, piv = qr(scaled, mode="economic", pivoting=True)
    d = np.abs(np.diag(r))
    rank = int(np.sum(d > RANK_TOL * d[0])) if d.size and d[0] > 0 else 0
    lost = set(int(c) for c in piv[rank:]) | set(int(c) for c in np.flatnonzero(norms == 0))
    return np.array(sorted(lost), dtype=int)


@dataclass
class Subsystem:
    """The robot and its columns seen through the kept joints and columns: what tls_result and
    the solve read from a robot (joints, units, nominal gains) and from a column layout (names,
    expressions, drive terms; columns/layout.py). A payload's unknowns are not told apart."""

    full: Any  # the robot
    joint_idx: np.ndarray
    col_idx: np.ndarray
    columns: ColumnLayout  # the full problem's
    has_payload_unknowns = False

    def __post_init__(self) -> None:
        self.name = self.full.name
        self.joints = tuple(self.full.joints[j] for j in self.joint_idx)
        self.locked_joints = self.full.locked_joints
        self.names = [self.columns.names[c] for c in self.col_idx]
        exprs = self.columns.expressions
        self.expressions = [exprs[c] if c < len(exprs) else "" for c in self.col_idx]
        self.nominal_gains_given = self.full.nominal_gains_given
        s_a = self.full.motor_scale
        self.motor_scale = None if s_a is None else s_a[self.joint_idx]
        self.terms = self._lag_terms()

    def _lag_terms(self) -> Terms:
        """The current-loop lag columns the equations still hold, as drive terms (one per kept
        joint, last: the full model's layout without the left-out joints'); none otherwise
        (a ripple at a given lead stays a plain column)."""
        full = self.columns.terms
        if not full or full.ripples or not full.lag:
            return Terms()
        n_b = len(self.columns.names) - full.n_extra
        lag_cols = [c for c in self.col_idx.tolist() if c >= n_b]
        want = [n_b + int(j) for j in self.joint_idx]
        return Terms(lag=len(want)) if lag_cols == want else Terms()

    @property
    def joint_names(self) -> tuple[str, ...]:
        return tuple(j.name for j in self.joints)

    @property
    def n_joints(self) -> int:
        return len(self.joints)

    @property
    def nominal_gains(self) -> np.ndarray:
        return np.asarray(self.full.nominal_gains, float)[self.joint_idx]


def reduce(factors: list[RecordFactors], model, columns: ColumnLayout, left_out: dict[int, str]
           ) -> tuple[list[RecordFactors], Subsystem]:
    """The factors and subsystem of the joints not ``left_out``, without the columns they lose
    (``model`` the robot, ``columns`` its layout)."""
    kept = np.array([j for j in range(model.n_joints) if j not in left_out], dtype=int)
    fs = [f.only_joints(kept) for f in factors]
    lost = lost_columns(fs)
    if lost.size:
        fs = [f.without_columns(lost) for f in fs]
    cols = np.setdiff1d(np.arange(factors[0].n_b), lost)
    return fs, Subsystem(model, kept, cols, columns)


def expand(result, model, sub: Subsystem, left_out: dict[int, str]) -> None:
    """``result`` (of the subsystem) in place over every joint of ``model``: the gains left out
    "not determined" with their reason (value and σ NaN: null in the JSON), residuals likewise;
    the base parameters only their rows held named in a warning."""
    from orthoglide_ident.results import Estimate

    solved = dict(zip(sub.joint_idx.tolist(), zip(result.drive_gains, result.residual_rms)))
    gains, rms = [], []
    for j, joint in enumerate(model.joints):
        if j in solved:
            gains.append(solved[j][0])
            rms.append(solved[j][1])
        else:
            gains.append(Estimate(joint.name, float("nan"), float("nan"), rel_std_paper=None,
                                  determined=False, reason=left_out[j]))
            rms.append(float("nan"))
    result.joint_names = list(model.joint_names)
    result.drive_gains, result.residual_rms = gains, rms
    result.gain_units = [j.gain_unit for j in model.joints]
    result.effort_units = [j.effort_unit for j in model.joints]
    result.nominal_gains = [float(j.nominal_gain) for j in model.joints]
    result.warnings.insert(0, "partial answer: " + result.not_determined_text()
                           + "; the other gains are identified without their rows (not latched "
                           "for the ctc: it takes only a full answer)")
    lost = [n for c, n in enumerate(sub.columns.names) if c not in set(sub.col_idx.tolist())]
    if lost:
        result.warnings.insert(1, "base parameters not determined without those rows (not "
                               "reported): " + ", ".join(lost))


@dataclass(frozen=True)
class Trial:
    """One subset of the free gains solved on its own rows and judged as a full answer is:
    ``ratio`` s_c/s_(c-1) of its W_tot (eq. 37), ``failure`` why it is not an answer (None: an
    answer: separated, conditioned, loaded by the payload, honest σ within bounds, positive);
    ``gains`` and ``std`` (honest σ) by joint index."""

    kept: frozenset[int]
    ratio: float
    failure: str | None
    gains: dict[int, float] = field(default_factory=dict)
    std: dict[int, float] = field(default_factory=dict)
    advice: str = ("record more motion of that joint with the payload on, or a heavier "
                   "payload off its axis")  # what would fix it (search_reasons)


def shift_beyond_noise(t: Trial, other: Trial) -> tuple[int, float] | None:
    """The first gain of both ``t`` and ``other`` (another consistent estimate of the same
    gains, less precise: fewer rows, or other row weights) that moves by more than NESTED_Z
    times what noise explains, and its shift in σ of ``t``. If the model fits, both estimates
    are consistent and their difference has the variance σ_other² - σ_t² (Hausman 1978), taken
    at least σ_t²; a larger shift is a bias that ``t``'s σ does not cover."""
    for i in sorted(t.kept & other.kept):
        sd = max(np.sqrt(max(other.std[i] ** 2 - t.std[i] ** 2, 0.0)), t.std[i])
        shift = abs(t.gains[i] - other.gains[i])
        if not shift <= NESTED_Z * sd:
            return i, shift / t.std[i]
    return None


def nested_shift(t: Trial, smaller: Trial, names: Sequence[str]) -> str | None:
    """Why ``t`` is not honest beside ``smaller`` (its subset without one gain, an answer too):
    a gain moves beyond noise (:func:`shift_beyond_noise`): the left-out gain's rows bias it."""
    moved = shift_beyond_noise(t, smaller)
    if moved is None:
        return None
    (j,) = t.kept - smaller.kept
    i, z = moved
    return (f"{names[i]}'s gain moves by {z:.1f} of its σ when {names[j]} is left out (beyond "
            f"what noise explains, > {NESTED_Z:g}): {names[j]}'s rows bias it")


def search_subsets(free: Sequence[int], trial: Callable[[frozenset[int]], Trial],
                   names: Sequence[str], exact_max: int = EXACT_SEARCH_MAX,
                   progress: Callable[..., None] | None = None) -> tuple[Trial | None, dict]:
    """The largest subset of ``free`` (the full set already failed) whose trial is an answer
    and honest beside its own subsets (:func:`nested_shift`), the least s_c/s_(c-1) among
    those of that size; None if no subset is. Every subset, largest first, up to ``exact_max``
    free gains; beyond, greedy: the gain whose removal lowers s_c/s_(c-1) most is dropped, one
    at a time. Also returns every trial made, by subset. ``progress`` hears the trials made of
    the most the search may make (it stops at the first answer)."""
    tried: dict[frozenset[int], Trial] = {}
    n = len(free)
    most = 2 ** n - 2 if n <= exact_max else n * (n + 1) // 2  # every proper subset; greedy

    def run(kept: frozenset[int]) -> Trial:
        if kept not in tried:
            tried[kept] = trial(kept)
            if progress is not None:
                progress("searching the gains the data fix", len(tried), max(most, len(tried)),
                         "subsets")
        return tried[kept]

    def answer(trials: list[Trial]) -> Trial | None:
        for t in sorted((t for t in trials if not t.failure), key=lambda t: t.ratio):
            for j in sorted(t.kept) if len(t.kept) > 1 else ():
                smaller = run(t.kept - {j})
                why = None if smaller.failure else nested_shift(t, smaller, names)
                if why:
                    tried[t.kept] = t = dataclasses.replace(t, failure=why)
                    break
            if not t.failure:
                return t
        return None

    free = [int(j) for j in free]
    if len(free) <= exact_max:
        for k in range(len(free) - 1, 0, -1):
            best = answer([run(frozenset(c)) for c in combinations(free, k)])
            if best:
                return best, tried
        return None, tried
    current = frozenset(free)
    while len(current) > 1:
        trials = [run(current - {j}) for j in current]
        best = answer(trials)
        if best:
            return best, tried
        current = min(trials, key=lambda t: t.ratio).kept
    return None, tried


def search_reasons(best: Trial, free: Sequence[int], trial: Callable[[frozenset[int]], Trial],
                   tried: dict, names: Sequence[str]) -> dict[int, str]:
    """Each free gain the answer ``best`` leaves out, with what goes wrong when it is added to
    the answered ones (that subset's trial)."""
    out = {}
    for j in sorted(set(free) - best.kept):
        with_j = tried.get(best.kept | {j}) or trial(best.kept | {j})
        out[j] = (f"{names[j]} not fixed beside the determined gains: with it, "
                  f"{with_j.failure} (without it s_c/s_c-1 = {best.ratio:.2f}); "
                  f"{with_j.advice}")
    return out
