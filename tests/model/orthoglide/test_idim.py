"""The IDIM against an independent inverse dynamics, and its base parameters against the paper.

The independent reference below shares no code with orthoglide_ident.model: body poses come from a
generic MDH chain (Tables 1-2) fed with the passive angles solved from the platform point,
velocities
and accelerations from jax automatic differentiation of those poses along a trajectory, and joint
efforts from the principle of virtual power with body Jacobians dp/dq.
"""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from orthoglide_ident.errors import ModelError, SingularityError, WorkspaceError
from orthoglide_ident.model.orthoglide.base import base_model, random_states
from orthoglide_ident.model.orthoglide.idim import standard_regressor
from orthoglide_ident.model.orthoglide.kinematics import fgm, igm, loop_closure_residual, tree_state
from orthoglide_ident.model.orthoglide.parameters import N_ST, STANDARD_NAMES

jax.config.update("jax_enable_x64", True)

a, d4, d6, g0 = 0.34, 0.31, 0.03, 9.80665
GRAV = jnp.array([0.0, g0, 0.0])
# Table 1 (with r_13 = q13 - a) and Table 2: (gamma, b, alpha, d, theta_offset, r_offset)
FOOT = [
    (0, 0, 0, 0, 0, 0),
    (np.pi / 2, a, np.pi / 2, 0, 0, -a),
    (0, a, -np.pi / 2, 0, -np.pi / 2, -a),
]
PIVOTS = [(-np.pi / 2, 0.0), (-np.pi / 2, 0.0), (0.0, d4), (np.pi / 2, 0.0)]  # (alpha, d) of 2..5


def mdh(gamma, b, alpha, d, theta, r):
    def rz(t):
        c, s = jnp.cos(t), jnp.sin(t)
        return jnp.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])

    def rx(t):
        c, s = jnp.cos(t), jnp.sin(t)
        return jnp.array([[1, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1.0]])

    def tz(x):
        return jnp.eye(4).at[2, 3].set(x)

    def tx(x):
        return jnp.eye(4).at[0, 3].set(x)

    return rz(gamma) @ tz(b) @ rx(alpha) @ tx(d) @ rz(theta) @ tz(r)


def platform_point(q):
    """Sphere intersection, solved by Newton iterations from the isotropic point (not the closed
    form)."""
    feet = [mdh(*FOOT[i][:4], FOOT[i][4], q[i] + FOOT[i][5]) for i in range(3)]
    c = jnp.stack([T[:3, 3] + d6 * T[:3, 2] for T in feet])
    P = jnp.array([0.0, 0.0, a])
    for _ in range(30):
        f = jnp.sum((P - c) ** 2, axis=1) - d4**2
        P = P - jnp.linalg.solve(2 * (P - c), f)
    return P


def poses(q):
    """4x4 poses of the 15 leg bodies, the tree joint values, and the platform point."""
    P = platform_point(q)
    out, qt = [], []
    for i in range(3):
        T = mdh(*FOOT[i][:4], FOOT[i][4], q[i] + FOOT[i][5])
        u = T[:3, :3].T @ (P - d6 * T[:3, 2] - T[:3, 3]) / d4  # (c2 c3, -s3, -s2 c3)
        q3 = jnp.arcsin(-u[1])
        q2 = jnp.arctan2(-u[2], u[0])
        angles = [q2, q3, -q3, -q2]
        out.append(T)
        for (alpha, d), th in zip(PIVOTS, angles):
            T = T @ mdh(0.0, 0.0, alpha, d, th, 0.0)
            out.append(T)
        qt.append(jnp.stack([q[i], *angles]))
    return out, jnp.stack(qt), P


def reference_tau(q, qd, qdd, chi, chi_payload):
    """Inverse dynamics by virtual power: tau = sum_k J_k^T [F_k; N_k] + J_t^T f_friction."""
    q, qd, qdd = map(jnp.asarray, (q, qd, qdd))

    def along(t):
        return poses(q + t * qd + 0.5 * t**2 * qdd)

    (T, qt, P) = along(0.0)
    dT, dqt, dP = jax.jacfwd(along)(0.0)
    ddT, _, ddP = jax.jacfwd(jax.jacfwd(along))(0.0)
    J_T, J_qt, J_P = jax.jacfwd(lambda x: poses(x))(q)  # d/dq of every pose: body Jacobians
    tau = jnp.zeros(3)
    k = 0
    for i in range(3):
        for body in range(1, 6):
            R, Rd, Rdd = T[k][:3, :3], dT[k][:3, :3], ddT[k][:3, :3]
            W = Rd @ R.T
            w = jnp.array([W[2, 1], W[0, 2], W[1, 0]])
            Wd = Rdd @ R.T + Rd @ Rd.T  # d/dt (Rd R^T)
            wd = jnp.array([Wd[2, 1], Wd[0, 2], Wd[1, 0]])
            acc = ddT[k][:3, 3]
            base = (i * 66) + (0 if body == 1 else 14 + 13 * (body - 2))
            xx, xy, xz, yy, yz, zz, mx, my, mz, m = [chi[base + n] for n in range(10)]
            I = jnp.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
            MS = jnp.array([mx, my, mz])
            wb, wdb, vdb = R.T @ w, R.T @ wd, R.T @ (acc - GRAV)
            F = m * vdb + jnp.cross(wdb, MS) + jnp.cross(wb, jnp.cross(wb, MS))
            N = I @ wdb + jnp.cross(wb, I @ wb) + jnp.cross(MS, vdb)
            Jv = J_T[k][:3, 3, :]  # dO/dq
            Jw = jnp.stack([(J_T[k][:3, :3, c] @ R.T) for c in range(3)])  # skew(w) per unit qd_c
            Jw = jnp.stack([Jw[:, 2, 1], Jw[:, 0, 2], Jw[:, 1, 0]], axis=0)  # (3 components, 3 qd)
            tau = tau + Jv.T @ (R @ F) + Jw.T @ (R @ N)
            # joint friction and drive inertia of tree joint (i, body)
            extra = chi[base + 10 : base + (14 if body == 1 else 13)]
            if body == 1:
                ia, fv, fs, off = extra
                tau = tau.at[i].add(ia * qdd[i])
            else:
                fv, fs, off = extra
            v = dqt[i, body - 1]
            tau = tau + J_qt[i, body - 1] * (fv * v + fs * jnp.sign(v) + off)
            k += 1
    m_pl = chi[N_ST - 1] + chi_payload[9]
    return tau + J_P.T @ (m_pl * (ddP - GRAV))


def random_physical(seed):
    rng = np.random.default_rng(seed)
    return rng.normal(size=N_ST), rng.normal(size=10)


def test_idim_matches_independent_virtual_power():
    q, qd, qdd = random_states(6, seed=3)
    qd = qd * 0.5 + np.sign(qd) * 0.3  # keep every tree joint away from zero velocity (sign())
    chi, chi_l = random_physical(4)
    W, W_l = standard_regressor(q, qd, qdd)
    tau_model = (W @ chi + W_l @ chi_l).reshape(3, -1).T
    ref_fn = jax.jit(reference_tau)
    for n in range(q.shape[0]):
        ref = np.asarray(ref_fn(q[n], qd[n], qdd[n], jnp.asarray(chi), jnp.asarray(chi_l)))
        assert np.max(np.abs(tau_model[n] - ref)) <= 1e-8 * np.max(np.abs(ref)), (
            n,
            tau_model[n],
            ref,
        )


def test_kinematics_consistent_and_loops_closed():
    q, qd, qdd = random_states(50, seed=5)
    s = tree_state(q, qd, qdd)
    assert np.max(np.abs(igm(s.P) - q)) < 1e-12
    assert np.max(np.abs(loop_closure_residual(q, s.P, s.qt))) < 1e-12  # eqs. (40)-(41)
    # velocities and accelerations are the time derivatives of positions (central differences)
    h = 1e-5
    sp = tree_state(q + h * qd + 0.5 * h * h * qdd, qd + h * qdd, qdd)
    sm = tree_state(q - h * qd + 0.5 * h * h * qdd, qd - h * qdd, qdd)
    np.testing.assert_allclose((sp.P - sm.P) / (2 * h), s.Pd, atol=1e-7)
    np.testing.assert_allclose((sp.qt - sm.qt) / (2 * h), s.qdt, atol=1e-6)
    np.testing.assert_allclose((sp.qdt - sm.qdt) / (2 * h), s.qddt, atol=1e-4)
    assert np.allclose(fgm(np.zeros(3)), [0.0, 0.0, 0.34])


def test_base_regressor_reproduces_standard_model():
    bm = base_model()
    q, qd, qdd = random_states(200, seed=11)
    chi, _ = random_physical(12)
    W_st, W_l = standard_regressor(q, qd, qdd)
    W_b, w_m7 = bm.observation(q, qd, qdd)
    np.testing.assert_allclose(
        W_b @ bm.base_values(chi), W_st @ chi, rtol=0, atol=1e-9 * np.abs(W_st @ chi).max()
    )
    np.testing.assert_allclose(w_m7, W_l[:, 9])
    np.testing.assert_allclose(bm.regressor(q, qd, qdd), W_b)


def test_base_parameters_are_symmetric_and_match_the_paper():
    bm = base_model()
    expr = dict(zip(bm.names, bm.expressions))
    assert bm.n_b == 61
    # The list after Table 3 (i = 1, 2, 3), 0.31 = d4, 3.2258 = 1/d4, 0.10197 = 1/g.
    for i in (1, 2, 3):
        assert expr[f"zz_2{i}R"] == f"zz_2{i} + yy_3{i} - 0.31 mx_3{i} + yy_4{i}"
        assert expr[f"my_2{i}R"] == f"my_2{i} + mz_3{i} + mz_4{i}"
        assert expr[f"fv_2{i}R"] == f"fv_2{i} + fv_5{i}"
        assert expr[f"fs_2{i}R"] == f"fs_2{i} + fs_5{i}"
        assert expr[f"tauoff_2{i}R"] == f"tauoff_2{i} - tauoff_5{i}"
        assert expr[f"xx_3{i}R"] == f"xx_3{i} - yy_3{i} + 0.31 mx_3{i}"
        assert expr[f"fv_3{i}R"] == f"fv_3{i} + fv_4{i}"
        assert expr[f"fs_3{i}R"] == f"fs_3{i} + fs_4{i}"
        assert expr[f"tauoff_3{i}R"] == f"tauoff_3{i} - tauoff_4{i}"
        # Paper misprint: printed "zz_3iR = xz_3i - 0.31 mz_4i"; that is xz_3iR ...
        assert expr[f"xz_3{i}R"] == f"xz_3{i} - 0.31 mz_4{i}"
        # ... and the regrouping of zz_3i itself is missing from the paper's list.
        assert expr[f"zz_3{i}R"] == f"zz_3{i} - 0.31 mx_3{i}"
    for j in (1, 2):
        assert expr[f"m_1{j}R"] == f"m_1{j} + ia_1{j} + m_2{j} - 3.2258 mx_3{j} + m_3{j}"
    # Paper misprint: "m_13R = m_13 - 0.10197 tauoff_13 + m_23 - 3.2258 mx_23 + m_23" repeats m_23.
    assert expr["m_13R"] == "m_13 - 0.10197 tauoff_13 + m_23 - 3.2258 mx_33 + m_33"
    assert expr["ia_13R"] == "ia_13 + 0.10197 tauoff_13"
    assert expr["m_6R"] == (
        "m_6 + 3.2258 mx_31 + 3.2258 mx_32 + 3.2258 mx_33 + m_41 + m_42 + m_43 + m_51 + m_52 + m_53"
    )
    # Symmetry (eq. 23): every leg parameter has the same form on the three legs, except the
    # vertical leg 3's foot (gravity regroups tauoff_13 into m_13R and ia_13R).
    for p in bm.parameters:
        if p.legs and not p.standard.startswith(("m_1", "ia_1", "tauoff_1")):
            assert p.legs == (1, 2, 3), p
    assert "tauoff_13" not in bm.names and "ia_11R" not in bm.names


def test_bad_states_get_clear_errors():
    with pytest.raises(WorkspaceError, match="outside the workspace"):
        fgm(np.array([[-0.5, -0.5, -0.5]]))  # the legs cannot meet
    with pytest.raises(WorkspaceError, match="fold back past its serial singularity"):
        fgm(np.array([[0.55, 0.55, 0.55]]))  # only the other working mode exists
    with pytest.raises(SingularityError, match="serial singularity of leg 1"):
        tree_state(np.full((1, 3), 0.52), np.zeros((1, 3)), np.zeros((1, 3)))
    with pytest.raises(WorkspaceError, match="out of reach"):
        igm(np.array([[0.0, 0.0, 1.5]]))
    # near the parallel singularity: all feet retracted, the bars fold towards one plane
    with pytest.raises(SingularityError, match="parallel singularity"):
        tree_state(np.full((1, 3), -0.06965), np.zeros((1, 3)), np.zeros((1, 3)))
    with pytest.raises(ModelError, match="non-finite"):
        standard_regressor(np.array([[np.nan, 0, 0]]), np.zeros((1, 3)), np.zeros((1, 3)))
    with pytest.raises(ModelError, match="shape"):
        standard_regressor(np.zeros((4, 2)), np.zeros((4, 2)), np.zeros((4, 2)))


def test_parameter_count_and_names():
    assert N_ST == 208 and len(set(STANDARD_NAMES)) == 208
    assert STANDARD_NAMES[:3] == ("xx_11", "xy_11", "xz_11") and STANDARD_NAMES[-1] == "m_6"
