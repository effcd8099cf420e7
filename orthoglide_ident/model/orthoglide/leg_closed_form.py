"""Closed-form leg columns of the IDIM for the bodies the base parameters keep (speed).

``idim.leg_columns`` evaluates the Newton-Euler wrench of every body in its MDH frame by generic
frame recursion and projections. For the Orthoglide leg the frames are simple enough to write
the same columns in a few array operations each (leg coordinates as in kinematics.py; c2 =
cos q2i, s3 = sin q3i; J0..J2 = rows of J_t, the tree-joint rates per unit actuator rate):

- foot (body 1) translates along z: its mass column is J0 (q̈1 - g_z);
- frame 2 = Rx(-π/2) Rz(q2): ω2 = (0, 0, q̇2) in frame 2, origin O_1;
- frame 3 = frame 2 · Rx(-π/2) Rz(q3): ω3 = (-s3 q̇2, -c3 q̇2, q̇3), origin O_1, x3 = u/d4;
- frame 4 = frame 2 · Rx(-π/2) (q4 = -q3: the parallelogram keeps its orientation):
  ω4 = (0, -q̇2, 0), origin O_4 = C_i, whose velocity per unit actuator rate is R_iᵀ J_p and
  acceleration R_iᵀ P̈.

Each column is τ_c = G_c · φ (eq. 15 per body), with G_c the body's (linear, angular) velocity
per unit rate of actuator c and φ the wrench of a unit inertial parameter (Khalil & Dombre),
both in the body frame. Agrees with the generic recursion to round-off
(tests/model/test_leg_closed_form.py).
"""
from __future__ import annotations

from collections.abc import Callable, Iterable

import numpy as np

from orthoglide_ident.model.orthoglide.geometry import (
    PAPER,
    PARALLEL_MARGIN,
    R_LEG,
    SERIAL_MARGIN,
    Geometry,
)
from orthoglide_ident.model.orthoglide.kinematics import (
    _TO_BASE,
    _TO_LEG,
    TreeState,
    check_regular,
    fgm,
    to_leg,
)
from orthoglide_ident.model.orthoglide.parameters import LEG_PARAMETERS

Column = Callable[["_Leg"], np.ndarray]
_E = R_LEG[:, :, 2]  # actuator axis e_i in base coordinates (3 legs, 3)


class _Leg:
    """Component-first leg quantities of one chunk: arrays (3 legs, N) unless said otherwise."""

    def __init__(self, c2, s2, c3, s3, qdt, qddt, J, V, a4, gravity_leg: np.ndarray):
        self.c2, self.s2, self.c3, self.s3 = c2, s2, c3, s3
        self.qdt, self.qddt = qdt, qddt  # (3 legs, 5, N): tree-joint rates and q̈ (q̈1..q̈3 used)
        self.J = J  # (3 legs, 5 joints, 3 act, N): J_t
        self.V = V  # (3 legs, 3 comps, 3 act, N): R_iᵀ J_p, velocity of C_i per actuator rate
        self.a4 = a4  # (3 legs, 3 comps, N): R_iᵀ P̈ - g, leg coordinates
        self.qd2, self.qd3 = qdt[:, 1], qdt[:, 2]
        self.qdd2, self.qdd3 = qddt[:, 1], qddt[:, 2]
        g = gravity_leg[:, :, None]  # (3 legs, 3 components, 1)
        # v̇ - g of O_1 in leg coordinates: (-g_x, -g_y, q̈1 - g_z)
        self.v1 = (-g[:, 0], -g[:, 1], qddt[:, 0] - g[:, 2])
        self._cache: dict[str, object] = {}

    @classmethod
    def from_tree_state(cls, s: TreeState) -> _Leg:
        qt, qdt, qddt = (np.ascontiguousarray(np.moveaxis(x, 0, -1)) for x in (s.qt, s.qdt, s.qddt))
        J = np.ascontiguousarray(np.moveaxis(s.J_t, 0, -1))
        V = np.moveaxis(s.J_p[:, _TO_LEG, :], 0, -1)
        g_leg = s.geom.gravity_leg
        a4 = np.moveaxis(to_leg(s.Pdd), 0, -1) - g_leg[:, :, None]
        return cls(np.cos(qt[:, 1]), np.sin(qt[:, 1]), np.cos(qt[:, 2]), np.sin(qt[:, 2]), qdt,
                   qddt, J, V, a4, g_leg)

    def Jrow(self, j: int) -> np.ndarray:
        """(3 actuators, 3 legs, N): rate of tree joint j + 1 per unit actuator rate."""
        return np.moveaxis(self.J[:, j], 1, 0)

    def cached(self, name: str, f: Callable[[], object]):
        if name not in self._cache:
            self._cache[name] = f()
        return self._cache[name]

    # --- body 2 --------------------------------------------------------------------------------
    def vd2(self):
        vx, _, vz = self.v1
        c2, s2 = self.c2, self.s2
        return self.cached("vd2", lambda: (c2 * vx - s2 * vz, -s2 * vx - c2 * vz))

    # --- body 3 --------------------------------------------------------------------------------
    def w3(self):
        def f():
            w = (-self.s3 * self.qd2, -self.c3 * self.qd2, self.qd3)
            wd = (-self.c3 * self.qd3 * self.qd2 - self.s3 * self.qdd2,
                  self.s3 * self.qd3 * self.qd2 - self.c3 * self.qdd2, self.qdd3)
            return w, wd
        return self.cached("w3", f)

    def GN3(self):
        """Angular velocity of body 3 per unit actuator rate, frame 3: 3 × (3 act, 3 legs, N)."""
        def f():
            J1, J2 = self.Jrow(1), self.Jrow(2)
            return (-self.s3 * J1, -self.c3 * J1, J2)
        return self.cached("GN3", f)

    def GF3(self):
        """Velocity of O_1 per unit actuator rate in frame 3: R3ᵀ z · J0."""
        def f():
            J0 = self.Jrow(0)
            return (-self.c3 * self.s2 * J0, self.s3 * self.s2 * J0, -self.c2 * J0)
        return self.cached("GF3", f)

    def vd3(self):
        def f():
            vx, vy, vz = self.v1
            c2, s2, c3, s3 = self.c2, self.s2, self.c3, self.s3
            return (c3 * c2 * vx - s3 * vy - c3 * s2 * vz, -s3 * c2 * vx - c3 * vy + s3 * s2 * vz,
                    -s2 * vx - c2 * vz)
        return self.cached("vd3", f)

    def inertia3(self, N: tuple[np.ndarray, np.ndarray, np.ndarray]) -> np.ndarray:
        GN = self.GN3()
        return GN[0] * N[0] + GN[1] * N[1] + GN[2] * N[2]

    # --- body 4 --------------------------------------------------------------------------------
    def body4(self):
        """Velocity of O_4 = C_i per unit actuator rate and v̇ - g of O_4, both in frame 4."""
        def f():
            V = np.moveaxis(self.V, 2, 0)  # (3 act, 3 legs, 3 comps, N)
            a = self.a4
            c2, s2 = self.c2, self.s2
            GF = (c2 * V[:, :, 0] - s2 * V[:, :, 2], -V[:, :, 1],
                  -s2 * V[:, :, 0] - c2 * V[:, :, 2])
            vd = (c2 * a[:, 0] - s2 * a[:, 2], -a[:, 1], -s2 * a[:, 0] - c2 * a[:, 2])
            return GF, vd
        return self.cached("body4", f)


def _m1(L: _Leg) -> np.ndarray:
    return L.Jrow(0) * L.v1[2]


def _zz2(L: _Leg) -> np.ndarray:
    return L.Jrow(1) * L.qdd2


def _mx2(L: _Leg) -> np.ndarray:  # F = (-q̇2², q̈2, 0), N = (0, -v̇_z, v̇_y)
    return L.Jrow(0) * (L.s2 * L.qd2 ** 2 - L.c2 * L.qdd2) + L.Jrow(1) * L.vd2()[1]


def _my2(L: _Leg) -> np.ndarray:  # F = (-q̈2, -q̇2², 0), N = (v̇_z, 0, -v̇_x)
    return L.Jrow(0) * (L.s2 * L.qdd2 + L.c2 * L.qd2 ** 2) - L.Jrow(1) * L.vd2()[0]


def _inertia3(kind: str) -> Column:
    """N = L(ω̇) + ω × L(ω) for a unit inertia parameter of body 3 (F = 0)."""
    def col(L: _Leg) -> np.ndarray:
        (wx, wy, wz), (ax, ay, az) = L.w3()
        N = {
            "xx": lambda: (ax, wz * wx, -wy * wx),
            "xy": lambda: (ay - wz * wx, ax + wz * wy, wx * wx - wy * wy),
            "xz": lambda: (az + wx * wy, wz * wz - wx * wx, ax - wy * wz),
            "yy": lambda: (-wz * wy, ay, wx * wy),
            "yz": lambda: (wy * wy - wz * wz, az - wx * wy, ay + wx * wz),
            "zz": lambda: (wy * wz, -wx * wz, az),
        }[kind]()
        return L.inertia3(N)
    return col


def _my3(L: _Leg) -> np.ndarray:  # F = ω̇ × e_y + ω × (ω × e_y), N = e_y × v̇
    (wx, wy, wz), (ax, ay, az) = L.w3()
    GF, GN, (vx, _vy, vz) = L.GF3(), L.GN3(), L.vd3()
    F = (-az + wx * wy, -(wx * wx + wz * wz), ax + wy * wz)
    return GF[0] * F[0] + GF[1] * F[1] + GF[2] * F[2] + GN[0] * vz - GN[2] * vx


def _mx4(L: _Leg) -> np.ndarray:  # ω4 = (0, -q̇2, 0): F = (-q̇2², 0, q̈2), N = (0, -v̇_z, v̇_y)
    GF, vd = L.body4()
    return GF[0] * -(L.qd2 ** 2) + GF[2] * L.qdd2 + L.Jrow(1) * vd[2]


def _joint(k: int, kind: str) -> Column:
    """Drive inertia and friction of tree joint k, mapped by row k of J_t (eq. 15)."""
    def col(L: _Leg) -> np.ndarray:
        x = {"ia": lambda: L.qddt[:, 0], "fv": lambda: L.qdt[:, k - 1],
             "fs": lambda: np.sign(L.qdt[:, k - 1]), "tauoff": lambda: np.ones_like(L.c2)}[kind]()
        return L.Jrow(k - 1) * x
    return col


def _table() -> dict[int, Column]:
    cols: dict[int, Column] = {}
    special = {(1, "m"): _m1, (2, "zz"): _zz2, (2, "mx"): _mx2, (2, "my"): _my2, (3, "my"): _my3,
               (4, "mx"): _mx4}
    for k_leg, (kind, body) in enumerate(LEG_PARAMETERS):
        if kind in ("ia", "fv", "fs", "tauoff"):
            cols[k_leg] = _joint(body, kind)
        elif (body, kind) in special:
            cols[k_leg] = special[(body, kind)]
        elif body == 3 and kind in ("xx", "xy", "xz", "yy", "yz", "zz"):
            cols[k_leg] = _inertia3(kind)
    return cols


CLOSED_FORM: dict[int, Column] = _table()


def closed_form_columns(state: TreeState | _Leg, wanted: Iterable[int]) -> dict[int, np.ndarray]:
    """Columns (3 actuators, 3 legs, N) of the leg parameters in ``wanted`` that have a closed
    form here (the others: ``idim.leg_columns``)."""
    wanted = [k for k in wanted if k in CLOSED_FORM]
    if not wanted:
        return {}
    L = state if isinstance(state, _Leg) else _Leg.from_tree_state(state)
    return {k: CLOSED_FORM[k](L) for k in wanted}


def has_closed_form(wanted: Iterable[int]) -> bool:
    return all(k in CLOSED_FORM for k in wanted)


def _inv3(M: np.ndarray) -> np.ndarray:
    """Inverse of 3x3 matrices stored component-first, M[i, k] (N,) (cofactors)."""
    a, b, c = M[0]
    d, e, f = M[1]
    g, h, i = M[2]
    co = np.array([[e * i - f * h, c * h - b * i, b * f - c * e],
                   [f * g - d * i, a * i - c * g, c * d - a * f],
                   [d * h - e * g, b * g - a * h, a * e - b * d]])
    det = a * co[0, 0] + b * co[1, 0] + c * co[2, 0]
    return co / det


def leg_state(q: np.ndarray, qd: np.ndarray, qdd: np.ndarray,
              geom: Geometry = PAPER) -> tuple[_Leg, np.ndarray]:
    """Component-first kinematics of a chunk (eqs. 5-9 with f_p of eq. 41, as
    ``kinematics.tree_state``) for the closed-form columns, and the platform column J_pᵀ(P̈ - g)
    (3, N). Raises WorkspaceError / SingularityError like ``tree_state``."""
    d4 = geom.d4
    P = fgm(q, geom)
    Pt, qt_, qdt_, qddt_ = P.T, q.T, qd.T, qdd.T  # (3, N)
    u = Pt[_TO_LEG] - geom.foot_offset[:, :, None]  # bars in leg coordinates (3 legs, 3, N)
    u[:, 2] -= qt_ + geom.d6
    ub = u[np.arange(3)[:, None], _TO_BASE]  # base coordinates: rows of A_p / 2
    _check(q, u, ub, d4)
    Ainv = _inv3(2.0 * ub)  # eq. (9): A_p = 2 [u_iᵀ], B_p = diag(-2 u_i . e_i)
    J_p = 2.0 * Ainv * u[:, 2][None]  # eq. (5): J_p = -A_p⁻¹ B_p, (3 comps, 3 act, N)
    Pd = (J_p * qdt_[None]).sum(1)
    ud = Pd[None] - _E[:, :, None] * qdt_[:, None]  # u̇_i = v - e_i q̇_i (base), (3 legs, 3, N)
    rhs = (2.0 * (ud * Pd[None]).sum(1) - 2.0 * u[:, 2] * qddt_
           - 2.0 * (ud * _E[:, :, None]).sum(1) * qdt_)
    Pdd = -(Ainv * rhs[None]).sum(1)  # eq. (6)
    sx, sy, sz = u[:, 0] / d4, u[:, 1] / d4, u[:, 2] / d4
    q3 = np.arcsin(np.clip(-sy, -1.0, 1.0))
    q2 = np.arctan2(-sz, sx)
    c2, s2, c3, s3 = np.cos(q2), np.sin(q2), np.cos(q3), np.sin(q3)

    def solve_jk(y, c2, s2, c3, s3):  # J_k x = y, J_k = [z, du/dq2, du/dq3] (eq. 7), triangular
        x3 = y[1] / (-d4 * c3)
        x2 = (y[0] + d4 * c2 * s3 * x3) / (-d4 * s2 * c3)
        return y[2] + d4 * c2 * c3 * x2 - d4 * s2 * s3 * x3, x2, x3

    V = J_p[_TO_LEG]  # R_iᵀ J_p: (3 legs, 3 comps, 3 act, N)
    J123 = solve_jk(tuple(np.moveaxis(V, 1, 0)), *(x[:, None] for x in (c2, s2, c3, s3)))
    qd123 = [(x * qdt_[None]).sum(1) for x in J123]
    qd2, qd3 = qd123[1], qd123[2]
    bias = (d4 * (-c2 * c3 * qd2 ** 2 + 2 * s2 * s3 * qd2 * qd3 - c2 * c3 * qd3 ** 2),
            d4 * s3 * qd3 ** 2,
            d4 * (s2 * c3 * qd2 ** 2 + 2 * c2 * s3 * qd2 * qd3 + s2 * c3 * qd3 ** 2))
    Pdd_leg = Pdd[_TO_LEG]  # (3 legs, 3, N)
    qdd123 = solve_jk(tuple(Pdd_leg[:, k] - bias[k] for k in range(3)), c2, s2, c3, s3)  # eq. (8)
    qdt = np.stack([qd123[0], qd2, qd3, -qd3, -qd2], axis=1)
    qddt = np.stack([qdd123[0], qdd123[1], qdd123[2], -qdd123[2], -qdd123[1]], axis=1)
    J = np.stack([J123[0], J123[1], J123[2], -J123[2], -J123[1]], axis=1)
    g_leg = geom.gravity_leg
    leg = _Leg(c2, s2, c3, s3, qdt, qddt, J, V, Pdd_leg - g_leg[:, :, None], g_leg)
    platform = (J_p * (Pdd - geom.gravity[:, None])[:, None]).sum(0)  # J_pᵀ (P̈ - g): m_6, m_7
    return leg, platform


def _check(q: np.ndarray, u: np.ndarray, ub: np.ndarray, d4: float) -> None:
    """kinematics.check_regular's margins; its message when one is crossed."""
    serial = np.abs(u[:, 2]) / d4
    a, b, c = ub[0]
    d, e, f = ub[1]
    g, h, i = ub[2]
    det = a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)
    if np.any(serial < SERIAL_MARGIN) or np.any(np.abs(det) / d4 ** 3 < PARALLEL_MARGIN):
        check_regular(q, np.moveaxis(u, -1, 0), np.moveaxis(ub, -1, 0), d4)
