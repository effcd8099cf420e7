"""Closed-loop Orthoglide dynamics from Lagrange's equations with automatic differentiation.

Independent of the identification model (orthoglide_ident.model): no Newton-Euler, no regressor,
no Lagrange multipliers. In the reduced coordinates q = (q11, q12, q13) the Lagrangian is the sum,
over every body b of the tree and the platform (+ payload), of

    T_b = 1/2 m v.v + v.(w x MS) + 1/2 w^T I_O w          (all in body-frame coordinates)
    V_b = -g.(m O + R MS)                                  (g = +9.80665 y0)

with v = R^T dO/dt and [w]x = R^T dR/dt obtained by differentiating the body poses of
``kinematics.body_poses`` along qd, plus 1/2 ia q1i_dot^2 for each actuator. Then

    tau = M(q) qdd + (d^2T/dqd dq) qd - dL/dq + J_t^T f(qt_dot),

where f_j = fv_j qt_dot_j + fs_j s(qt_dot_j) + tauoff_j is the friction of every tree joint
(actuated and passive), J_t = d q_t / d q. The identification model uses s = sign; the plant uses a
smooth s(x) = tanh(x / v_s) by default (real drives' Coulomb friction turns smoothly through zero).

Layouts: single-sample functions take q, qd, qdd (3,); the public ``inverse_dynamics`` and
``forward_dynamics`` accept (3,) or (N, 3) arrays.
"""
from __future__ import annotations

from typing import NamedTuple

import jax

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

from orthoglide_sim import kinematics as kin  # noqa: E402
from orthoglide_sim.true_parameters import STANDARD_NAMES, TrueParameters  # noqa: E402


class PlantParams(NamedTuple):
    """Plant parameters as jax arrays (a pytree)."""

    inertial: jnp.ndarray  # (16, 10): leg bodies 1..5 of legs 1..3, then platform + payload
    ia: jnp.ndarray  # (3,) kg
    fv: jnp.ndarray  # (3, 5) per leg, per tree joint 1..5
    fs: jnp.ndarray  # (3, 5)
    tauoff: jnp.ndarray  # (3, 5)
    v_s: jnp.ndarray  # (5,) Coulomb smoothing velocity per joint kind (m/s for 1, rad/s for 2..5)


def _indices() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    idx = {n: k for k, n in enumerate(STANDARD_NAMES)}
    kinds = ("xx", "xy", "xz", "yy", "yz", "zz", "mx", "my", "mz", "m")
    inertial = np.array(
        [[idx[f"{p}_{j}{i}"] for p in kinds] for i in (1, 2, 3) for j in range(1, 6)]
        + [[idx[f"{p}_6"] for p in kinds]]
    )
    ia = np.array([idx[f"ia_1{i}"] for i in (1, 2, 3)])
    fr = [np.array([[idx[f"{p}_{j}{i}"] for j in range(1, 6)] for i in (1, 2, 3)]) for p in ("fv", "fs", "tauoff")]
    return inertial, ia, *fr


_I_INERTIAL, _I_IA, _I_FV, _I_FS, _I_TAUOFF = _indices()


def pack(chi_st, chi_l=None, v_s: tuple[float, float] = (1.0e-3, 5.0e-3)) -> PlantParams:
    """PlantParams from the 208 standard robot parameters and the 10 payload parameters."""
    chi_st = jnp.asarray(chi_st, dtype=jnp.float64)
    inertial = chi_st[_I_INERTIAL]
    if chi_l is not None:
        inertial = inertial.at[15].add(jnp.asarray(chi_l, dtype=jnp.float64))  # body 7 on body 6's frame
    vs = jnp.array([v_s[0], v_s[1], v_s[1], v_s[1], v_s[1]], dtype=jnp.float64)
    return PlantParams(inertial, chi_st[_I_IA], chi_st[_I_FV], chi_st[_I_FS], chi_st[_I_TAUOFF], vs)


def plant_params(tp: TrueParameters, payload: str | float | None = "none") -> PlantParams:
    """PlantParams of the true robot carrying ``payload`` ("none", "1.983", "1.136" or kg)."""
    v_s = (tp.coulomb_velocity["prismatic"], tp.coulomb_velocity["revolute"])
    return pack(tp.standard_vector(), tp.payload_vector(payload), v_s)


def _unskew(S):
    return jnp.stack([S[..., 2, 1], S[..., 0, 2], S[..., 1, 0]], axis=-1)


def kinetic_energy(q, qd, p: PlantParams):
    """T (J) of the whole robot at one state q, qd (3,)."""
    (O, R), (Od, Rd) = jax.jvp(kin.body_poses, (q,), (qd,))
    v = jnp.einsum("bji,bj->bi", R, Od)  # body-frame velocity of the frame origin
    w = _unskew(jnp.einsum("bji,bjk->bik", R, Rd))  # body-frame angular velocity
    I = p.inertial
    Imat = jnp.stack([
        jnp.stack([I[:, 0], I[:, 1], I[:, 2]], -1),
        jnp.stack([I[:, 1], I[:, 3], I[:, 4]], -1),
        jnp.stack([I[:, 2], I[:, 4], I[:, 5]], -1),
    ], axis=-2)
    MS, m = I[:, 6:9], I[:, 9]
    T_bodies = (0.5 * m * jnp.sum(v * v, -1) + jnp.sum(v * jnp.cross(w, MS), -1)
                + 0.5 * jnp.einsum("bi,bij,bj->b", w, Imat, w))
    return jnp.sum(T_bodies) + 0.5 * jnp.sum(p.ia * qd**2)


def potential_energy(q, p: PlantParams):
    """V (J) at q (3,): -g.(m O + R MS) summed over bodies, g = +9.80665 y0."""
    O, R = kin.body_poses(q)
    MS, m = p.inertial[:, 6:9], p.inertial[:, 9]
    first_moment = m[:, None] * O + jnp.einsum("bij,bj->bi", R, MS)
    return -jnp.sum(first_moment @ jnp.asarray(kin.GRAVITY))


def friction_force(q, qd, p: PlantParams, coulomb: str = "smooth"):
    """Generalised friction force J_t^T f (3,) of all 15 tree joints, f acting against q_t."""
    Jt = jax.vmap(lambda e: jax.jvp(kin.tree_joints, (q,), (e,))[1], out_axes=-1)(jnp.eye(3))  # (3, 5, 3)
    qtd = Jt @ qd
    if coulomb == "sign":
        s = jnp.sign(qtd)
    elif coulomb == "smooth":
        s = jnp.tanh(qtd / p.v_s[None, :])
    else:
        raise ValueError(f"coulomb must be 'sign' or 'smooth', got {coulomb!r}")
    f = p.fv * qtd + p.fs * s + p.tauoff
    return jnp.einsum("ijk,ij->k", Jt, f)


def _inertia_matrices(p: PlantParams):
    I = p.inertial
    return jnp.stack([
        jnp.stack([I[:, 0], I[:, 1], I[:, 2]], -1),
        jnp.stack([I[:, 1], I[:, 3], I[:, 4]], -1),
        jnp.stack([I[:, 2], I[:, 4], I[:, 5]], -1),
    ], axis=-2)


def _skew(v):
    z = jnp.zeros_like(v[..., 0])
    return jnp.stack([jnp.stack([z, -v[..., 2], v[..., 1]], -1),
                      jnp.stack([v[..., 2], z, -v[..., 0]], -1),
                      jnp.stack([-v[..., 1], v[..., 0], z], -1)], -2)


def _pose_jacobians(q):
    """Body poses and their derivatives along each q_k: dO (3, 16, 3), dR (3, 16, 3, 3)."""
    def jvp_k(e):
        return jax.jvp(kin.body_poses, (q,), (e,))
    return jax.vmap(jvp_k, out_axes=(None, 0))(jnp.eye(3))


def mass_matrix(q, p: PlantParams):
    """M(q) (3, 3) in kg: the Hessian of T in qd, built from the body velocity Jacobians.

    With v = V qd and w = W qd (body frame; V, W from forward differentiation of the body poses),
    T = 1/2 qd^T [sum_b m V^T V - V^T S W - W^T S^T V + W^T I_O W] qd + 1/2 ia qd^2 with
    S = [MS]x: exactly the ``kinetic_energy`` formula.
    """
    (O, R), (dO, dR) = _pose_jacobians(q)
    V = jnp.einsum("bji,kbj->bik", R, dO)  # (16, 3, 3): body-frame velocity per unit qd_k
    W = jnp.transpose(_unskew(jnp.einsum("bji,kbjl->kbil", R, dR)), (1, 2, 0))  # (16, 3, 3)
    I = p.inertial
    VtSW = jnp.einsum("bij,bjl,blk->bik", jnp.swapaxes(V, 1, 2), _skew(I[:, 6:9]), W)
    Mb = (I[:, 9, None, None] * jnp.einsum("bji,bjk->bik", V, V) - VtSW - jnp.swapaxes(VtSW, 1, 2)
          + jnp.einsum("bji,bjl,blk->bik", W, _inertia_matrices(p), W))
    return jnp.sum(Mb, axis=0) + jnp.diag(p.ia)


def dynamics_terms(q, qd, p: PlantParams, coulomb: str = "smooth"):
    """(M (3, 3), h (3,)) such that tau = M qdd + h at one state (h includes gravity and friction).

    Lagrange's equations with T = 1/2 qd^T M(q) qd + V(q):
    tau = M qdd + (sum_k dM/dq_k qd_k) qd - 1/2 [qd^T dM/dq_k qd]_k + dV/dq + J_t^T f.
    Only forward-mode differentiation (it keeps the compiled plant small and fast).
    """
    def M_of(qq):
        return mass_matrix(qq, p)

    M, dM = jax.jvp(M_of, (q,), (qd,))
    dM_dq = jax.vmap(lambda e: jax.jvp(M_of, (q,), (e,))[1])(jnp.eye(3))  # (k, i, j)
    dV_dq = jax.vmap(lambda e: jax.jvp(lambda qq: potential_energy(qq, p), (q,), (e,))[1])(jnp.eye(3))
    h = dM @ qd - 0.5 * jnp.einsum("kij,i,j->k", dM_dq, qd, qd) + dV_dq + friction_force(q, qd, p, coulomb)
    return M, h


def dynamics_terms_reverse(q, qd, p: PlantParams, coulomb: str = "smooth"):
    """Same as ``dynamics_terms`` straight from ``kinetic_energy`` by reverse mode (slow; for tests)."""
    dT_dqd = jax.grad(kinetic_energy, 1)
    M = jax.jacfwd(dT_dqd, 1)(q, qd, p)
    _, mixed = jax.jvp(lambda qq: dT_dqd(qq, qd, p), (q,), (qd,))  # (d2T/dqd dq) qd
    dT_dq = jax.grad(kinetic_energy, 0)(q, qd, p)
    dV_dq = jax.grad(potential_energy, 0)(q, p)
    h = mixed - dT_dq + dV_dq + friction_force(q, qd, p, coulomb)
    return M, h


def _inverse_one(q, qd, qdd, p, coulomb):
    M, h = dynamics_terms(q, qd, p, coulomb)
    return M @ qdd + h


def _forward_one(q, qd, tau, p, coulomb):
    M, h = dynamics_terms(q, qd, p, coulomb)
    return jnp.linalg.solve(M, tau - h)


_inverse_batch = jax.jit(jax.vmap(_inverse_one, (0, 0, 0, None, None)), static_argnums=4)
_forward_batch = jax.jit(jax.vmap(_forward_one, (0, 0, 0, None, None)), static_argnums=4)


def _as_params(params) -> PlantParams:
    if isinstance(params, PlantParams):
        return params
    if isinstance(params, TrueParameters):
        return plant_params(params)
    chi_st, chi_l = params
    return pack(chi_st, chi_l)


def inverse_dynamics(q, qd, qdd, params, coulomb: str = "smooth") -> np.ndarray:
    """Actuator forces tau (N, 3) in N for states (N, 3) (or (3,) -> (3,)).

    ``params``: PlantParams, TrueParameters (unloaded) or a tuple (chi_st (208,), chi_l (10,)).
    """
    q, qd, qdd = (jnp.asarray(x, dtype=jnp.float64) for x in (q, qd, qdd))
    single = q.ndim == 1
    out = _inverse_batch(jnp.atleast_2d(q), jnp.atleast_2d(qd), jnp.atleast_2d(qdd), _as_params(params), coulomb)
    return np.asarray(out[0] if single else out)


def forward_dynamics(q, qd, tau, params, coulomb: str = "smooth") -> np.ndarray:
    """Actuator accelerations qdd (N, 3) in m/s² under actuator forces tau (N, 3) in N."""
    q, qd, tau = (jnp.asarray(x, dtype=jnp.float64) for x in (q, qd, tau))
    single = q.ndim == 1
    out = _forward_batch(jnp.atleast_2d(q), jnp.atleast_2d(qd), jnp.atleast_2d(tau), _as_params(params), coulomb)
    return np.asarray(out[0] if single else out)


def total_energy(q, qd, p: PlantParams):
    """T + V (J) at one state."""
    return kinetic_energy(q, qd, p) + potential_energy(q, p)


def parameter_regressor(q, qd, qdd):
    """d tau / d chi_st (3N, 208) with sign() friction, rows joint by joint (eq. 20 layout).

    Exact for the plant's own model since tau is linear in the standard parameters; used as a
    stand-in for the identification regressor when optimising trajectories.
    """
    q, qd, qdd = (jnp.atleast_2d(jnp.asarray(x, dtype=jnp.float64)) for x in (q, qd, qdd))
    W = _regressor_batch(q, qd, qdd)  # (N, 3, 208)
    return np.asarray(jnp.transpose(W, (1, 0, 2)).reshape(-1, W.shape[-1]))


def _tau_of_chi(chi, q, qd, qdd):
    return _inverse_one(q, qd, qdd, pack(chi), "sign")


_regressor_batch = jax.jit(jax.vmap(lambda q, qd, qdd: jax.jacfwd(_tau_of_chi)(jnp.zeros(208), q, qd, qdd)))


class Geometry(NamedTuple):
    """Configuration-dependent terms of the Lagrange equations at one q (see ``geometry``)."""

    q: jnp.ndarray  # (3,) where they were evaluated
    M: jnp.ndarray  # (3, 3)
    dM: jnp.ndarray  # (3, 3, 3): dM[k] = dM/dq_k
    g: jnp.ndarray  # (3,) dV/dq
    dg: jnp.ndarray  # (3, 3) d2V/dq2
    Jt: jnp.ndarray  # (3, 5, 3) d q_t / d q
    dJt: jnp.ndarray  # (3, 5, 3, 3): dJt[..., i, k] = d2 q_t / dq_i dq_k


def geometry(q, p: PlantParams) -> Geometry:
    """M, dM/dq, dV/dq, d2V/dq2 and J_t at q (forward-mode differentiation of the exact plant)."""
    def M_of(qq):
        return mass_matrix(qq, p)

    def dV(qq):
        return jax.vmap(lambda e: jax.jvp(lambda x: potential_energy(x, p), (qq,), (e,))[1])(jnp.eye(3))

    eye = jnp.eye(3)
    M, dM = jax.vmap(lambda e: jax.jvp(M_of, (q,), (e,)), out_axes=(None, 0))(eye)
    g, dg = jax.vmap(lambda e: jax.jvp(dV, (q,), (e,)), out_axes=(None, -1))(eye)
    def Jt_of(qq):
        return jax.vmap(lambda e: jax.jvp(kin.tree_joints, (qq,), (e,))[1], out_axes=-1)(eye)

    Jt, dJt = jax.vmap(lambda e: jax.jvp(Jt_of, (q,), (e,)), out_axes=(None, -1))(eye)
    return Geometry(q, M, dM, g, dg, Jt, dJt)


def _solve3(M, b):
    """x = M^-1 b for a 3 x 3 matrix with scalar operations (Cramer's rule, adjugate)."""
    (a, b_, c), (d, e, f), (g, h, i) = [[M[r][s] for s in range(3)] for r in range(3)]
    A = e * i - f * h
    B = -(d * i - f * g)
    C = d * h - e * g
    det = a * A + b_ * B + c * C
    inv = [[A, -(b_ * i - c * h), b_ * f - c * e],
           [B, a * i - c * g, -(a * f - c * d)],
           [C, -(a * h - b_ * g), a * e - b_ * d]]
    return [sum(inv[r][s] * b[s] for s in range(3)) / det for r in range(3)]


def forward_dynamics_local(q, qd, tau, geo: Geometry, p: PlantParams):
    """qdd (list of 3 scalars) near geo.q: M, dV/dq and J_t to first order in q - geo.q, the
    Christoffel terms (dM/dq) frozen. The simulator evaluates ``geometry`` at the middle of each
    1 ms tick, so |q - geo.q| < 0.6 mm and the relative error on qdd is ~1e-5 (see
    tests/test_sim_plant.py). Scalar operations only, so that XLA compiles it into few kernels.
    """
    dq = [q[k] - geo.q[k] for k in range(3)]
    M = [[geo.M[i, j] + sum(geo.dM[k, i, j] * dq[k] for k in range(3)) for j in range(3)] for i in range(3)]
    dMqd = [[sum(geo.dM[k, i, j] * qd[k] for k in range(3)) for j in range(3)] for i in range(3)]
    qdMqd = [sum(qd[i] * geo.dM[k, i, j] * qd[j] for i in range(3) for j in range(3)) for k in range(3)]
    rhs = []
    fr = [0.0, 0.0, 0.0]
    for leg in range(3):
        for joint in range(5):
            J = [geo.Jt[leg, joint, k] + sum(geo.dJt[leg, joint, k, m] * dq[m] for m in range(3))
                 for k in range(3)]
            v = sum(J[k] * qd[k] for k in range(3))
            f = p.fv[leg, joint] * v + p.fs[leg, joint] * jnp.tanh(v / p.v_s[joint]) + p.tauoff[leg, joint]
            for k in range(3):
                fr[k] = fr[k] + J[k] * f
    for i in range(3):
        c = sum(dMqd[i][j] * qd[j] for j in range(3)) - 0.5 * qdMqd[i]
        grav = geo.g[i] + sum(geo.dg[i, k] * dq[k] for k in range(3))
        rhs.append(tau[i] - c - grav - fr[i])
    return _solve3(M, rhs)
