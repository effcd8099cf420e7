"""Orthoglide kinematics: IGM, FGM, passive joints, A_p, B_p, J_p, J_k, J_t (paper eqs. 3-9, 15,
41).

All functions are vectorised over N samples: ``q, qd, qdd`` are (N, 3) arrays (q11, q12, q13) in m,
m/s, m/s²; ``geom`` is the robot's :class:`~geometry.Geometry` (the paper's by default). Leg
quantities are computed in each leg's own frame (geometry.R_LEG), where the three
legs obey the same equations:

    foot point   O_1i = FOOT_OFFSET[i] + q1i z                       (Table 1)
    bar          u_i  = C_i - O_1i = d4 (c2 c3, -s3, -s2 c3)          (eq. 41, leg coordinates)
    bar end      C_i  = R_LEG[i]^T P - d6 z                           (P: platform point)

with q2i, q3i the pivots at the foot and q4i = -q3i, q5i = -q2i the pivots at the platform
(closure f_2i of eq. 41). The tree coordinates of leg i are q_t = (q1i, q2i, q3i, q4i, q5i).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from orthoglide_ident.errors import ModelError, SingularityError, WorkspaceError
from orthoglide_ident.model.orthoglide.geometry import (
    E_AXIS,
    PAPER,
    PARALLEL_MARGIN,
    R_LEG,
    SERIAL_MARGIN,
    Geometry,
)

_Z = np.array([0.0, 0.0, 1.0])


def as_samples(x: np.ndarray, name: str) -> np.ndarray:
    x = np.asarray(x, dtype=float)
    if x.ndim == 1:
        x = x[None, :]
    if x.ndim != 2 or x.shape[1] != 3:
        raise ModelError(f"{name} must have shape (N, 3), got {x.shape}")
    if not np.all(np.isfinite(x)):
        k = int(np.flatnonzero(~np.all(np.isfinite(x), axis=1))[0])
        raise ModelError(f"{name} has a non-finite value at sample {k}: {x[k].tolist()}")
    return x


# R_LEG are cyclic permutations: leg coordinates of a base vector v are v[_TO_LEG[i]].
_TO_LEG = np.array([[0, 1, 2], [1, 2, 0], [2, 0, 1]])
_TO_BASE = np.argsort(_TO_LEG, axis=1)
assert np.allclose(R_LEG[np.arange(3)[:, None], _TO_LEG, np.arange(3)[None, :]], 1.0)


def to_leg(v: np.ndarray) -> np.ndarray:
    """Base-frame vectors (N, 3) -> leg-frame coordinates (N, 3 legs, 3): R_LEG[i]^T v."""
    return v[:, _TO_LEG]


def to_base(u: np.ndarray) -> np.ndarray:
    """Leg-frame vectors (N, 3 legs, 3) -> base coordinates (N, 3 legs, 3): R_LEG[i] u_i."""
    return np.take_along_axis(u, np.broadcast_to(_TO_BASE, u.shape), axis=2)


def inv3(M: np.ndarray) -> np.ndarray:
    """Inverse of stacked 3x3 matrices (..., 3, 3) by cofactors (much faster than batched
    LAPACK)."""
    a, b, c = M[..., 0, 0], M[..., 0, 1], M[..., 0, 2]
    d, e, f = M[..., 1, 0], M[..., 1, 1], M[..., 1, 2]
    g, h, i = M[..., 2, 0], M[..., 2, 1], M[..., 2, 2]
    out = np.empty_like(M)
    out[..., 0, 0], out[..., 0, 1], out[..., 0, 2] = e * i - f * h, c * h - b * i, b * f - c * e
    out[..., 1, 0], out[..., 1, 1], out[..., 1, 2] = f * g - d * i, a * i - c * g, c * d - a * f
    out[..., 2, 0], out[..., 2, 1], out[..., 2, 2] = d * h - e * g, b * g - a * h, a * e - b * d
    det = a * out[..., 0, 0] + b * out[..., 1, 0] + c * out[..., 2, 0]
    return out / det[..., None, None]


def matvec(M: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Stacked M v; explicit sums beat a reduction over a length-3 axis several times over."""
    return M[..., 0] * v[..., None, 0] + M[..., 1] * v[..., None, 1] + M[..., 2] * v[..., None, 2]


def matmat(M: np.ndarray, B: np.ndarray) -> np.ndarray:
    return (
        M[..., :, 0, None] * B[..., None, 0, :]
        + M[..., :, 1, None] * B[..., None, 1, :]
        + M[..., :, 2, None] * B[..., None, 2, :]
    )


def foot_points(q: np.ndarray, geom: Geometry = PAPER) -> np.ndarray:
    """O_1i in leg coordinates, (N, 3 legs, 3)."""
    o = np.broadcast_to(geom.foot_offset, (q.shape[0], 3, 3)).copy()
    o[:, :, 2] += q
    return o


def bar_vectors(q: np.ndarray, P: np.ndarray, geom: Geometry = PAPER) -> np.ndarray:
    """u_i = C_i - O_1i in leg coordinates, (N, 3 legs, 3)."""
    u = to_leg(P) - foot_points(q, geom)
    u[:, :, 2] -= geom.d6
    return u


def fgm(q: np.ndarray, geom: Geometry = PAPER) -> np.ndarray:
    """Forward geometric model: platform point P (N, 3) from q by the three sphere intersections.

    f_p of eq. (41): |P - c_i|² = d4² with c_i = O_1i + d6 e_i. Differences of the spheres give a
    line; the real robot's assembly mode is the intersection on the side of the plane (c_1, c_2,
    c_3)
    that holds P = (0, 0, a) at q = 0.
    """
    q = as_samples(q, "q")
    c = to_base(foot_points(q, geom)) + geom.d6 * E_AXIS  # base coords (N, 3, 3)
    n = np.cross(c[:, 1] - c[:, 0], c[:, 2] - c[:, 0])
    n /= np.sqrt(n[:, 0] ** 2 + n[:, 1] ** 2 + n[:, 2] ** 2)[:, None]
    # Linear part: 2 (c_i - c_1) . P = |c_i|² - |c_1|², i = 2, 3, plus n . P = n . c_1 (a point of
    # the line).
    L = np.stack([2 * (c[:, 1] - c[:, 0]), 2 * (c[:, 2] - c[:, 0]), n], axis=1)
    sq = (c * c).sum(-1)
    h = np.stack([sq[:, 1] - sq[:, 0], sq[:, 2] - sq[:, 0], (n * c[:, 0]).sum(-1)], axis=1)
    P0 = matvec(inv3(L), h)
    # |P0 + t n - c_1|² = d4², with (P0 - c_1) . n = 0 by construction.
    r2 = geom.d4**2 - ((P0 - c[:, 0]) ** 2).sum(-1)
    if np.any(r2 < 0):
        k = int(np.flatnonzero(r2 < 0)[0])
        raise WorkspaceError(
            f"q = {np.round(q[k], 4).tolist()} m (sample {k}) is outside the workspace: "
            "the three legs cannot meet at one platform point"
        )
    P = P0 + np.sqrt(r2)[:, None] * n
    # The real working mode has every bar pointing forward along its actuator (u_i . e_i > 0).
    ahead = bar_vectors(q, P, geom)[:, :, 2]
    if np.any(ahead <= 0):
        k, i = np.argwhere(ahead <= 0)[0]
        raise WorkspaceError(
            f"q = {np.round(q[k], 4).tolist()} m (sample {k}) is outside the workspace: "
            f"leg {i + 1} would have to fold back past its serial singularity"
        )
    return P


def igm(P: np.ndarray, geom: Geometry = PAPER) -> np.ndarray:
    """Inverse geometric model: q (N, 3) from the platform point P (N, 3), real assembly mode."""
    P = as_samples(P, "P")
    Pl = to_leg(P) - geom.foot_offset
    r2 = geom.d4**2 - Pl[:, :, 0] ** 2 - Pl[:, :, 1] ** 2
    if np.any(r2 < 0):
        k = int(np.flatnonzero(np.any(r2 < 0, axis=1))[0])
        raise WorkspaceError(
            f"P = {np.round(P[k], 4).tolist()} m (sample {k}) is out of reach of a leg"
        )
    return Pl[:, :, 2] - geom.d6 - np.sqrt(r2)


def check_regular(q: np.ndarray, u: np.ndarray, U: np.ndarray, d4: float) -> None:
    """Raise SingularityError when a leg or the platform is too close to a singularity.

    Serial (leg) singularity: the bar is perpendicular to its actuator, u_i . e_i -> 0, B_p and J_k
    lose rank. Parallel singularity: the three bars become coplanar, det(A_p) -> 0.
    """
    serial = np.abs(u[:, :, 2]) / d4
    if np.any(serial < SERIAL_MARGIN):
        k, i = np.argwhere(serial < SERIAL_MARGIN)[0]
        raise SingularityError(
            f"q = {np.round(q[k], 4).tolist()} m (sample {k}) is at a serial singularity of leg "
            f"{i + 1}: "
            f"its bar is nearly perpendicular to the actuator (|u.e|/d4 = {serial[k, i]:.3g} < "
            f"{SERIAL_MARGIN})"
        )
    parallel = np.abs(np.linalg.det(U)) / d4**3
    if np.any(parallel < PARALLEL_MARGIN):
        k = int(np.flatnonzero(parallel < PARALLEL_MARGIN)[0])
        raise SingularityError(
            f"q = {np.round(q[k], 4).tolist()} m (sample {k}) is at a parallel singularity: the "
            "three bars are "
            f"nearly coplanar (|det(u_1, u_2, u_3)|/d4³ = {parallel[k]:.3g} < {PARALLEL_MARGIN})"
        )


@dataclass
class TreeState:
    """Platform and virtual-tree coordinates for N samples.

    P, Pd, Pdd: (N, 3) platform point, velocity v and acceleration (eqs. 5-6; D = [I3; 0] here).
    qt, qdt, qddt: (N, 3 legs, 5) tree joints q1i..q5i (eqs. 7-8).
    J_p: (N, 3, 3) with v = J_p qd (eq. 5). J_t: (N, 3 legs, 5, 3) with qdt = J_t qd (eq. 15).
    u: (N, 3 legs, 3) bars in leg coordinates. geom: the dimensions they were computed with.
    """

    P: np.ndarray
    Pd: np.ndarray
    Pdd: np.ndarray
    qt: np.ndarray
    qdt: np.ndarray
    qddt: np.ndarray
    J_p: np.ndarray
    J_t: np.ndarray
    u: np.ndarray
    geom: Geometry = PAPER


def _bar_derivatives(q2: np.ndarray, q3: np.ndarray, d4: float):
    """du/dq2, du/dq3 and the second derivatives of u = d4 (c2 c3, -s3, -s2 c3), each (..., 3)."""
    c2, s2, c3, s3 = np.cos(q2), np.sin(q2), np.cos(q3), np.sin(q3)
    z = np.zeros_like(c2)
    du2 = d4 * np.stack([-s2 * c3, z, -c2 * c3], -1)
    du3 = d4 * np.stack([-c2 * s3, -c3, s2 * s3], -1)
    d22 = d4 * np.stack([-c2 * c3, z, s2 * c3], -1)
    d23 = d4 * np.stack([s2 * s3, z, c2 * s3], -1)
    d33 = d4 * np.stack([-c2 * c3, s3, s2 * c3], -1)
    return du2, du3, d22, d23, d33


def tree_state(q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, check: bool = True,
               geom: Geometry = PAPER) -> TreeState:
    """All platform and tree coordinates, velocities, accelerations and Jacobians from (q, qd,
    qdd)."""
    q, qd, qdd = (as_samples(x, name) for x, name in ((q, "q"), (qd, "qd"), (qdd, "qdd")))
    N = q.shape[0]
    P = fgm(q, geom)
    u = bar_vectors(q, P, geom)  # leg coordinates
    ub = to_base(u)  # base coordinates, rows of A_p / 2
    if check:
        check_regular(q, u, ub, geom.d4)

    # eq. (9) with f_p of eq. (41): A_p = 2 [u_i^T], B_p = diag(-2 u_i . e_i).
    A_p = 2.0 * ub
    B_p = -2.0 * u[:, :, 2]  # diagonal
    A_p_inv = inv3(A_p)
    J_p = -A_p_inv * B_p[:, None, :]  # eq. (5): v = -A_p^-1 B_p qd
    Pd = matvec(J_p, qd)
    # eq. (6): A_p vd = -(A_p' v + B_p qdd + B_p' qd), with A_p' = 2 [ud_i^T], ud_i = v - e_i qd_i.
    ud = Pd[:, None, :] - E_AXIS[None] * qd[:, :, None]  # base coords (N, 3, 3)
    Ad_v = 2.0 * (ud * Pd[:, None, :]).sum(-1)
    Bd_qd = -2.0 * (ud * E_AXIS).sum(-1) * qd
    Pdd = -matvec(A_p_inv, Ad_v + B_p * qdd + Bd_qd)

    # Passive pivots from the bar direction: u/d4 = (c2 c3, -s3, -s2 c3), real mode has c3 > 0.
    s = u / geom.d4
    q3 = np.arcsin(np.clip(-s[:, :, 1], -1.0, 1.0))
    q2 = np.arctan2(-s[:, :, 2], s[:, :, 0])
    du2, du3, d22, d23, d33 = _bar_derivatives(q2, q3, geom.d4)
    # eq. (7) for leg i, position rows: [z, du/dq2, du/dq3] (qd1, qd2, qd3) = R_i^T v   (J_k, J_tk)
    Jk = np.stack([np.broadcast_to(_Z, du2.shape), du2, du3], axis=-1)  # (N, 3, 3 rows, 3 cols)
    Jtk_Jp = J_p[:, _TO_LEG, :]  # R_i^T J_p: (N, 3 legs, 3, 3)
    Jk_inv = inv3(Jk)
    J123 = matmat(Jk_inv, Jtk_Jp)  # d(q1, q2, q3)/dq
    qd123 = matvec(J123, qd[:, None, :])
    # eq. (8): J_k qdd_t = J_tk vd - (dJ_k/dt) qd_t  (J_tk is constant here)
    Pdd_leg = to_leg(Pdd)
    qd2, qd3 = qd123[:, :, 1:2], qd123[:, :, 2:3]
    bias = d22 * qd2**2 + 2 * d23 * qd2 * qd3 + d33 * qd3**2
    qdd123 = matvec(Jk_inv, Pdd_leg - bias)

    # Orientation closure f_2i: q4 = -q3, q5 = -q2 (and their derivatives).
    def five(x1, x2, x3):
        return np.stack([x1, x2, x3, -x3, -x2], axis=2)

    qt = five(q, q2, q3)
    qdt = five(qd123[:, :, 0], qd123[:, :, 1], qd123[:, :, 2])
    qddt = five(qdd123[:, :, 0], qdd123[:, :, 1], qdd123[:, :, 2])
    J_t = np.stack(
        [J123[:, :, 0], J123[:, :, 1], J123[:, :, 2], -J123[:, :, 2], -J123[:, :, 1]], axis=2
    )
    assert J_t.shape == (N, 3, 5, 3)
    return TreeState(P=P, Pd=Pd, Pdd=Pdd, qt=qt, qdt=qdt, qddt=qddt, J_p=J_p, J_t=J_t, u=u,
                     geom=geom)


def loop_closure_residual(q: np.ndarray, P: np.ndarray, qt: np.ndarray,
                          geom: Geometry = PAPER) -> np.ndarray:
    """Residual of the full loop-closure equations f of eqs. (40)-(41), (N, 3 legs, 5).

    f_1i: P - R_0^i (d4 c2 c3 + ..., ...) i.e. the bar end computed from the tree joints must be the
    platform attachment point; f_2i: q2i + q5i and q3i + q4i.
    """
    q2, q3 = qt[:, :, 1], qt[:, :, 2]
    u = geom.d4 * np.stack([np.cos(q2) * np.cos(q3), -np.sin(q3), -np.sin(q2) * np.cos(q3)], -1)
    C_from_tree = foot_points(q, geom) + u + geom.d6 * _Z
    f1 = to_leg(P) - C_from_tree
    f2 = np.stack([q2 + qt[:, :, 4], q3 + qt[:, :, 3]], axis=-1)
    return np.concatenate([f1, f2], axis=-1)
