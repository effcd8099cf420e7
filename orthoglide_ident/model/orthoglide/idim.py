"""Inverse dynamic identification model of the Orthoglide, standard parameters (eqs. 1-2, 15, 18).

Step 1 (Sect. 2.2): the virtual tree, 3 legs x 5 joints, by Newton-Euler in MDH frames. For each
body k of a leg the wrench at its frame origin, in its frame, is linear in its 10 inertial
parameters (Khalil & Dombre):

    F_k = m v'_k + (w'_k x + w_k x w_k x) MS_k
    N_k = I_k w'_k + w_k x (I_k w_k) + MS_k x v'_k          (v'_k includes -g)

and tree joint j carries the projection of the wrenches of the bodies it supports:
tau_t,j = a . N_k + (a x r) . F_k (revolute) or a . F_k (prismatic), with a the joint axis and r the
vector O_j -> O_k, both in frame k. Joint friction and drive inertia act on the joint itself.

Step 2 (Sect. 2.3): the loops are closed with tau = J_t^T tau_t + J_p^T D^T tau_p, eq. (15),
evaluated body by body as (S_k J_t)^T Phi_k, S_k stacking the joint projections above. The platform
(body 6) and the payload (body 7) only translate, so with D = [I3; 0] only their masses act:
tau_p = m (P'' - g).

For speed over 10^5 samples every vector is stored component-first, (3, N), and each body
contributes only the columns asked for. Rows of the returned matrices are stacked joint by joint
(eq. 20): (3 N, n).
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from orthoglide_ident.model.orthoglide.geometry import PAPER, Geometry
from orthoglide_ident.model.orthoglide.kinematics import TreeState, as_samples, tree_state
from orthoglide_ident.model.orthoglide.leg_closed_form import (
    closed_form_columns,
    has_closed_form,
    leg_state,
)
from orthoglide_ident.model.orthoglide.parameters import LEG_PARAMETERS, N_LEGS, N_ST, N_ST_LEG

_ALPHA = {2: -np.pi / 2, 3: -np.pi / 2, 4: 0.0, 5: np.pi / 2}  # MDH alpha of frames 2..5 (Table 2)
_INERTIA = ("xx", "xy", "xz", "yy", "yz", "zz")
_MS = ("mx", "my", "mz")


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.stack(
        [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
    )


def _in_frame(R: tuple[np.ndarray, np.ndarray, np.ndarray], v: np.ndarray) -> np.ndarray:
    """Coordinates in frame R = (x, y, z axes, each (3, N)) of the leg-frame vector v (3, N)."""
    return np.stack([_dot(R[0], v), _dot(R[1], v), _dot(R[2], v)])


def _child_frame(R, alpha: float, theta: np.ndarray):
    """Axes of frame k from those of frame k-1: R_k = R_k-1 Rot(x, alpha) Rot(z, theta)."""
    x, y, z = R
    if alpha < 0:  # -pi/2
        y, z = -z, y
    elif alpha > 0:  # +pi/2
        y, z = z, -y
    c, s = np.cos(theta), np.sin(theta)
    return (c * x + s * y, -s * x + c * y, z)


def _inertia_column(w: np.ndarray, kind: str) -> np.ndarray:
    """Column of L(w) with I w = L(w) [xx xy xz yy yz zz]."""
    z = np.zeros_like(w[0])
    return {
        "xx": (w[0], z, z),
        "xy": (w[1], w[0], z),
        "xz": (w[2], z, w[0]),
        "yy": (z, w[1], z),
        "yz": (z, w[2], w[1]),
        "zz": (z, z, w[2]),
    }[kind]


def _wrench(kind: str, w: np.ndarray, wd: np.ndarray, vd: np.ndarray):
    """(F, N) at the frame origin for a unit value of inertial parameter ``kind`` (None = zero)."""
    if kind in _INERTIA:
        Lwd, Lw = np.stack(_inertia_column(wd, kind)), np.stack(_inertia_column(w, kind))
        return None, Lwd + _cross(w, Lw)
    if kind in _MS:
        e = np.zeros((3,) + (1,) * (w.ndim - 1))
        e[_MS.index(kind)] = 1.0
        return _cross(wd, e) + _cross(w, _cross(w, e)), _cross(e, vd)
    return vd, None  # mass


def _leg_recursion(state: TreeState, qt, qdt, qddt, frame1: tuple) -> tuple:
    """Forward recursion in leg coordinates (body 1, the foot, only translates along z):
    per body its frame R, angular velocity w and acceleration wd, origin acceleration acc, and
    r_bar = O_4 - O_1 = d4 x_3. Every array (3, 3 legs, N)."""
    ez = frame1[2]
    zero = np.zeros_like(ez)
    R = [frame1]
    w, wd, acc = [zero], [zero], [ez * qddt[0]]
    r_bar = None
    for k in range(2, 6):
        Rk = _child_frame(R[-1], _ALPHA[k], qt[k - 1])
        zk = Rk[2]
        if k == 4:
            r_bar = state.geom.d4 * R[-1][0]
            acc.append(acc[-1] + _cross(wd[-1], r_bar) + _cross(w[-1], _cross(w[-1], r_bar)))
        else:
            acc.append(acc[-1])
        w.append(w[-1] + zk * qdt[k - 1])
        wd.append(wd[-1] + zk * qddt[k - 1] + _cross(w[-2], zk * qdt[k - 1]))
        R.append(Rk)
    return R, w, wd, acc, r_bar


def _body_jacobian(k: int, R: list, r_bar, J_t: np.ndarray, shape: tuple) -> tuple[list, list]:
    """Body k's Jacobian G_k = S_k J_t in its own frame: (F part, N part) per actuator c, each
    (3, 3 legs, N)."""
    Rk = R[k - 1]
    GF = [np.zeros((3,) + shape) for _ in range(3)]
    GN = [np.zeros((3,) + shape) for _ in range(3)]
    for j in range(1, k + 1):
        if j == 1:
            sF, sN = _in_frame(Rk, R[0][2]), None
        else:
            axis_j = _in_frame(Rk, R[j - 1][2])
            sF = _cross(axis_j, _in_frame(Rk, r_bar)) if (k >= 4 and j <= 3) else None
            sN = axis_j
        for c in range(3):
            if sF is not None:
                GF[c] += sF * J_t[j - 1, c]
            if sN is not None:
                GN[c] += sN * J_t[j - 1, c]
    return GF, GN


def leg_columns(state: TreeState, wanted: Sequence[int]) -> dict[int, np.ndarray]:
    """Actuated-effort columns (3 actuators, 3 legs, N) of the leg parameters ``wanted`` (0..65).

    The three legs obey the same equations in their own frames (docs/design/conventions.md), so
    they are computed side by side along a leg axis: a third of the array operations of a
    leg-by-leg loop.
    """
    # (5, 3 legs, N)
    qt, qdt, qddt = (np.transpose(x, (2, 1, 0)) for x in (state.qt, state.qdt, state.qddt))
    J_t = np.transpose(state.J_t, (2, 3, 1, 0))  # (5 tree joints, 3 actuators, 3 legs, N)
    shape = qt.shape[1:]
    wanted = set(wanted)

    def axis(k: int) -> np.ndarray:
        e = np.zeros((3, 1, 1))
        e[k] = 1.0
        return np.broadcast_to(e, (3,) + shape)

    ez = axis(2)
    R, w, wd, acc, r_bar = _leg_recursion(state, qt, qdt, qddt, (axis(0), axis(1), ez))

    g = state.geom.gravity_leg.T[:, :, None]  # (3 components, 3 legs, 1)
    out: dict[int, np.ndarray] = {}
    col0 = 0
    for k in range(1, 6):
        kinds = [kind for kind, body in LEG_PARAMETERS if body == k]
        cols = {c: kind for c, kind in enumerate(kinds, start=col0) if c in wanted}
        col0 += len(kinds)
        inertial = {c: kind for c, kind in cols.items() if kind in _INERTIA + _MS + ("m",)}
        if inertial:
            Rk = R[k - 1]
            wk, wdk, vdk = (
                _in_frame(Rk, w[k - 1]),
                _in_frame(Rk, wd[k - 1]),
                _in_frame(Rk, acc[k - 1] - g),
            )
            GF, GN = _body_jacobian(k, R, r_bar, J_t, shape)
            for col, kind in inertial.items():
                F, Nm = _wrench(kind, wk, wdk, vdk)
                out[col] = np.stack(
                    [
                        (_dot(GF[c], F) if F is not None else 0.0)
                        + (_dot(GN[c], Nm) if Nm is not None else 0.0)
                        for c in range(3)
                    ]
                )
        for col, kind in cols.items():
            if col in inertial:
                continue
            # Drive inertia and friction of tree joint k, mapped by row k of J_t (eq. 15).
            x = {
                "ia": qddt[0],
                "fv": qdt[k - 1],
                "fs": np.sign(qdt[k - 1]),
                "tauoff": np.ones(shape),
            }[kind]
            out[col] = J_t[k - 1] * x
    return out


def platform_column(state: TreeState) -> np.ndarray:
    """(3, N): actuated efforts per unit mass of a body translating with the platform.

    tau = J_p^T D^T tau_p with tau_p = m (P'' - g): the column of m_6 and of the payload mass m_7.
    """
    f = state.Pdd - state.geom.gravity
    return (state.J_p * f[:, :, None]).sum(1).T


def _leg_wanted(columns: Sequence[int]) -> set[int]:
    return {c % N_ST_LEG for c in columns if c < N_LEGS * N_ST_LEG}


def _place(legs: dict[int, np.ndarray], platform: np.ndarray, columns: Sequence[int],
           out: np.ndarray) -> None:
    """Leg columns (3 actuators, 3 legs, N) and the platform column into ``out`` (n, 3, N)."""
    where = {c: n for n, c in enumerate(columns)}
    for k_leg, val in legs.items():
        for leg in range(1, N_LEGS + 1):
            c = (leg - 1) * N_ST_LEG + k_leg
            if c in where:
                out[where[c]] = val[:, leg - 1]
    if N_ST - 1 in where:  # m_6; the other 9 platform columns are identically zero
        out[where[N_ST - 1]] = platform


def regressor_columns(state: TreeState, columns: Sequence[int]) -> np.ndarray:
    """Selected standard-parameter columns, (len(columns), 3, N): column, joint, sample."""
    out = np.zeros((len(columns), 3, state.P.shape[0]))
    wanted = _leg_wanted(columns)
    closed = closed_form_columns(state, wanted)  # most base columns: a few array operations
    generic = leg_columns(state, wanted - set(closed)) if wanted - set(closed) else {}
    _place({**closed, **generic}, platform_column(state), columns, out)
    return out


CHUNK = 2048  # samples per pass: keeps the (3, 3 legs, chunk) temporaries in cache


def observation_block(
    q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, columns: Sequence[int],
    with_payload_mass: bool = False, out: np.ndarray | None = None, geom: Geometry = PAPER,
) -> np.ndarray:
    """Selected standard columns (and the payload-mass column last, if asked): (n, 3, N).

    Column, joint, sample: each column of each joint is contiguous in time, the layout the
    parallel decimation filters along. ``out`` (n, 3, N), e.g. a view of a larger buffer, is
    written in place and returned.
    """
    q, qd, qdd = (as_samples(x, name) for x, name in ((q, "q"), (qd, "qd"), (qdd, "qdd")))
    N = q.shape[0]
    columns = list(columns)
    n = len(columns) + int(with_payload_mass)
    if out is None:
        out = np.zeros((n, 3, N))
    wanted = _leg_wanted(columns)
    fast = has_closed_form(wanted)  # the base columns: component-first closed forms
    zero = [n for n, c in enumerate(columns) if c >= N_LEGS * N_ST_LEG and c != N_ST - 1]
    for s in range(0, N, CHUNK):
        e = min(N, s + CHUNK)
        if fast:
            leg, platform = leg_state(q[s:e], qd[s:e], qdd[s:e], geom)
            _place(closed_form_columns(leg, wanted), platform, columns, out[:len(columns), :, s:e])
            out[zero, :, s:e] = 0.0  # platform columns other than m_6: identically zero
        else:
            state = tree_state(q[s:e], qd[s:e], qdd[s:e], geom=geom)
            out[: len(columns), :, s:e] = regressor_columns(state, columns)
            platform = platform_column(state) if with_payload_mass else None
        if with_payload_mass:
            out[-1, :, s:e] = platform
    return out


def observation_columns(
    q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, columns: Sequence[int],
    with_payload_mass: bool = False, geom: Geometry = PAPER,
) -> np.ndarray:
    """Selected standard columns (and the payload-mass column last, if asked) for samples (N, 3).

    Returns W (3 N, n), rows stacked joint by joint (eq. 20). It is column-major (a transposed
    view), so that each column, filtered on its own by the parallel decimation, is contiguous.
    """
    out = observation_block(q, qd, qdd, columns, with_payload_mass, geom=geom)
    return out.reshape(out.shape[0], -1).T


def standard_regressor(q: np.ndarray, qd: np.ndarray, qdd: np.ndarray,
                       geom: Geometry = PAPER) -> tuple[np.ndarray, np.ndarray]:
    """W_st (3 N, 208) and W_l (3 N, 10) for samples (N, 3), rows stacked joint by joint (eq. 20).

    tau (3 N,) = W_st chi_st + W_l chi_payload with chi in parameters.STANDARD_NAMES / PAYLOAD_NAMES
    order; friction uses sign(qd) (Sect. 2.2).
    """
    X = observation_columns(q, qd, qdd, range(N_ST), with_payload_mass=True, geom=geom)
    W = X[:, :N_ST]
    W_l = np.zeros((W.shape[0], 10))
    W_l[:, 9] = X[:, N_ST]  # m_7; the other 9 payload columns are identically zero
    return W, W_l
