"""Least squares under linear matrix inequalities, solved by Clarabel (an interior-point conic
solver): the numerical core of the physical-consistency step (consistency.py).

    minimise   ‖A z − a‖² + w ‖B z − b‖²
    subject to svec(S_k(z)) = G_k z + h_k ⪰ 0      (4×4 blocks: the bodies' pseudo-inertias)
               C z ≥ 0                            (rotor inertia, friction ≥ 0; bounding spheres)

The residuals are auxiliary variables (e = A z − a, f = B z − b are equality constraints and the
objective is ‖e‖² + w ‖f‖²): the ill-conditioning of a whitened A (σ of base parameters spanning
eight decades) then sits in the constraint matrix, which Clarabel equilibrates, not in P.
``relaxation`` answers the feasibility question with slacks: the least total relaxation t_k of
each block (S_k + t_k 1 ⪰ 0) and u_i of each inequality ((C z)_i + u_i ≥ 0) with A z = a
exactly.

Clarabel is called directly (PSDTriangleConeT: upper triangle, column by column, off-diagonal
entries × √2): importing cvxpy alone takes ~2 s here, longer than the whole solve; the tests
check this formulation against cvxpy's. Any failure (infeasible, not converged, a solver
exception) is a SolverError with a one-line reason.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
from scipy import sparse

from orthoglide_ident.errors import SolverError

SIDE = 4  # pseudo-inertias are 4×4
SVEC = SIDE * (SIDE + 1) // 2  # 10 entries of the upper triangle
MAX_ITER = 200
SOLVED = ("Solved", "AlmostSolved")
POLISH_SLACK = 1e-6  # the polish keeps ‖A z − a‖² within this fraction of the first solve's


def svec_index() -> list[tuple[int, int]]:
    """(row, column) of each svec entry: the upper triangle column by column (Clarabel's order)."""
    return [(r, c) for c in range(SIDE) for r in range(c + 1)]


def svec(S: np.ndarray) -> np.ndarray:
    """(..., 10) scaled vector of symmetric (..., 4, 4) matrices: off-diagonals × √2."""
    return np.stack([S[..., r, c] * (1.0 if r == c else math.sqrt(2.0)) for r, c in svec_index()],
                    axis=-1)


def smat(v: np.ndarray) -> np.ndarray:
    """The symmetric 4×4 matrix of a scaled vector (inverse of :func:`svec`)."""
    S = np.zeros((SIDE, SIDE))
    for k, (r, c) in enumerate(svec_index()):
        S[r, c] = S[c, r] = v[k] / (1.0 if r == c else math.sqrt(2.0))
    return S


IDENTITY_SVEC = svec(np.eye(SIDE))


@dataclass(frozen=True)
class Block:
    """One LMI: svec(S(z)) = G z[cols] + h ⪰ 0 with G (10, len(cols))."""

    cols: np.ndarray  # indices of the unknowns it involves
    G: np.ndarray
    h: np.ndarray


@dataclass
class ConicAnswer:
    """The solver's answer: ``z`` the unknowns, the slacks when asked, status and cost."""

    z: np.ndarray
    objective: float
    status: str
    iterations: int
    solve_s: float
    t: np.ndarray = field(default_factory=lambda: np.zeros(0))  # block relaxations
    u: np.ndarray = field(default_factory=lambda: np.zeros(0))  # bound relaxations


def _rows(blocks: list[Block], n: int, n_x: int, offset: int = 0,
          relax: int | None = None) -> tuple[sparse.csc_matrix, np.ndarray]:
    """Rows of A x + s = b for the PSD cones: s = G z + h (+ t_k svec(1) at column relax + k)."""
    A = sparse.lil_matrix((SVEC * len(blocks), n_x))
    b = np.empty(SVEC * len(blocks))
    for k, blk in enumerate(blocks):
        r = slice(SVEC * k, SVEC * (k + 1))
        A[r, offset + blk.cols] = -blk.G
        if relax is not None:
            A[r, relax + k] = -IDENTITY_SVEC[:, None]
        b[r] = blk.h
    return A.tocsc(), b


def _solve(P, q, A_parts, b_parts, cones, what: str) -> tuple[np.ndarray, str, int, float]:
    """Run Clarabel; SolverError unless solved."""
    import clarabel

    A = sparse.vstack(A_parts, format="csc")
    b = np.concatenate(b_parts)
    settings = clarabel.DefaultSettings()
    settings.verbose = False
    settings.max_iter = MAX_ITER
    t0 = time.perf_counter()
    try:
        solver = clarabel.DefaultSolver(sparse.csc_matrix(P), q, A, b, cones, settings)
        sol = solver.solve()
    except Exception as exc:  # the solver's own refusal (bad data): one line, not a traceback
        raise SolverError(f"{what}: the conic solver refused the problem "
                          f"({type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''})"
                          ) from None
    status = str(sol.status).split(".")[-1]
    if status not in SOLVED:
        raise SolverError(f"{what}: the conic solver stopped with status {status} after "
                          f"{sol.iterations} iterations ({_meaning(status)})")
    return np.asarray(sol.x), status, int(sol.iterations), time.perf_counter() - t0


def _meaning(status: str) -> str:
    if "Infeasible" in status:
        return "no physically consistent parameters satisfy the constraints"
    if status in ("MaxIterations", "MaxTime", "InsufficientProgress", "NumericalError"):
        return "not converged: the problem is badly scaled or nearly infeasible"
    return "no answer"


def fit(A: np.ndarray, a: np.ndarray, B: np.ndarray, b: np.ndarray, weight: float,
        blocks: list[Block], C: np.ndarray, what: str = "consistency fit",
        polish: bool = True) -> ConicAnswer:
    """argmin ‖A z − a‖² + weight ‖B z − b‖² under the blocks ⪰ 0 and C z ≥ 0.

    With ``polish``, a second solve then takes, among the answers whose ‖A z − a‖² is within
    POLISH_SLACK of the first one's, the nearest to B z = b: the solver's accuracy (~1e-8 of the
    objective) would otherwise leave the unknowns only the prior decides anywhere within
    ~√(1e-8 / weight) of it."""
    import clarabel

    n, m_e, m_f = A.shape[1], A.shape[0], B.shape[0]
    n_x = n + m_e + m_f
    P = sparse.diags(np.concatenate([np.zeros(n), np.full(m_e, 2.0),
                                     np.full(m_f, 2.0 * weight)]))
    eq = sparse.hstack([sparse.csc_matrix(np.vstack([A, B])), -sparse.eye(m_e + m_f)])
    A_psd, b_psd = _rows(blocks, n, n_x)
    k = C.shape[0]
    A_nn = sparse.hstack([sparse.csc_matrix(-C), sparse.csc_matrix((k, m_e + m_f))])
    cones = [clarabel.ZeroConeT(m_e + m_f)]
    if k:
        cones.append(clarabel.NonnegativeConeT(k))
    cones += [clarabel.PSDTriangleConeT(SIDE) for _ in blocks]
    parts = [eq, A_nn, A_psd], [np.concatenate([a, b]), np.zeros(k), b_psd]
    x, status, it, dt = _solve(P, np.zeros(n_x), *parts, cones, what)
    z = x[:n]
    if polish:
        e = A @ z - a
        radius = math.sqrt(float(e @ e) * (1.0 + POLISH_SLACK)) + 1e-12
        # ‖e‖ ≤ radius: s = (radius, e) in a second-order cone
        A_soc = sparse.vstack([sparse.csc_matrix((1, n_x)), sparse.hstack([
            sparse.csc_matrix((m_e, n)), -sparse.eye(m_e), sparse.csc_matrix((m_e, m_f))])])
        P2 = sparse.diags(np.concatenate([np.zeros(n + m_e), np.full(m_f, 2.0)]))
        try:
            x2, status2, it2, dt2 = _solve(
                P2, np.zeros(n_x), parts[0] + [A_soc], parts[1] + [np.r_[radius, np.zeros(m_e)]],
                cones + [clarabel.SecondOrderConeT(m_e + 1)], what + " (nearest the prior)")
            z, it, dt = x2[:n], it + it2, dt + dt2
        except SolverError as exc:  # keep the first answer: consistent, only less polished
            status = f"{status} (not polished: {exc})"
    e, f = A @ z - a, B @ z - b
    return ConicAnswer(z, float(e @ e + weight * (f @ f)), status, it, dt)


def relaxation(A: np.ndarray, a: np.ndarray, B: np.ndarray, b: np.ndarray, weight: float,
               blocks: list[Block], C: np.ndarray,
               what: str = "consistency check") -> ConicAnswer:
    """The least Σ t_k + Σ u_i with A z = a, S_k(z) + t_k 1 ⪰ 0, (C z)_i + u_i ≥ 0, t, u ≥ 0
    (+ weight ‖B z − b‖², a tie-break in A's null space): t_k > 0 says block k could not be
    consistent together with the others while reproducing a exactly."""
    import clarabel

    n, m_e, m_f, n_t, n_u = A.shape[1], A.shape[0], B.shape[0], len(blocks), C.shape[0]
    n_x = n + n_t + n_u + m_f
    P = sparse.diags(np.concatenate([np.zeros(n + n_t + n_u), np.full(m_f, 2.0 * weight)]))
    q = np.concatenate([np.zeros(n), np.ones(n_t + n_u), np.zeros(m_f)])
    eq = sparse.vstack([
        sparse.hstack([sparse.csc_matrix(A), sparse.csc_matrix((m_e, n_t + n_u + m_f))]),
        sparse.hstack([sparse.csc_matrix(B), sparse.csc_matrix((m_f, n_t + n_u)),
                       -sparse.eye(m_f)])], format="csc")
    A_psd, b_psd = _rows(blocks, n, n_x, relax=n)
    A_nn = sparse.hstack([sparse.csc_matrix(-C), sparse.csc_matrix((n_u, n_t)), -sparse.eye(n_u),
                          sparse.csc_matrix((n_u, m_f))])
    k = np.arange(n_t + n_u)
    A_tu = sparse.csc_matrix((-np.ones(n_t + n_u), (k, n + k)), shape=(n_t + n_u, n_x))
    cones = [clarabel.ZeroConeT(m_e + m_f), clarabel.NonnegativeConeT(n_u + n_t + n_u)]
    cones += [clarabel.PSDTriangleConeT(SIDE) for _ in blocks]
    x, status, it, dt = _solve(P, q, [eq, A_nn, A_tu, A_psd],
                               [np.concatenate([a, b]), np.zeros(n_u + n_t + n_u), b_psd],
                               cones, what)
    t, u = x[n:n + n_t], x[n + n_t:n + n_t + n_u]
    return ConicAnswer(x[:n], float(t.sum() + u.sum()), status, it, dt, np.maximum(t, 0.0),
                       np.maximum(u, 0.0))
