"""The simulator's own Orthoglide kinematics, in numpy (independent of orthoglide_ident.model).

Forward geometric model by intersecting the three spheres |P - S_i| = d4 in closed form
(S_i = O_1i + d6 e_i), passive pivot angles from the bar direction, and their first time
derivatives in closed form. Every function takes actuator positions ``q: (..., 3)`` (m) and is
vectorised over the leading dimensions. The simulator uses ``tree_state`` to put its Pinocchio tree
(15 joints) exactly on the closed-loop manifold once per tick.
"""
from __future__ import annotations

import numpy as np

from orthoglide_ident.errors import WorkspaceError

A = 0.34  # m
D4 = 0.31  # m
D6 = 0.03  # m
G0 = 9.80665  # m/s², gravity acceleration directed along +y0 (Sect. 5.1)
GRAVITY = np.array([0.0, G0, 0.0])

# Actuator axes e_i (base coordinates) and the constant part of the foot origins, from Table 1:
# O_11 = (0, 0, q11), O_12 = (q12 - a, 0, a), O_13 = (0, q13 - a, a).
E_AXIS = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
FOOT_BASE = np.array([[0.0, 0.0, 0.0], [-A, 0.0, A], [0.0, -A, A]])
# Foot frames 1_i (columns x_1i, y_1i, z_1i in base coordinates): cyclic permutations of the base.
R_FOOT = np.array([np.eye(3), [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
                   [[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]])


def sphere_centres(q: np.ndarray) -> np.ndarray:
    """S_i = O_1i + d6 e_i (..., 3 legs, 3): P lies at d4 from each (reduced closure eq. 41)."""
    q = np.asarray(q, dtype=float)
    return FOOT_BASE + (q[..., :, None] + D6) * E_AXIS


def platform_position(q: np.ndarray) -> np.ndarray:
    """P (..., 3) from eq. (41): the point at distance d4 from S_1, S_2, S_3.

    The three spheres have the same radius, so P lies on the normal to the plane S_1 S_2 S_3 through
    its circumcentre, on the side that puts P at (0, 0, a) for q = 0. Raises WorkspaceError where
    the spheres do not meet.
    """
    S = sphere_centres(q)
    b = S[..., 1, :] - S[..., 0, :]
    c = S[..., 2, :] - S[..., 0, :]
    n = np.cross(b, c)
    nn = np.sum(n * n, axis=-1, keepdims=True)
    cc = S[..., 0, :] + (np.sum(b * b, -1, keepdims=True) * np.cross(c, n)
                         + np.sum(c * c, -1, keepdims=True) * np.cross(n, b)) / (2.0 * nn)
    h2 = D4**2 - np.sum((cc - S[..., 0, :]) ** 2, axis=-1, keepdims=True)
    unreachable = ~(h2[..., 0] > 0.0)
    if np.any(unreachable):
        bad = (
            np.asarray(q, dtype=float)[unreachable]
            if unreachable.ndim
            else np.asarray(q, dtype=float)
        )
        raise WorkspaceError(
            f"no assembly at q = {np.round(np.reshape(bad, (-1, 3))[0], 4).tolist()} m: "
            "the legs cannot reach a common platform position"
        )
    return cc + np.sqrt(h2) * n / np.sqrt(nn)


def bar_directions(q: np.ndarray, P: np.ndarray | None = None) -> np.ndarray:
    """Unit bar vectors u_i = (C_i - O_1i) / d4 = (P - S_i) / d4 (..., 3 legs, 3), base frame."""
    P = platform_position(q) if P is None else P
    return (P[..., None, :] - sphere_centres(q)) / D4


def platform_velocity(q: np.ndarray, qd: np.ndarray, P: np.ndarray | None = None) -> np.ndarray:
    """dP/dt (..., 3) = J_p qd with A_p dP/dt + B_p qd = 0 (time derivative of eq. 41)."""
    u = bar_directions(q, P)
    rhs = np.asarray(qd, dtype=float) * np.sum(u * E_AXIS, axis=-1)  # u_i . e_i qd_i
    return np.linalg.solve(u, rhs[..., None])[..., 0]


def _foot_coordinates(u: np.ndarray) -> np.ndarray:
    """Bar directions in the foot frames: u~_i = R_1i^T u_i (..., 3, 3)."""
    return np.einsum("iab,...ia->...ib", R_FOOT, u)


def tree_state(q: np.ndarray, qd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """All tree joint positions and velocities on the closed loop: (q_t, qd_t), each (..., 3, 5).

    Row i = leg i: (q1i, q2i, q3i, q4i, q5i) in m and rad. In frame 1_i the bar is
    d4 (cos q2 cos q3, -sin q3, -sin q2 cos q3) (eq. 41), q2i = -pi/2, q3i = 0 at q = 0, and the
    orientation closure gives q4i = -q3i, q5i = -q2i.
    """
    q, qd = np.asarray(q, dtype=float), np.asarray(qd, dtype=float)
    P = platform_position(q)
    u = bar_directions(q, P)
    ud = (platform_velocity(q, qd, P)[..., None, :] - qd[..., :, None] * E_AXIS) / D4
    w, wd = _foot_coordinates(u), _foot_coordinates(ud)
    q3 = np.arcsin(-w[..., 1])
    q2 = np.arctan2(-w[..., 2], w[..., 0])
    q3d = -wd[..., 1] / np.cos(q3)
    q2d = (w[..., 2] * wd[..., 0] - w[..., 0] * wd[..., 2]) / (w[..., 0] ** 2 + w[..., 2] ** 2)
    qt = np.stack([q, q2, q3, -q3, -q2], axis=-1)
    qtd = np.stack([qd, q2d, q3d, -q3d, -q2d], axis=-1)
    return qt, qtd


def singularity_margins(q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Dimensionless distances to singularity at q (..., 3): (min_i |u_i . e_i|, |det(u_1, u_2,
    u_3)|,
    1/cond(J_p)).

    - serial (leg) singularity: a bar perpendicular to its actuator <=> u_i . e_i -> 0;
    - parallel singularity: the three bars coplanar <=> det(A_p) -> 0.
    """
    u = bar_directions(q)
    serial = np.min(np.abs(np.sum(u * E_AXIS, axis=-1)), axis=-1)
    parallel = np.abs(np.linalg.det(u))
    Jp = np.linalg.solve(u, np.sum(u * E_AXIS, axis=-1)[..., :, None] * np.eye(3))
    s = np.linalg.svd(Jp, compute_uv=False)
    return serial, parallel, s[..., -1] / s[..., 0]
