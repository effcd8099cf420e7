"""A search with gradients (``excite design --search gradient``, the default): the best random
shape polished by SLSQP with analytic gradients of the criterion and of the constraints.

Variables v = [s, α_u, α_l, t]: the shape's Fourier coefficients s (per joint, in the subspace
at rest at the period's ends: Σ_l a_l = 0, Σ_l l b_l = 0, trajectory.rest_projection), one
amplitude α per run (run r moves q = P + α_r Φ₀ s), and the epigraph variable t of the worst
gain. On the coarse grid t_k (``samples`` per period, the criterion's own):

    minimise  t + COND_WEIGHT · log κ(F)
    s.t.      t ≥ log σ(g_j)/g_j            for each determined gain j (design.py's J)
              the shape's position, velocity, acceleration within the limits less their margins
              (linear in s: α ≤ 1 keeps both runs inside too)
              |τ_j(t_k)| ≤ (1 − margin) τ_max,j, τ = W(q, q̇, q̈) χ̃ with the run's payload

with F = Σ_runs Σ_j A_jᵀ A_j (prediction.information: rows a = [W_row, −v_τ e_j, v̇_τ e_j]).

Gradients (analytic through the Fourier series): joint i's q_i, q̇_i, q̈_i are linear in its own
coefficients only, through the basis Φ₀, Φ₁ = Φ₀', Φ₂ = Φ₀''. So for any scalar f of the
regressor rows, ∂f/∂s_i = α Σ_k [∂f/∂q_i(t_k) Φ₀(t_k) + ∂f/∂q̇_i(t_k) Φ₁(t_k) + ∂f/∂q̈_i(t_k)
Φ₂(t_k)], and the partials of the regressor per sample need 5n + 1 evaluations of the
product's own observation block (whatever the number of harmonics): q̈ exactly (W is affine in
q̈), q and q̇ by central differences. The product's block, rather than Pinocchio's
computeRNEADerivatives, because it is what the prediction uses: base-parameter regrouping,
motor rows, friction and armature columns, the payload column, mimic joints and a closed
chain's loops all come with it (RNEA derivatives would be needed once per standard parameter
and then regrouped, and give none of the closure's). The information matrix's gradient is taken
by its adjoint (tr(G dF) = 2 Σ_j tr(G A_jᵀ dA_j), G = ∂f/∂F), so no dF per coefficient is
formed; ∂ log σ_j² / ∂F = −F⁺e_j e_jᵀF⁺ / σ_j², ∂ log κ / ∂F through the column scaling D and
the extreme eigenpairs of D F D.

Self-collision (the smallest distance over the checked pairs), a closed chain's working mode
and its rate growth are constraints on every 4th sample (every sample for a closed chain), their
gradients by central differences in q of the distances and closures (only where within
NEAR_SLACK: elsewhere inactive). The answer is evaluated as the walk evaluates
(design.Problem.evaluate_trajectory); where it breaks a constraint the solver's previous
iterates are tried. The 1 ms check and its repair (design.repaired: the amplitude lowered
while a limit is broken between the coarse samples) follow as for the walk.
"""
from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize

from orthoglide_ident.errors import ModelError
from orthoglide_ident.excite.constraints import payload_dict
from orthoglide_ident.excite.prediction import RATE_HZ, periodic_rate
from orthoglide_ident.excite.trajectory import ExcitationRun, ExcitationTrajectory
from orthoglide_ident.model.pinocchio_model import MAX_RATE_GROWTH

H_Q, H_QD = 1e-6, 1e-6  # central-difference steps of the regressor in q (rad, m) and q̇
ALPHA_MIN = 0.05  # the smallest amplitude the NLP may give a run
MAX_ITER = 20  # SLSQP iterations per start (UR5: −6.09 at 20, −6.14 at 30, 3.6 → 5.0 s CPU)
H_DIST = 1e-4  # rad or m: central differences of the bodies' distances (GJK ~1e-8 m)
COLLISION_SCALE = 0.02  # m: a distance constraint normalised like design.VIOLATION_SCALE's
NEAR_SLACK = 3.0  # normalised pose slack (3 × 2 cm, 3 × 0.05 rad) within which it is derived
POSE_BOUND = 2.5  # margins: pairs further apart than this get their bounding spheres' bound
WORKING_MODE_SCALE = 0.05  # rad or m: a passive joint's room, likewise
NEAR_VIOLATION, INSIDE = 1e-3, 1e-3  # normalised violation of an iterate on a limit; α cut
BACKTRACKS = 8  # SLSQP iterates tried back from its answer when it breaks a checked constraint


@dataclass(frozen=True)
class Basis:
    """The Fourier basis at rest at the period's ends on grid ``t``: Φ (3, m, 2(L−1)) for q − P,
    q̇, q̈ of one joint's reduced coefficients s = [a N_a, b N_b] (N: orthonormal complements of
    1 and of (1..L), so a = N_a s_a satisfies Σ a_l = 0 and b = N_b s_b, Σ l b_l = 0)."""

    phi: np.ndarray
    N_a: np.ndarray
    N_b: np.ndarray

    @classmethod
    def on(cls, t: np.ndarray, w_f: float, L: int) -> Basis:
        ell = np.arange(1, L + 1, dtype=float)
        kw = w_f * ell
        s, c = np.sin(np.outer(t, kw)), np.cos(np.outer(t, kw))
        # trajectory.py: q − P = Σ a/(lω) sin + b/(lω)(1 − cos); q̇ = a cos + b sin; q̈ = lω(−a sin
        # + b cos)
        pa, pb = np.stack([s / kw, c, -s * kw]), np.stack([(1 - c) / kw, s, c * kw])
        N_a, N_b = (np.linalg.svd(v[None])[2][1:].T for v in (np.ones(L), ell))
        phi = np.concatenate([pa @ N_a, pb @ N_b], axis=2)
        phi[1:, t % (2 * math.pi / w_f) == 0] = 0.0  # at rest: exactly, not up to rounding
        return cls(phi, N_a, N_b)

    @property
    def k(self) -> int:
        return self.phi.shape[2]

    def coefficients(self, S: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(a, b) (n, L) of reduced coefficients S (n, k)."""
        h = self.N_a.shape[1]
        return S[:, :h] @ self.N_a.T, S[:, h:] @ self.N_b.T

    def reduced(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """S (n, k) of (a, b) at rest (their components off the subspace dropped)."""
        return np.concatenate([a @ self.N_a, b @ self.N_b], axis=1)

    def motion(self, P: np.ndarray, S: np.ndarray, alpha: float):
        """q, q̇, q̈ (m, n) of coefficients α S."""
        q, qd, qdd = alpha * (self.phi @ S.T)
        return P + q, qd, qdd


def regressor_partials(model, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray
                       ) -> tuple[np.ndarray, np.ndarray]:
    """X = [W | W_payload] (p, n, m) and ∂X/∂x (3, n, p, n, m) per sample, x = q, q̇, q̈ of each
    actuated joint: q̈ exactly (X affine in q̈: a unit step), q and q̇ by central differences
    (H_Q, H_QD). The 5n + 1 states of each sample are stacked next to it in one call of the
    observation block, whatever the number of harmonics (its per-call cost dominates at 100
    samples; a closed chain's loops, warm-started from the previous sample, stay on one branch)."""
    m, n = q.shape
    E = np.eye(n)
    z = np.zeros((1, n))
    # offsets (S, n) of q, q̇, q̈: the sample, ± H_Q e_i, ± H_QD e_i, + e_i
    dq = np.concatenate([z, H_Q * E, -H_Q * E, np.zeros((3 * n, n))])
    dqd = np.concatenate([np.zeros((1 + 2 * n, n)), H_QD * E, -H_QD * E, np.zeros((n, n))])
    dqdd = np.concatenate([np.zeros((1 + 4 * n, n)), E])
    S = dq.shape[0]
    states = [(x[:, None, :] + d[None]).reshape(m * S, n) for x, d in
              ((q, dq), (qd, dqd), (qdd, dqdd))]
    X = np.moveaxis(model.observation_block(*states).reshape(-1, n, m, S), 3, 0)
    X0 = X[0]
    dX = np.empty((3, n) + X0.shape)
    dX[0] = (X[1:1 + n] - X[1 + n:1 + 2 * n]) / (2 * H_Q)
    dX[1] = (X[1 + 2 * n:1 + 3 * n] - X[1 + 3 * n:1 + 4 * n]) / (2 * H_QD)
    dX[2] = X[1 + 4 * n:] - X0
    return X0, dX


@dataclass
class RunRows:
    """One run on the coarse grid: its rows A_j (n, m, c) of prediction.information (weight w
    included as √w), efforts τ (n, m), and what the adjoint needs."""

    A: np.ndarray
    tau: np.ndarray
    dX: np.ndarray | None  # None: values only
    chi: np.ndarray  # χ̃ = [χ_b, payload mass]
    scale: np.ndarray  # (n,) 1 / (g_j σ_j) · √w
    dt: float | None  # s per sample when the lag columns are in (periodic central difference)

    @property
    def F(self) -> np.ndarray:
        return np.einsum("jtc,jtd->cd", self.A, self.A)

    def tau_partials(self) -> np.ndarray:
        """∂τ_j(t)/∂x (3, n_in, n, m)."""
        return np.einsum("p,kipjt->kijt", self.chi, self.dX)


def run_rows(model, chi_b, gains, noise, mass, motion, weight, dt, partials=True) -> RunRows:
    """The run's rows (prediction.information's columns [χ_b, g, lag]) and (``partials``)
    the regressor's partials."""
    X, dX = regressor_partials(model, *motion) if partials else \
        (model.observation_block(*motion), None)
    n_b, n, m = X.shape[0] - 1, X.shape[1], X.shape[2]
    chi = np.append(chi_b, mass)
    tau = np.einsum("p,pjt->jt", chi, X)
    c = n_b + n * (1 if dt is None else 2)
    A = np.zeros((n, m, c))
    A[:, :, :n_b] = np.moveaxis(X[:-1], 0, 2)
    A[np.arange(n), :, n_b + np.arange(n)] = -tau / gains[:, None]
    if dt is not None:
        A[np.arange(n), :, n_b + n + np.arange(n)] = periodic_rate(tau, dt) / gains[:, None]
    scale = math.sqrt(weight) / (gains * noise)
    return RunRows(A * scale[:, None, None], tau, dX, chi, scale, dt)


def sensitivities(rows: RunRows, G: np.ndarray, gains: np.ndarray) -> np.ndarray:
    """∂f/∂x(t) (f, 3, n_in, m) of scalars f of F with ∂f/∂F = G (f, c, c), symmetric:
    df = 2 Σ_j tr(G A_jᵀ dA_j) (the adjoint: no dF per coefficient)."""
    n, m, c = rows.A.shape
    n_b = rows.chi.shape[0] - 1
    B = 2.0 * np.moveaxis(np.tensordot(rows.A, G, axes=([2], [1])), 2, 0)  # ∂f/∂A_j[t, :]
    omega = np.zeros((G.shape[0], n_b + 1, n, m))
    omega[:, :n_b] = np.moveaxis(B[..., :n_b], 3, 1) * rows.scale[None, None, :, None]
    j = np.arange(n)
    beta = -B[:, j, :, n_b + j]  # (n, f, m): v_τ column = −τ/g
    if rows.dt is not None:  # v̇_τ = R τ / g, R the periodic central difference: Rᵀ = −R
        lag = B[:, j, :, n_b + n + j]
        beta = beta - (np.roll(lag, -1, -1) - np.roll(lag, 1, -1)) / (2.0 * rows.dt)
    beta = np.moveaxis(beta, 0, 1) * (rows.scale / gains)[None, :, None]
    omega += beta[:, None] * rows.chi[None, :, None, None]
    f, (k, ni) = omega.shape[0], rows.dX.shape[:2]
    # Σ_pj Ω[f,p,j,t] ∂X[p,j,t]/∂x_ki(t): one matrix product per sample t
    out = np.matmul(omega.reshape(f, -1, m).transpose(2, 0, 1),
                    rows.dX.reshape(k * ni, -1, m).transpose(2, 1, 0))
    return out.transpose(1, 2, 0).reshape(f, k, ni, m)


def to_coefficients(phi: np.ndarray, sens: np.ndarray, S: np.ndarray, alpha: float
                    ) -> tuple[np.ndarray, np.ndarray]:
    """(∂f/∂S (f, n, k), ∂f/∂α (f,)) of per-sample sensitivities (f, 3, n, m): the Fourier
    series' chain rule, ∂x_i(t)/∂s_i = α Φ(t), ∂x_i(t)/∂α = Φ(t) s_i."""
    gamma = np.einsum("fkit,ktc->fic", sens, phi)
    return alpha * gamma, np.einsum("fic,ic->f", gamma, S)


def criterion_partials(F: np.ndarray, gain_index: np.ndarray, gains: np.ndarray, cap: float
                       ) -> tuple[np.ndarray, np.ndarray]:
    """Values [log σ(g_j)/g_j for j in ``gain_index``, log κ] of information F (prediction.
    from_information at ``cap``: the directions beyond it left out) and their ∂/∂F (f, c, c).

    σ_j² = (F⁺)_jj: ∂ log σ_j² = −(F⁺e_j)(F⁺e_j)ᵀ / σ_j² (d F⁺ = −F⁺ dF F⁺ on the kept
    directions). κ² = λ_max/λ_min of F_s = D F D, D = diag(F)^−½: ∂λ = vᵀ dF_s v, and through D,
    ∂f/∂F = D G_s D − diag(D_ii³ (F D G_s)_ii)."""
    Dm = 1.0 / np.sqrt(np.clip(np.diag(F), 1e-300, None))
    lam, V = np.linalg.eigh(F * np.outer(Dm, Dm))
    keep = lam > lam[-1] / cap ** 2
    cov = (V[:, keep] / lam[keep]) @ V[:, keep].T * np.outer(Dm, Dm)
    vals, grads = [], []
    for idx, g in zip(gain_index, gains):
        c = cov[:, idx]
        vals.append(0.5 * math.log(cov[idx, idx]) - math.log(g))
        grads.append(-0.5 * np.outer(c, c) / cov[idx, idx])
    lo = int(np.flatnonzero(keep)[0])
    vM, vm = V[:, -1], V[:, lo]
    vals.append(0.5 * (math.log(lam[-1]) - math.log(lam[lo])))
    Gs = 0.5 * (np.outer(vM, vM) / lam[-1] - np.outer(vm, vm) / lam[lo])
    G = Gs * np.outer(Dm, Dm)
    G[np.diag_indices_from(G)] -= Dm ** 3 * np.einsum("ij,j,ji->i", F, Dm, Gs)
    grads.append(G)
    return np.array(vals), np.array(grads)


class Polish:
    """The NLP of the module docstring for ``problem`` (design.Problem), the gains in
    ``determined`` kept in the epigraph, the directions beyond ``cap`` left out. Also what
    design.repaired needs of a problem: ``trajectory(v)``, ``with_alpha(v, k, factor)``."""

    def __init__(self, problem, cap: float, cond_weight: float, determined: np.ndarray,
                 collision_every: int = 1, clock=None):
        p = problem
        self.every, self.clock = collision_every, clock
        self.problem, self.cap, self.cond_weight = p, cap, cond_weight
        self.robot, self.limits, self.collision, self.opt, self.runs = (
            p.robot, p.limits, p.collision, p.opt, p.runs)
        self.n, self.basis = p.n, Basis.on(p.t, p.w_f, p.L)
        self.models = [(p.robot if pl is None else p.robot.with_payload(pl),
                        0.0 if pl is None else pl.mass) for _, pl in p.runs]
        m = len(p.t)
        self.weight = RATE_HZ * p.opt.period_s * p.opt.periods / m
        self.dt = None if p.lag_rate(np.zeros((p.n, m))) is None else p.opt.period_s / m
        n_b = p.chi_b.shape[0]
        self.gain_index = n_b + np.flatnonzero(determined)
        self.gain_values = p.gains[determined]
        self.effort = p.limits.effort * (1.0 - p.opt.margins.effort)
        self.M, self.b = self._linear()
        self._cache: tuple[bytes, dict] | None = None

    @property
    def size(self) -> int:
        return self.n * self.basis.k + 3

    def unpack(self, v: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
        nk = self.n * self.basis.k
        return v[:nk].reshape(self.n, self.basis.k), v[nk:nk + 2], float(v[-1])

    def _linear(self) -> tuple[np.ndarray, np.ndarray]:
        """Position, velocity, acceleration of the shape within the limits less their margins,
        normalised: b + M v ≥ 0 (exact: linear in s)."""
        p, phi, k = self.problem, self.basis.phi, self.basis.k
        mg = p.opt.margins
        vel = p.bounds.velocity * (1 - mg.velocity)
        acc = p.bounds.acceleration * (1 - mg.acceleration)
        rng = p.hi - p.lo
        Ms, bs = [], []
        for i in range(self.n):
            blk = np.zeros((6 * phi.shape[1], self.size))
            rows = np.concatenate([-phi[0], phi[0], -phi[1], phi[1], -phi[2], phi[2]])
            sc = np.repeat([rng[i], rng[i], vel[i], vel[i], acc[i], acc[i]], phi.shape[1])
            blk[:, i * k:(i + 1) * k] = rows / sc[:, None]
            Ms.append(blk)
            bs.append(np.repeat([(p.hi[i] - p.P[i]) / rng[i], (p.P[i] - p.lo[i]) / rng[i],
                                 1.0, 1.0, 1.0, 1.0], phi.shape[1]))
        return np.concatenate(Ms), np.concatenate(bs)

    def terms(self, v: np.ndarray, grad: bool = True) -> dict:
        """Criterion values, the effort constraints and (``grad``) their gradients in v (the
        line search's trial points need no partials of the regressor)."""
        key = v.tobytes()
        if self._cache is not None and self._cache[0] == key and \
                (self._cache[1]["grad"] is not None or not grad):
            return self._cache[1]
        p, S, alpha, _ = self.problem, *self.unpack(v)
        rows, F = [], 0.0
        for r, (model, mass) in enumerate(self.models):
            motion = self.basis.motion(p.P, S, alpha[r])
            rows.append(run_rows(model, p.chi_b, p.gains, p.opt.noise_a, mass, motion,
                                 self.weight, self.dt, grad))
            F = F + rows[-1].F
        vals, G = criterion_partials(F, self.gain_index, self.gain_values, self.cap)
        if not grad:
            u = np.concatenate([(rr.tau / self.effort[:, None]).ravel() for rr in rows])
            slack = 1.0 - self.opt.margins.effort
            eff = np.concatenate([np.concatenate([slack - x, slack + x])
                                  for x in np.split(u, len(rows))])
            self._cache = (key, {"vals": vals, "grad": None, "effort": eff,
                                 "collision": self._collision(S, alpha, False)[0]})
            return self._cache[1]
        grad = np.zeros((len(vals), self.size))
        eff_c, eff_J = [], []
        for r, rr in enumerate(rows):
            gS, ga = to_coefficients(self.basis.phi, sensitivities(rr, G, p.gains), S, alpha[r])
            grad[:, :S.size] += gS.reshape(len(vals), -1)
            grad[:, S.size + r] += ga
            c, J = self._effort(rr, S, alpha, r)
            eff_c.append(c)
            eff_J.append(J)
        c, J = self._collision(S, alpha, True)
        out = {"vals": vals, "grad": grad, "effort": np.concatenate(eff_c),
               "effort_jac": np.concatenate(eff_J), "collision": c, "collision_jac": J}
        self._cache = (key, out)
        return out

    def _effort(self, rr: RunRows, S: np.ndarray, alpha: np.ndarray, r: int
                ) -> tuple[np.ndarray, np.ndarray]:
        """(1 − margin) ∓ τ_j(t)/τ_max,j ≥ 0 on the grid and its Jacobian: τ = X χ̃, so
        ∂τ/∂x = (∂X/∂x) χ̃ through the same Fourier chain rule."""
        T = rr.tau_partials() / self.effort[None, None, :, None]
        k, n, _, m = T.shape
        gS = alpha[r] * np.matmul(T.transpose(3, 2, 1, 0).reshape(m, n * n, k),
                                  self.basis.phi.transpose(1, 0, 2)
                                  ).reshape(m, n, n, -1).transpose(1, 0, 2, 3)
        ga = np.einsum("kijt,ktc,ic->jt", T, self.basis.phi, S)
        J = np.zeros((rr.tau.size, self.size))
        J[:, :S.size] = gS.reshape(rr.tau.size, S.size)
        J[:, S.size + r] = ga.ravel()
        u = (rr.tau / self.effort[:, None]).ravel()
        slack = 1.0 - self.opt.margins.effort
        return np.concatenate([slack - u, slack + u]), np.concatenate([-J, J])

    def _pose_slacks(self, q: np.ndarray) -> np.ndarray:
        """(m, K) normalised slacks of poses q (m, n) that only the pose sets: the smallest
        distance over the checked pairs less its margin; for a closed chain, its passive
        joints' distance to their limits (working mode) and its rate growth, as
        constraints.TreeStates.mode_slacks."""
        p, mg, out = self.problem, self.opt.margins, []
        Q, G = p.tree.configurations(q)
        if self.collision is not None and self.collision.mode != "skip":
            # exact for the pairs whose bounding spheres are within POSE_BOUND margins, their
            # bound beyond (inactive there): coal's mesh distances cost ~0.3 ms a pair
            d = self.collision.distances_above(Q, POSE_BOUND * mg.collision).min(
                axis=1, initial=math.inf)
            out.append((d - mg.collision) / COLLISION_SCALE)
        if G is not None:
            for j in p.tree.passive:
                room = np.minimum(Q[:, j.iq] - j.lower, j.upper - Q[:, j.iq])
                out.append((room - mg.working_mode) / WORKING_MODE_SCALE)
            out.append(1.0 - G / (MAX_RATE_GROWTH * p.tree.g_ref) - mg.rate_growth)
        return np.column_stack(out) if out else np.zeros((len(q), 0))

    def _collision(self, S: np.ndarray, alpha: np.ndarray, grad: bool
                   ) -> tuple[np.ndarray, np.ndarray | None]:
        """The pose slacks (``_pose_slacks``) ≥ 0 on every ``collision_every``-th sample of both
        runs and (``grad``) their Jacobian: ∂/∂q_i by central differences (H_DIST) of the
        distances and closures, through q_i = P_i + α Φ₀ s_i."""
        p = self.problem
        if (self.collision is None or self.collision.mode == "skip") and p.tree.closure is None:
            return np.zeros(0), np.zeros((0, self.size))
        phi0 = self.basis.phi[0, ::self.every]
        cs, Js = [], []
        for r in range(2):
            q = p.P + alpha[r] * (phi0 @ S.T)
            m, n = q.shape
            d0 = self._pose_slacks(q)  # (m, K)
            cs.append(d0.ravel())
            if not grad:
                continue
            # ∂/∂q (m, n, K) where a slack is within NEAR_SLACK: 0 where none is (inactive;
            # an iterate that comes near gets its gradient there)
            near = (d0 < NEAR_SLACK).any(axis=1)
            g = np.zeros((m, n, d0.shape[1]))
            if near.any():
                h = H_DIST * np.eye(n)
                pts = np.concatenate([q[near][:, None] + h, q[near][:, None] - h], axis=1)
                d = self._pose_slacks(pts.reshape(-1, n)).reshape(near.sum(), 2 * n, -1)
                g[near] = (d[:, :n] - d[:, n:]) / (2 * H_DIST)
            J = np.zeros((m, d0.shape[1], self.size))
            J[:, :, :S.size] = alpha[r] * np.einsum("tik,tc->tkic", g, phi0).reshape(
                m, d0.shape[1], -1)
            J[:, :, S.size + r] = np.einsum("tik,tc,ic->tk", g, phi0, S)
            Js.append(J.reshape(-1, self.size))
        return np.concatenate(cs), (np.concatenate(Js) if grad else None)

    def objective(self, v: np.ndarray) -> float:
        return float(v[-1] + self.cond_weight * self.terms(v, False)["vals"][-1])

    def objective_grad(self, v: np.ndarray) -> np.ndarray:
        g = self.cond_weight * self.terms(v)["grad"][-1]
        g[-1] = 1.0
        return g

    def constraints(self, v: np.ndarray) -> np.ndarray:
        t = self.terms(v, False)
        return np.concatenate([v[-1] - t["vals"][:-1], self.b + self.M @ v, t["effort"],
                               t["collision"]])

    def constraints_jac(self, v: np.ndarray) -> np.ndarray:
        t = self.terms(v)
        J = -t["grad"][:-1]
        J[:, -1] = 1.0
        return np.concatenate([J, self.M, t["effort_jac"], t["collision_jac"]])

    def start(self, x: np.ndarray) -> np.ndarray:
        """v of the walk's x (design.Problem): its scaled shape, amplitudes, t at its worst gain."""
        a, b = self.problem.shape(x)
        alpha = 1.0 / (1.0 + np.exp(-x[-2:]))
        v = np.concatenate([self.basis.reduced(a, b).ravel(), alpha, [0.0]])
        v[-1] = self.terms(v, False)["vals"][:-1].max(initial=-math.inf)
        return v

    def trajectory(self, v: np.ndarray) -> ExcitationTrajectory:
        p, (S, alpha, _) = self.problem, self.unpack(v)
        a, b = self.basis.coefficients(S)
        runs = {}
        for k, (name, payload) in enumerate(self.runs):
            A, B = a * alpha[k], b * alpha[k]
            q0 = p.P + (B / (p.w_f * p.ell)).sum(axis=1)  # q(0) = P
            runs[name] = ExcitationRun(name, q0, A, B, payload_dict(payload))
        return ExcitationTrajectory(p.robot.name, p.robot.joint_names, p.opt.period_s,
                                    p.opt.periods, runs)

    def with_alpha(self, v: np.ndarray, k: int, factor: float) -> np.ndarray:
        y = v.copy()
        y[self.n * self.basis.k + k] *= factor
        return y

    def solve(self, v0: np.ndarray) -> list[np.ndarray]:
        """SLSQP's iterates from v0 (MAX_ITER iterations), the last first; [v0] when the model
        fails on the way."""
        bounds = [(None, None)] * (self.size - 3) + [(ALPHA_MIN, 1.0)] * 2 + [(None, None)]
        path = [v0]

        def step(v: np.ndarray) -> None:  # the iterates, and the time limit (the best so far)
            path.append(np.array(v))
            if self.clock is not None and self.clock.out():
                raise StopIteration

        try:
            res = minimize(self.objective, v0, jac=self.objective_grad, method="SLSQP",
                           bounds=bounds, constraints=[{"type": "ineq", "fun": self.constraints,
                                                        "jac": self.constraints_jac}],
                           options={"maxiter": MAX_ITER, "ftol": 1e-6}, callback=step)
            path.append(res.x)
        except ModelError:
            return [v0]
        except StopIteration:
            pass
        return [v for v in path[::-1] if np.all(np.isfinite(v))]


def distinct(starts: list[np.ndarray]) -> list[np.ndarray]:
    out: list[np.ndarray] = []
    for x in starts:
        if not any(np.array_equal(x, y) for y in out):
            out.append(x)
    return out


def polish(problem, starts: list[np.ndarray], cap: float, cond_weight: float,
           determined: np.ndarray, say: Callable[[str], None], collision_every: int = 1,
           clock=None):
    """(the Polish, its best v, its Evaluation) over ``starts`` (design.Problem's x): each
    solved, then evaluated as the walk evaluates (collision, working mode); where SLSQP's
    answer breaks one of those, its last iterate that does not and improves on the start
    (at most BACKTRACKS of them tried), else the start."""
    nlp = Polish(problem, cap, cond_weight, determined, collision_every, clock)
    best = None
    for x in starts:
        v0 = nlp.start(x)
        ev0 = problem.evaluate_trajectory(nlp.trajectory(v0))
        v, ev, broken = v0, ev0, []
        path = nlp.solve(v0)
        if len(path) == 1:
            say(f"gradient polish: no step from {ev0.criterion:.4f} (the model failed on the way)")
        for y in path[:BACKTRACKS + 1] if len(path) > 1 else ():
            y, e = _inside(nlp, y)
            if e.violation == 0 and e.score < ev0.score:
                v, ev = y, e
                break
            broken.append(e)
        if len(path) > 1:
            say(f"gradient polish: criterion {ev0.criterion:.4f} -> {ev.criterion:.4f}"
                + (f" ({len(broken)} iterates back: {_why(broken[0])})" if broken else ""))
        if best is None or ev.score < best[1].score:
            best = (v, ev)
    return nlp, best[0], best[1]


def _inside(nlp: Polish, v: np.ndarray):
    """(v, its evaluation), v's amplitudes lowered by INSIDE when SLSQP left it on a limit up to
    rounding (an SQP iterate meets its constraints only to its tolerance)."""
    ev = nlp.problem.evaluate_trajectory(nlp.trajectory(v))
    if 0 < ev.violation < NEAR_VIOLATION:
        v = nlp.with_alpha(nlp.with_alpha(v, 0, 1 - INSIDE), 1, 1 - INSIDE)
        ev = nlp.problem.evaluate_trajectory(nlp.trajectory(v))
    return v, ev


def _why(ev) -> str:
    return "a checked constraint broken" if ev.worst is None else ev.worst.kind
