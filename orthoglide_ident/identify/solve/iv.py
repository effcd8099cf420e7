"""IDIM-IV: drive gains and base parameters by instrumental variables, scaled by the payload mass.

Janot, Vandanjon & Gautier, "A generic instrumental variable approach for industrial robot
identification", IEEE TCST 22(1), 2014. The equations are eq. (33)'s, with the payload's known
mass on the right-hand side (the same scale as IDIM-TLS, Sect. 4):

    X θ = y + ρ,   X = [ -W   V_τ ],  θ = [χ; g_τ],  y = W_kl m_kl        (rows of eq. 33)

The current columns V_τ carry the current noise, so least squares on X is biased and TLS is
consistent only when the scaled columns carry equal noise (issue 43). The instruments Z are X with
V_τ replaced by the currents the identified model predicts, Ṽ_τ,j = (W_j χ̂ + W_kl,j m) / ĝ_j: a
simulation of the identified model that carries none of the recorded current's noise, correlated
with X, uncorrelated with ρ. Then

    θ̂ = (Zᵀ Ω X)⁻¹ Zᵀ Ω y,   Ω = diag(1/σ_j²) per joint (Sect. 4.2)

iterated from a start (the TLS answer): Ṽ_τ and σ_j from the last θ̂, until θ̂ stops moving. Its
covariance is the IV sandwich A⁻¹ B A⁻ᵀ, A = Zᵀ Ω X, with B = Zᵀ Ω Z (white residual) or, larger
where the residual is correlated in time, the sum over ~1 s blocks of (Zᵀ Ω ρ)(Zᵀ Ω ρ)ᵀ.

Why the model's predicted current and not a closed-loop simulation (Janot 2014's practical choice,
which needs the controller's gains and the reference): see docs/guide/iv.md.

IV needs the decimated rows themselves, not only their R factors: the offline path keeps them
(``RecordFactors.observations``); the live path does not, and says so.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from orthoglide_ident.errors import ExcitationError, IdentificationError
from orthoglide_ident.identify.observe.equations import Observations

MAX_ITERATIONS = 30
TOLERANCE = 1e-7  # largest relative change of the gains between iterations that stops them
BLOCK_S = 1.0  # s: the residual's correlation is covered over blocks this long


@dataclass
class IVSolution:
    """θ̂ = [χ (n_b), g_τ (n_j)], its covariance (honest: the larger of the white and block
    sandwiches per entry), σ_j per joint, residual rms per joint and the iterations run."""

    chi: np.ndarray
    g_tau: np.ndarray
    cov: np.ndarray
    cov_white: np.ndarray
    joint_sigma: np.ndarray
    residual_rms: np.ndarray
    iterations: int
    n_rows: int
    rows_per_joint: np.ndarray

    @property
    def std(self) -> np.ndarray:
        return np.sqrt(np.abs(np.diag(self.cov)))

    @property
    def rel_std(self) -> np.ndarray:
        x = np.concatenate([self.chi, self.g_tau])
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(x != 0, self.std / np.abs(x), np.inf)


@dataclass
class _Rows:
    """Joint j's kept rows of one record: W (r, n_b), the payload term y (r,), v_τ (r,), the
    rows' instants (r,) s since the record's first stamp (its row index without them)."""

    j: int
    W: np.ndarray
    y: np.ndarray
    v: np.ndarray
    t: np.ndarray
    record: int


def _rows(blocks: list[Observations]) -> list[_Rows]:
    out = []
    for k, b in enumerate(blocks):
        t = b.t if b.t is not None else np.arange(b.n_samples, dtype=float)
        for j in range(b.v_tau.shape[0]):
            sel = slice(None) if b.keep is None else b.keep[j]
            out.append(_Rows(j, b.W[j][sel], b.payload_mass * b.w_m[j][sel], b.v_tau[j][sel],
                             t[sel], k))
    return out


def _sums(rows: list[_Rows], theta: np.ndarray, sigma: np.ndarray, n_j: int
          ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A = Zᵀ Ω X, b = Zᵀ Ω y and B = Zᵀ Ω Z for the instruments of ``theta``."""
    n_b = theta.shape[0] - n_j
    chi, g = theta[:n_b], theta[n_b:]
    c = n_b + n_j
    A, B, bvec = np.zeros((c, c)), np.zeros((c, c)), np.zeros(c)
    for r in rows:
        w = 1.0 / sigma[r.j] ** 2
        v_sim = (r.W @ chi + r.y) / g[r.j]  # the identified model's current: no noise
        Zr = np.zeros((r.W.shape[0], c))
        Zr[:, :n_b] = -r.W
        Zr[:, n_b + r.j] = v_sim
        Xr = Zr.copy()
        Xr[:, n_b + r.j] = r.v
        A += w * Zr.T @ Xr
        B += w * Zr.T @ Zr
        bvec += w * Zr.T @ r.y
    return A, bvec, B


def _residuals(rows: list[_Rows], theta: np.ndarray, n_j: int) -> list[np.ndarray]:
    """ρ = X θ - y of each row group (N or N·m)."""
    n_b = theta.shape[0] - n_j
    return [-r.W @ theta[:n_b] + r.v * theta[n_b + r.j] - r.y for r in rows]


def _joint_sigma(rows: list[_Rows], res: list[np.ndarray], n_j: int, c: int) -> np.ndarray:
    ss, n = np.zeros(n_j), np.zeros(n_j)
    for r, e in zip(rows, res):
        ss[r.j] += float(e @ e)
        n[r.j] += e.shape[0]
    dof = np.maximum(n - c * n / n.sum(), 1.0)
    return np.sqrt(ss / dof)


def _block_meat(rows: list[_Rows], res: list[np.ndarray], theta: np.ndarray,
                sigma: np.ndarray, n_j: int) -> np.ndarray:
    """Σ over ~BLOCK_S blocks of each record of s sᵀ, s = Σ_rows z ρ / σ_j²: B when the
    residual is correlated in time (rows of every joint in a block summed together)."""
    n_b = theta.shape[0] - n_j
    c = n_b + n_j
    scores: dict[tuple[int, int], np.ndarray] = {}
    for r, e in zip(rows, res):
        v_sim = (r.W @ theta[:n_b] + r.y) / theta[n_b + r.j]
        zr = np.zeros((r.W.shape[0], c))
        zr[:, :n_b] = -r.W
        zr[:, n_b + r.j] = v_sim
        block = np.floor(r.t / BLOCK_S).astype(int)  # t: s since the record's first stamp
        contrib = zr * (e / sigma[r.j] ** 2)[:, None]
        for k in np.unique(block):
            key = (r.record, int(k))
            s = contrib[block == k].sum(axis=0)
            scores[key] = scores.get(key, 0.0) + s
    S = np.array(list(scores.values()))
    return S.T @ S


def idim_iv(blocks: list[Observations], chi0: np.ndarray, g0: np.ndarray,
            max_iterations: int = MAX_ITERATIONS) -> IVSolution:
    """IDIM-IV on the decimated records ``blocks`` from the start (χ0 over W's columns, g0):
    see the module docstring. ExcitationError when Zᵀ Ω X is singular."""
    if not any(b.loaded for b in blocks):
        raise IdentificationError("IDIM-IV needs a loaded record: the payload's known mass "
                                  "fixes the scale of the drive gains")
    n_j = blocks[0].v_tau.shape[0]
    rows = _rows(blocks)
    theta = np.concatenate([np.asarray(chi0, float), np.asarray(g0, float)])
    c = theta.shape[0]
    sigma = _joint_sigma(rows, _residuals(rows, theta, n_j), n_j, c)
    it = 0
    for it in range(1, max_iterations + 1):  # noqa: B007  (it: the iterations taken, returned)
        A, bvec, _ = _sums(rows, theta, sigma, n_j)
        try:
            new = np.linalg.solve(A, bvec)
        except np.linalg.LinAlgError as exc:
            raise ExcitationError("IDIM-IV: the instruments do not determine the parameters "
                                  "(Zᵀ W_tot singular): the trajectories are not exciting") from exc
        step = np.max(np.abs(new[-n_j:] / theta[-n_j:] - 1.0))
        theta = new
        sigma = _joint_sigma(rows, _residuals(rows, theta, n_j), n_j, c)
        if step < TOLERANCE:
            break
    return _finish(rows, theta, sigma, n_j, it)


def _finish(rows: list[_Rows], theta: np.ndarray, sigma: np.ndarray, n_j: int,
            iterations: int) -> IVSolution:
    """The IV sandwich covariances at θ̂ (module docstring) and the residual figures."""
    A, _, B = _sums(rows, theta, sigma, n_j)
    res = _residuals(rows, theta, n_j)
    A_inv = np.linalg.inv(A)
    cov_white = A_inv @ B @ A_inv.T
    cov_block = A_inv @ _block_meat(rows, res, theta, sigma, n_j) @ A_inv.T
    dw, db = np.diag(cov_white), np.diag(cov_block)
    d = np.sqrt(np.maximum(dw, db) / np.where(dw > 0, dw, 1.0))
    cov = cov_white * np.outer(d, d)  # white-noise correlations, the larger variance of the two
    ss, n = np.zeros(n_j), np.zeros(n_j, dtype=int)
    for r, e in zip(rows, res):
        ss[r.j] += float(e @ e)
        n[r.j] += e.shape[0]
    n_b = theta.shape[0] - n_j
    return IVSolution(theta[:n_b].copy(), theta[n_b:].copy(), cov, cov_white, sigma,
                      np.sqrt(ss / np.maximum(n, 1)), iterations, int(n.sum()), n)


def observations_of(factors: list) -> list[Observations]:
    """The decimated rows behind the factors (RecordFactors.observations); IdentificationError
    when they were not kept (the live estimate folds rows into R and drops them)."""
    obs = [f.observations for f in factors]
    if any(o is None for o in obs):
        raise IdentificationError("IDIM-IV needs the records' decimated rows, which only the "
                                  "offline identification keeps (orthoglide-ident identify)")
    return obs


CROSS_CHECK_SIGMAS = 3.0  # TLS and IV gains further apart than this many combined σ disagree


def disagreement(g_tls: np.ndarray, rel_tls: np.ndarray, iv: IVSolution) -> np.ndarray:
    """Per gain |g_TLS - g_IV| in combined σ: the larger of the two answers' σ. Both come from
    the same data, so their errors from the current noise largely move together and their
    difference is not as uncertain as either; σ added in quadrature would hide a bias as large
    as the issue's (Panda joint 7: TLS at 5.7 of its σ from the truth, 2.6 quadrature σ from
    IV), the larger σ does not (4.0) and a clean record stays below 3 (bench/tls_vs_iv.py)."""
    s = np.maximum(np.abs(g_tls) * rel_tls, iv.std[-g_tls.shape[0]:])
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.abs(g_tls - iv.g_tau) / s
