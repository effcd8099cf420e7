"""The simulator's own Orthoglide kinematics, in jax (independent of orthoglide_ident.model).

Forward geometric model by intersecting the three spheres |C_i - O_1i| = d4 in closed form, passive
pivot angles from the bar direction, then every body frame's pose from the MDH transforms of
docs/conventions.md. All functions take one configuration ``q: (3,)`` (m) and are jit/vmap-able.
"""
from __future__ import annotations

import jax

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

A = 0.34  # m
D4 = 0.31  # m
D6 = 0.03  # m
G0 = 9.80665  # m/s², gravity acceleration directed along +y0 (Sect. 5.1)
GRAVITY = np.array([0.0, G0, 0.0])

# Actuator axes e_i (base coordinates) and the constant part of the foot origins, from Table 1:
# O_11 = (0, 0, q11), O_12 = (q12 - a, 0, a), O_13 = (0, q13 - a, a).
E_AXIS = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
FOOT_BASE = np.array([[0.0, 0.0, 0.0], [-A, 0.0, A], [0.0, -A, A]])


def _rot_x(t):
    c, s = jnp.cos(t), jnp.sin(t)
    one, zero = jnp.ones_like(t), jnp.zeros_like(t)
    return jnp.array([[one, zero, zero], [zero, c, -s], [zero, s, c]])


def _rot_z(t):
    c, s = jnp.cos(t), jnp.sin(t)
    one, zero = jnp.ones_like(t), jnp.zeros_like(t)
    return jnp.array([[c, -s, zero], [s, c, zero], [zero, zero, one]])


def mdh(gamma, b, alpha, d, theta, r):
    """Homogeneous transform Rot(z,gamma) Trans(z,b) Rot(x,alpha) Trans(x,d) Rot(z,theta) Trans(z,r)."""
    gamma, b, alpha, d, theta, r = (jnp.asarray(v, dtype=jnp.float64) for v in (gamma, b, alpha, d, theta, r))

    def h(R, p):
        return jnp.block([[R, p[:, None]], [jnp.zeros((1, 3)), jnp.ones((1, 1))]])

    z, e_z, e_x = jnp.zeros(3), jnp.array([0.0, 0.0, 1.0]), jnp.array([1.0, 0.0, 0.0])
    return (h(_rot_z(gamma), z) @ h(jnp.eye(3), b * e_z) @ h(_rot_x(alpha), z)
            @ h(jnp.eye(3), d * e_x) @ h(_rot_z(theta), z) @ h(jnp.eye(3), r * e_z))


def foot_transforms(q):
    """(3, 4, 4) transforms of frames 1_1, 1_2, 1_3 in the base frame (Table 1, r of 1_3 = q13 - a)."""
    hp = jnp.pi / 2
    return jnp.stack([
        mdh(0.0, 0.0, 0.0, 0.0, 0.0, q[0]),
        mdh(hp, A, hp, 0.0, 0.0, q[1] - A),
        mdh(0.0, A, -hp, 0.0, -hp, q[2] - A),
    ])


def platform_position(q):
    """P (3,) from the reduced loop closure eq. (41): P is at distance d4 from S_i = O_1i + d6 e_i.

    The three spheres have the same radius, so P lies on the normal to the plane S_1 S_2 S_3 through
    its circumcentre, on the side that puts P at (0, 0, a) for q = 0.
    """
    S = FOOT_BASE + q[:, None] * E_AXIS + D6 * E_AXIS
    b = S[1] - S[0]
    c = S[2] - S[0]
    n = jnp.cross(b, c)
    nn = n @ n
    cc = S[0] + (jnp.dot(b, b) * jnp.cross(c, n) + jnp.dot(c, c) * jnp.cross(n, b)) / (2.0 * nn)
    rho2 = jnp.sum((cc - S[0]) ** 2)
    h = jnp.sqrt(D4**2 - rho2)
    return cc + h * n / jnp.sqrt(nn)


def passive_angles(q):
    """(q2i, q3i) for i = 1..3 as a (3, 2) array, from the bar direction in each foot frame.

    The bar C_i - O_1i, in frame 1_i, is d4 (cos q2 cos q3, -sin q3, -sin q2 cos q3) (eq. 41), with
    q2 = -pi/2, q3 = 0 in the isotropic configuration.
    """
    P = platform_position(q)
    O1 = FOOT_BASE + q[:, None] * E_AXIS
    C = P[None, :] - D6 * E_AXIS
    u = jnp.einsum("iab,ia->ib", jnp.asarray(R_FOOT), C - O1) / D4
    q3 = jnp.arcsin(-u[:, 1])
    q2 = jnp.arctan2(-u[:, 2], u[:, 0])
    return jnp.stack([q2, q3], axis=1)


def tree_joints(q):
    """All tree joint coordinates (3 legs, 5 joints): q_t[i] = (q1i, q2i, q3i, q4i, q5i) (m, rad).

    Orientation closure: q4i = -q3i, q5i = -q2i.
    """
    pa = passive_angles(q)
    return jnp.stack([q, pa[:, 0], pa[:, 1], -pa[:, 1], -pa[:, 0]], axis=1)


R_FOOT = np.array([np.eye(3), [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
                   [[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]])  # columns x_1i, y_1i, z_1i
_RX_MINUS = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])  # Rot(x, -pi/2)
_RX_PLUS = _RX_MINUS.T  # Rot(x, pi/2)


def _rot_z_batch(t):
    c, s = jnp.cos(t), jnp.sin(t)
    o, z = jnp.ones_like(t), jnp.zeros_like(t)
    return jnp.stack([jnp.stack([c, -s, z], -1), jnp.stack([s, c, z], -1), jnp.stack([z, z, o], -1)], -2)


def body_poses(q):
    """Origins O (16, 3) and rotations R (16, 3, 3) of bodies in base coordinates.

    Order: leg 1 bodies 1..5, leg 2 bodies 1..5, leg 3 bodies 1..5, platform 6 (frame parallel to
    the base at P). R maps body-frame coordinates to base coordinates. The MDH chain of Table 2
    (d = r = 0 except d4) is applied to the three legs at once; ``body_poses_mdh`` is the same
    thing with the generic transform, kept to check this one.
    """
    P = platform_position(q)
    O1 = FOOT_BASE + q[:, None] * E_AXIS
    C = P[None, :] - D6 * E_AXIS
    R1 = jnp.asarray(R_FOOT)
    u = jnp.einsum("iab,ia->ib", R1, C - O1) / D4
    q3 = jnp.arcsin(-u[:, 1])
    q2 = jnp.arctan2(-u[:, 2], u[:, 0])
    R2 = R1 @ _RX_MINUS @ _rot_z_batch(q2)
    R3 = R2 @ _RX_MINUS @ _rot_z_batch(q3)
    R4 = R3 @ _rot_z_batch(-q3)
    R5 = R4 @ _RX_PLUS @ _rot_z_batch(-q2)
    O4 = O1 + D4 * R3[:, :, 0]
    O = jnp.stack([O1, O1, O1, O4, O4], axis=1).reshape(15, 3)
    R = jnp.stack([R1, R2, R3, R4, R5], axis=1).reshape(15, 3, 3)
    return jnp.concatenate([O, P[None, :]]), jnp.concatenate([R, jnp.eye(3)[None]])


def body_poses_mdh(q):
    """Same as ``body_poses`` with the generic MDH transform of docs/conventions.md (slow; for tests)."""
    qt = tree_joints(q)
    T1 = foot_transforms(q)
    hp = jnp.pi / 2
    Os, Rs = [], []
    for i in range(3):
        T = T1[i]
        frames = [T]
        T = T @ mdh(0.0, 0.0, -hp, 0.0, qt[i, 1], 0.0)
        frames.append(T)
        T = T @ mdh(0.0, 0.0, -hp, 0.0, qt[i, 2], 0.0)
        frames.append(T)
        T = T @ mdh(0.0, 0.0, 0.0, D4, qt[i, 3], 0.0)
        frames.append(T)
        T = T @ mdh(0.0, 0.0, hp, 0.0, qt[i, 4], 0.0)
        frames.append(T)
        for F in frames:
            Os.append(F[:3, 3])
            Rs.append(F[:3, :3])
    Os.append(platform_position(q))
    Rs.append(jnp.eye(3))
    return jnp.stack(Os), jnp.stack(Rs)


def closure_matrices(q):
    """A_p = df_p/dP and B_p = df_p/dq of eq. (41) at q (3 x 3 each)."""
    P = platform_position(q)

    def f_p(P, q):
        S = FOOT_BASE + q[:, None] * E_AXIS + D6 * E_AXIS
        return jnp.sum((P[None, :] - S) ** 2, axis=1) - D4**2

    return jax.jacfwd(f_p, 0)(P, q), jax.jacfwd(f_p, 1)(P, q)


def singularity_margins(q):
    """Dimensionless distances to singularity: (cos q3i min, |det(u1,u2,u3)|, 1/cond(J_p)).

    - serial (leg) singularity: a bar perpendicular to its actuator <=> u_i . e_i -> 0, i.e.
      cos q2i cos q3i -> 0 (also J_k loses rank when cos q3i -> 0);
    - parallel singularity: the three bars coplanar <=> det(A_p) -> 0.
    """
    P = platform_position(q)
    S = FOOT_BASE + q[:, None] * E_AXIS + D6 * E_AXIS
    u = (P[None, :] - S) / D4
    serial = jnp.min(jnp.abs(jnp.sum(u * E_AXIS, axis=1)))
    parallel = jnp.abs(jnp.linalg.det(u))
    Ap, Bp = closure_matrices(q)
    Jp = -jnp.linalg.solve(Ap, Bp)
    s = jnp.linalg.svd(Jp, compute_uv=False)
    return serial, parallel, s[-1] / s[0]
