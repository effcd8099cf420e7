"""IDIM-TLS: drive gains and base parameters at once, scaled by a known payload mass (Sect. 4).

    W_tot χ_tot = [ -W_a   V_τa    0      0          ] [ χ    ]
                  [ -W_b   V_τb  -W_ul  -W_kl χ_kl   ] [ g_τ  ] = ρ                    eq. (33)
                                                       [ χ_ul ]
                                                       [ 1    ]

Several loaded records may be stacked, each with its own weighed mass: the last column then holds
-W_kl·m_7 of each. χ_ul is empty for the Orthoglide (only m_7 acts on a translating platform).
The solution is the right singular vector of the smallest singular value (eqs. 35-36), scaled so
that its last component is 1. Eq. (34)'s closest compatible system is the errors-in-variables
answer only when the columns carry equal noise: by default (``noisy_columns="per-joint"``) W and
W_kl are taken as exact and each current column is scaled to its joint's noise (issue 43). Rows of
joint j are weighted by 1/σ_j (Sect. 4.2), σ_j from a first
unweighted solution. Standard deviations by eqs. (37)-(39) (``rel_std_paper``) and the honest
ones that also cover correlated residuals (``rel_std``, uncertainty.py).

Non-excitation is detected, not returned as numbers: with gentle trajectories the smallest
singular vector of W_tot is a near-null direction of the regressor, not the gains
(:func:`check_excitation`).
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from orthoglide_ident.errors import ExcitationError, IdentificationError
from orthoglide_ident.identify.observe.equations import Observations
from orthoglide_ident.identify.options import ExcitationLimits
from orthoglide_ident.identify.solve.factors import RecordFactors, as_factors
from orthoglide_ident.identify.solve.uncertainty import Uncertainty, evaluate


@dataclass
class TLSSolution:
    """Result of one IDIM-TLS solve over the active base parameters.

    ``chi (n,)`` active base parameters, ``g_tau (n_j,)`` N/A or N·m/A; ``cov`` over ``[chi,
    g_tau]``: the
    honest covariance (uncertainty.py: the largest of eq. 39, the stationary-correlation and the
    block sandwich), ``cov_paper`` that of eq. (39); ``rel_std`` = σ/|value| as a fraction (honest),
    ``rel_std_paper`` the paper's; residuals in N.
    """

    active: np.ndarray  # (n_b,) bool
    chi: np.ndarray
    g_tau: np.ndarray
    cov: np.ndarray
    std: np.ndarray
    rel_std: np.ndarray
    sigma_w: float  # eq. (38), weighted units
    singular_values: np.ndarray  # of weighted W_tot, decreasing
    joint_sigma: np.ndarray  # (n_j,) σ_j used as row weights, N or N·m
    residual_rms: np.ndarray  # (n_j,) rms of ρ per joint, N or N·m
    condition_number: float  # column-scaled regressor (weighted rows)
    n_rows: int
    n_cols: int
    lambda_scale: float  # eq. (36) scale 1/χ^n_c
    cov_paper: np.ndarray | None = None  # eq. (39)
    rel_std_paper: np.ndarray | None = None
    uncertainty: Uncertainty | None = None
    rows_per_joint: np.ndarray | None = None  # (n_j,) equations

    @property
    def singular_ratio(self) -> float:
        s = self.singular_values
        return float(s[-1] / s[-2]) if s.size > 1 and s[-2] > 0 else 0.0

    def chi_full(self) -> np.ndarray:
        """All n_b base parameters, zero where inactive (removed as non-essential)."""
        out = np.zeros(self.active.shape[0])
        out[self.active] = self.chi
        return out


def require_loaded_and_unloaded(blocks: list[Observations | RecordFactors], what: str) -> None:
    """TLS needs a known payload (scale) and an unloaded record (m_7 apart from the platform)."""
    n_loaded = sum(b.loaded for b in blocks)
    if n_loaded == 0:
        raise IdentificationError(
            f"{what} needs at least one bag recorded with the weighed payload (condition loaded) "
            "to fix the scale of the drive gains; only unloaded bags were given"
        )
    if n_loaded == len(blocks):
        raise IdentificationError(
            f"{what} needs at least one unloaded bag: with the payload always on, its mass "
            "cannot be told apart from the mass of the link that carries it"
        )
    for b in blocks:
        if b.loaded and not b.payload_mass > 0:
            raise IdentificationError(
                f"bag {b.source} is loaded but its payload mass is {b.payload_mass} kg; "
                "give the weighed mass with --payload-mass"
            )


def tls_columns(b: RecordFactors, j: int) -> np.ndarray:
    """T with [W | W_kl | v_τ]·T = joint j's rows of W_tot (eq. 33): (n_b + 2, n_b + n_j + 1)."""
    n_b = b.n_b
    T = np.zeros((n_b + 2, n_b + b.n_joints + 1))
    T[np.arange(n_b), np.arange(n_b)] = -1.0  # -W
    T[n_b + 1, n_b + j] = 1.0  # v_τ in the column of g_τ,j
    if b.loaded:
        T[n_b, -1] = -b.payload_mass  # -W_kl χ_kl with χ_kl = m_7
    return T


NOISY_COLUMNS = ("all", "currents", "per-joint")  # which columns of W_tot carry errors
# gains and σ_j re-estimated for the current columns' noise scaling until the gains move less
PER_JOINT_MAX_ITERATIONS = 50
PER_JOINT_TOLERANCE = 1e-13


class TLSProblem:
    """W_tot of eq. (33) held as one R factor per joint (W_tot^j = Q_j R_j).

    Row weighting per joint only scales R_j, residual norms per joint are ‖R_j χ‖, and removing
    columns of W_tot is removing the same columns of R: every solve after the three QR
    factorisations (one per joint) works on small (c × c) matrices. The singular values and right
    singular vectors of W_tot[:, cols] are those of the stacked R_j[:, cols].
    """

    def __init__(self, blocks: list[Observations | RecordFactors], weighting: bool = True,
                 noisy_columns: str = "all", row_scale: np.ndarray | None = None,
                 column_scale: np.ndarray | None = None):
        """``row_scale`` (n_j,): the first pass's row weights (None: 1, the paper's);
        ``column_scale`` (n_b + n_j + 1,) C: the SVD is taken of W_tot C and the answer given
        back in W_tot's units (None: C = I). Both put a motor's equations in joint-side units
        (joint_units.py). ``noisy_columns``: "all" (the paper's), "currents" (mixed LS-TLS) or
        "per-joint" (mixed LS-TLS, each current column scaled by its noise: see
        :meth:`_equal_current_noise`)."""
        if noisy_columns not in NOISY_COLUMNS:
            raise IdentificationError(
                f"noisy_columns must be one of {', '.join(NOISY_COLUMNS)}, not {noisy_columns!r}")
        self.per_joint = noisy_columns == "per-joint"
        noisy_columns = "currents" if self.per_joint else noisy_columns
        self.noisy_columns = noisy_columns
        self.blocks = as_factors(blocks)
        self.n_joints = n_joints = self.blocks[0].n_joints
        self.n_b = self.blocks[0].n_b
        self.scale = np.ones(self.n_b + n_joints + 1) if column_scale is None \
            else np.asarray(column_scale, float)
        self.first_sigma = np.ones(n_joints) if row_scale is None \
            else 1.0 / np.asarray(row_scale, float)
        self.R_plain: list[np.ndarray] = []  # of W_tot
        self.rows_joint = np.zeros(n_joints, dtype=int)
        for j in range(n_joints):
            # R of joint j's rows of W_tot from each record's R of [W | W_kl | v_τ]
            Rs = [b.joint_r(j, tls_columns(b, j)) for b in self.blocks]
            self.rows_joint[j] = sum(int(b.rows[j]) for b in self.blocks)
            self.R_plain.append(np.linalg.qr(np.vstack(Rs), mode="r"))
            if self.rows_joint[j] == 0:
                raise ExcitationError(f"no equation left for joint {j + 1}: record longer or "
                                      "more exciting trajectories")
        self.n_rows = int(self.rows_joint.sum())
        self.weighting = weighting
        self.first_scale = self.scale.copy()
        self._set_scale(self.scale)

    def _set_scale(self, scale: np.ndarray) -> None:
        """Column scale C of W_tot C (R_joint: the R factors of W_tot C), weights as before."""
        self.scale = np.asarray(scale, float)
        self.R_joint = [R * self.scale for R in self.R_plain]
        self._set_weights(getattr(self, "joint_sigma", self.first_sigma))

    def _set_weights(self, sigma: np.ndarray) -> None:
        self.joint_sigma = np.asarray(sigma, dtype=float)
        self.R = np.linalg.qr(np.vstack([R / s for R, s in zip(self.R_joint, self.joint_sigma)]),
                              mode="r")

    def columns(self, active: np.ndarray) -> np.ndarray:
        return np.concatenate([np.flatnonzero(active), self.n_b + np.arange(self.n_joints + 1)])

    def joint_rms(self, chi_tot_full: np.ndarray, n_params: int) -> tuple[np.ndarray, np.ndarray]:
        """Per joint, rms of ρ_j = W_tot^j χ_tot (N) and the unbiased σ_j (dof shared by rows)."""
        rms = np.empty(self.n_joints)
        sig = np.empty(self.n_joints)
        for j in range(self.n_joints):
            ss = float(np.sum((self.R_joint[j] @ chi_tot_full) ** 2))  # ‖ρ_j‖² = ‖R_j χ‖²
            n = self.rows_joint[j]
            rms[j] = np.sqrt(ss / n)
            dof = n - n_params * n / self.n_rows
            sig[j] = np.sqrt(ss / max(dof, 1.0))
        return rms, sig

    def solve(self, active: np.ndarray | None = None, reweight: bool | None = None) -> TLSSolution:
        """IDIM-TLS over the ``active`` base parameters (all by default), eqs. (33)-(39)."""
        if active is None:
            active = np.ones(self.n_b, dtype=bool)
        active = np.asarray(active, dtype=bool)
        reweight = self.weighting if reweight is None else reweight
        if reweight:
            if self.per_joint:
                self._set_scale(self.first_scale)
            self._set_weights(self.first_sigma)
            first = self._solve_weighted(active)
            _, sig = self.joint_rms(self._full(first, active), first.shape[0] - 1)
            if np.all(sig > 0):
                self._set_weights(sig)
            if self.per_joint:
                self._equal_current_noise(active)
        return self._finish(active)

    def _equal_current_noise(self, active: np.ndarray) -> None:
        """The current columns scaled to equal noise (eq. 34's closest compatible system is
        then the errors-in-variables answer): joint j's residual ρ_j = g_j e_j is its current
        noise, so once its rows are weighted by 1/σ_j its current column carries noise σ_j /
        (g_j σ_j) = 1/g_j; scaled by |g_j| every current column carries the same. Without it a
        small distal gain's column is the noisiest and the mixed LS-TLS biases it low (issue
        43: -0.45 % at 5 σ, Panda joint 7, 1 % current noise). g_j and σ_j iterated together."""
        n = int(np.count_nonzero(active))
        gains = slice(self.n_b, self.n_b + self.n_joints)
        last = None
        for _ in range(PER_JOINT_MAX_ITERATIONS):
            chi_c = self._solve_weighted(active)  # of W_tot C
            _, sig = self.joint_rms(self._full(chi_c, active), chi_c.shape[0] - 1)
            g = np.abs(chi_c * self.scale[self.columns(active)])[n:n + self.n_joints]
            if not np.all(np.isfinite(g)) or not np.all(g > 0) or not np.all(sig > 0):
                return  # no gain direction: the checks say so on the answer
            scale = self.scale.copy()
            scale[gains] = g / np.exp(np.mean(np.log(g)))  # W_tot's own units: any reduction
            self._set_weights(sig)
            self._set_scale(scale)
            if last is not None and np.max(np.abs(g / last - 1.0)) < PER_JOINT_TOLERANCE:
                return  # a fixed point: the same answer whatever the units of the columns
            last = g

    def _full(self, chi_tot: np.ndarray, active: np.ndarray) -> np.ndarray:
        full = np.zeros(self.n_b + self.n_joints + 1)
        full[self.columns(active)] = chi_tot
        return full

    def _solve_weighted(self, active: np.ndarray) -> np.ndarray:
        A = self.R[:, self.columns(active)]
        if self.noisy_columns == "currents":
            return self._direction_currents(A, int(np.count_nonzero(active)))[0]
        return self._direction_all(A)[0]

    def _direction_all(self, A: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
        """Paper's TLS (eqs. 35-39): every column of W_tot may carry errors.

        Returns χ_tot (last component 1), the singular values, Ŵ_totᵀŴ_tot and σ_ρ² (row
        variance of the equation error, = σ_W² (1 + ‖χ̂‖²) of eq. 39).
        """
        _, s, vt = np.linalg.svd(A, full_matrices=False)  # eq. (35)
        v_c = vt[-1]
        if abs(v_c[-1]) < 1e-300:
            raise ExcitationError(
                "the smallest singular vector of W_tot has no payload component: the loaded "
                "records do not excite the payload mass"
            )
        chi_tot = v_c / v_c[-1]  # λ = 1 / χ^n_c
        c = A.shape[1]
        sigma_w2 = s[-1] ** 2 / (self.n_rows - c)  # eq. (38)
        # Ŵ_tot = W_tot - s_c U_c V_cᵀ (eq. 36) ⇒ Ŵ_totᵀ Ŵ_tot = V diag(s², 0) Vᵀ
        s2 = s * s
        s2[-1] = 0.0
        G = (vt.T * s2) @ vt
        x = chi_tot[:-1]
        return chi_tot, s, G, sigma_w2 * (1.0 + x @ x)

    def _direction_currents(self, A: np.ndarray, n: int
                            ) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
        """Mixed LS-TLS: only the current columns V_τ carry errors, W and W_kl are exact.

        Columns ordered [exact | V_τ] and triangularised: the gains are the smallest right
        singular vector of the V_τ block R22 (what of V_τ the exact columns cannot explain), the
        base parameters follow by back-substitution, scaled so that the payload component is 1.
        The corrected matrix is Ŵ_tot = W_tot - ρ dᵀ with d = [0, g, 0]/‖g‖² (V_τ columns only).
        """
        c = A.shape[1]
        nj = self.n_joints
        exact = np.concatenate([np.arange(n), [c - 1]])
        noisy = np.arange(n, n + nj)
        Rp = np.linalg.qr(A[:, np.concatenate([exact, noisy])], mode="r")
        ne = exact.shape[0]
        R11, R12, R22 = Rp[:ne, :ne], Rp[:ne, ne:], Rp[ne:, ne:]
        _, s22, vt22 = np.linalg.svd(R22)
        g_dir = vt22[-1]
        try:
            x1 = -np.linalg.solve(R11, R12 @ g_dir)
        except np.linalg.LinAlgError as exc:
            raise ExcitationError(
                "the observation matrix is singular: some base parameter has no effect on the "
                "recorded forces"
            ) from exc
        if abs(x1[-1]) < 1e-300:
            raise ExcitationError(
                "the drive gains have no payload component: the loaded records do not excite "
                "the payload mass"
            )
        chi_tot = np.empty(c)
        chi_tot[:n] = x1[:-1] / x1[-1]
        chi_tot[n:n + nj] = g_dir / x1[-1]
        chi_tot[-1] = 1.0
        rho = A @ chi_tot  # ‖ρ‖ in R-space equals ‖W_tot χ_tot‖
        g = chi_tot[n:n + nj]
        d = np.zeros(c)
        d[n:n + nj] = g / (g @ g)
        AtA = A.T @ A
        Atr = A.T @ rho
        G = AtA - np.outer(Atr, d) - np.outer(d, Atr) + (rho @ rho) * np.outer(d, d)
        sigma_rho2 = float(rho @ rho) / (self.n_rows - c)
        return chi_tot, s22, G, sigma_rho2

    def _finish(self, active: np.ndarray) -> TLSSolution:
        cols = self.columns(active)
        n = int(np.count_nonzero(active))
        c = cols.shape[0]
        A = self.R[:, cols]
        r = self.n_rows
        if r <= c:
            raise IdentificationError(f"only {r} equations for {c} unknowns: record longer")
        if self.noisy_columns == "currents":
            chi_tot, s, G, sigma_rho2 = self._direction_currents(A, n)
        else:
            chi_tot, s, G, sigma_rho2 = self._direction_all(A)
        lam = float(np.linalg.norm(chi_tot))  # |λ| of eq. (36): χ^n_tot has unit norm
        x = chi_tot[:c - 1]
        sigma_w = np.sqrt(sigma_rho2 / (1.0 + x @ x))
        G1 = G[:c - 1, :c - 1]
        try:
            G_inv = np.linalg.inv(G1)
        except np.linalg.LinAlgError as exc:
            raise ExcitationError(
                "Ŵ_tot is singular: some base parameter has no effect on the recorded forces"
            ) from exc
        cov_paper = sigma_rho2 * G_inv  # eq. (39): σ_W² (1 + ‖χ̂‖²) (Ŵᵀ Ŵ)⁻¹
        d = self.scale[cols]
        unc = evaluate(self.blocks, lambda b, j: tls_columns(b, j)[:, cols] * d,
                       chi_tot, self.joint_sigma, G_inv, cov_paper, r)
        rms, _ = self.joint_rms(self._full(chi_tot, active), c - 1)
        if np.any(d != 1.0):  # back to W_tot's units: χ = C χ', cov = C cov' C
            chi_tot, unc, cov_paper = chi_tot * d, _rescaled(unc, d[:-1]), \
                cov_paper * np.outer(d[:-1], d[:-1])
            x = chi_tot[:c - 1]
        cov = unc.cov
        std = np.sqrt(np.abs(np.diag(cov)))
        std_paper = np.sqrt(np.abs(np.diag(cov_paper)))
        with np.errstate(divide="ignore", invalid="ignore"):
            rel = np.where(x != 0, std / np.abs(x), np.inf)
            rel_paper = np.where(x != 0, std_paper / np.abs(x), np.inf)
        Wa = A[:, :n]
        norms = np.linalg.norm(Wa, axis=0)
        if n and np.all(norms > 0):
            sw = np.linalg.svd(Wa / norms, compute_uv=False)
            cond = float(sw[0] / sw[-1]) if sw[-1] > 0 else np.inf
        else:
            cond = np.inf
        return TLSSolution(
            active=active.copy(),
            chi=chi_tot[:n].copy(),
            g_tau=chi_tot[n:n + self.n_joints].copy(),
            cov=cov,
            std=std,
            rel_std=rel,
            sigma_w=float(sigma_w),
            singular_values=np.asarray(s),
            joint_sigma=self.joint_sigma.copy(),
            residual_rms=rms,
            condition_number=cond,
            n_rows=r,
            n_cols=c,
            lambda_scale=float(lam),
            cov_paper=cov_paper,
            rel_std_paper=rel_paper,
            uncertainty=unc,
            rows_per_joint=self.rows_joint.copy(),
        )


def _rescaled(unc: Uncertainty, d: np.ndarray) -> Uncertainty:
    """``unc`` of unknowns x' given for x = d ⊙ x' (covariances D cov D, variances d² var)."""
    D = np.outer(d, d)
    return dataclasses.replace(unc, cov=unc.cov * D, cov_paper=unc.cov_paper * D,
                               var_stationary=unc.var_stationary * d * d,
                               var_block=unc.var_block * d * d)


def idim_tls(blocks: list[Observations | RecordFactors], weighting: bool = True,
             active: np.ndarray | None = None, noisy_columns: str = "all") -> TLSSolution:
    """IDIM-TLS (eqs. 33-39) on decimated records; rows weighted per joint when ``weighting``.

    ``noisy_columns="all"`` is the paper's TLS; ``"currents"`` the mixed LS-TLS variant that
    treats W and W_kl as exact and only the current references as noisy.
    """
    require_loaded_and_unloaded(blocks, "IDIM-TLS")
    return TLSProblem(blocks, weighting, noisy_columns=noisy_columns).solve(active)


def check_excitation(sol: TLSSolution, limits: ExcitationLimits, names: list[str] | None,
                     joint_names: tuple[str, ...]) -> list[str]:
    """Raise :class:`ExcitationError` (one-line reason) when the TLS answer is not the gains.

    The answer is judged by what the TLS itself says (Sect. 4): the separation of the two
    smallest singular values of W_tot (eq. 37: the solution is the gains only when s_c stands
    apart), the conditioning, the gains' honest σ and their signs. A magnitude band is a
    warning, and only when the robot file gives nominal gains (``limits.gain_range``): a right
    answer far from the manufacturer's figure says more about the figure (a motor-side gain, a
    unit) than about the data. Returns the warnings.
    """
    check_subspace(sol, limits)
    return check_gains(sol, limits, joint_names)


def check_subspace(sol: TLSSolution, limits: ExcitationLimits) -> None:
    """Eq. (37): s_c apart from s_(c-1), and the scaled regressor's condition number."""
    if sol.singular_ratio > limits.max_singular_ratio:
        raise ExcitationError(
            f"the two smallest singular values of W_tot are not separated (s_c/s_c-1 = "
            f"{sol.singular_ratio:.2f} > {limits.max_singular_ratio:g}, eq. 37): the trajectories "
            "do not excite the model enough to tell the gains from a near-null regressor "
            "direction, or the loaded records' payload (mass, frame, centre of mass) is not the "
            "one mounted"
        )
    if sol.condition_number > limits.max_condition:
        raise ExcitationError(
            f"condition number of the scaled observation matrix is {sol.condition_number:.3g} "
            f"(> {limits.max_condition:.3g}): the trajectories are not exciting enough"
        )


def check_gains(sol: TLSSolution, limits: ExcitationLimits,
                joint_names: tuple[str, ...]) -> list[str]:
    """The gains' honest σ and signs (errors), their band (warnings, see check_excitation)."""
    g = sol.g_tau
    n = sol.chi.shape[0]
    grel = sol.rel_std[n:n + g.shape[0]]
    if np.any(grel > limits.max_gain_rel_std):
        j = int(np.argmax(grel))
        raise ExcitationError(
            f"drive gain of {joint_names[j]} is poorly identified (relative std "
            f"{100 * grel[j]:.1f} % > {100 * limits.max_gain_rel_std:.1f} %): record longer or "
            "more exciting trajectories"
        )
    negative = [f"{name} {v:.4g}" for name, v in zip(joint_names, g) if not v > 0]
    if negative:
        raise ExcitationError(
            f"identified drive gains {', '.join(negative)} are negative with the singular values "
            "separated: the current of that joint is recorded with the sign opposite to its "
            "effort (a reversed motor or a negative reduction: give the robot file a "
            "transmission with a negative reduction), or the payload tag (mass, frame) is wrong"
        )
    return gain_band_warnings(g, limits, joint_names)


def gain_band_warnings(g: np.ndarray, limits: ExcitationLimits,
                       joint_names: tuple[str, ...]) -> list[str]:
    """Gains outside the band around the robot file's nominal gains (none without them)."""
    if limits.gain_range is None:
        return []
    lo, hi = (np.broadcast_to(np.asarray(x, float), g.shape) for x in limits.gain_range)
    out = [f"identified drive gain of {name} {v:.4g} is outside {a:.4g}-{b:.4g} (the robot "
           "file's nominal gain and gain_range_ratio): the singular values are separated, so "
           "the data say this gain; check the nominal gain's unit and side of the reduction "
           "(motor or joint), and the payload tag"
           for name, v, a, b in zip(joint_names, g, lo, hi) if not a <= v <= b]
    if out and limits.band_is_error:
        raise ExcitationError(out[0].replace("(the robot file's nominal gain and "
                                             "gain_range_ratio)", "(gain_min, gain_max)"))
    return out
