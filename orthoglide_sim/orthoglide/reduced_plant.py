"""The Orthoglide's plant at a small cost per tick: Pinocchio once per tick, the tick's RK4
compiled.

The reference (simulator.Integrator) calls Pinocchio's constraintDynamics on the 15-joint tree at
every RK4 stage from Python: 4 steps x 4 stages = 16 calls and their numpy per 1 ms tick, most of
the driver's CPU. ``ReducedIntegrator`` integrates the same plant (orthoglide_sim.orthoglide.plant:
the same
Pinocchio model, loops, rotor inertias, tanh friction on the 15 tree joints, the same DriveModel)
with the same RK4 steps, reduced to the three actuator coordinates (q, qd):

- at a state (q, qd), the simulator's closed-form kinematics (kinematics.tree_state, compiled here
  as ``_tree``) give the tree configuration Q on the loop and the loop's velocity map G (15 x 3,
  V = G qd); one Pinocchio call, constraintDynamics under zero joint forces, gives the free
  acceleration a_0 (gravity, Coriolis, the loops' velocity products) and leaves the tree's mass
  matrix M (crba, rotor inertias as armature) in its data; M_a = G^T M G. Projecting the tree's
  constrained equation of motion on G (J_c G = 0 removes the loop forces) gives, exactly there,
      qdd = a_0 + M_a^-1 (F - G^T f(G qd)),
  F the drive's forces on the actuated joints, f the tree joints' friction (fv qd + fs tanh +
  tauoff);
- over a tick, the RK4 stages evaluate the friction and the drive (stiff near zero velocity: tanh
  at 1 mm/s) at each stage's state as the reference does, while the smooth part X = (a_0, M_a^-1,
  G), which varies at the motion's own pace, is linear in time between its values at the tick's
  start and end: predictor-corrector, the tick integrated once with X held, X evaluated at the
  predicted end (which is the next tick's start), the tick integrated again. Its error is O(T^3)
  of X's own variation: 0.03 um and 0.02 mA from the reference along a 2 s exciting run, half of
  what separates the reference from itself at twice its RK4 steps
  (tests/sim/orthoglide/test_plant_cheap.py).

Per tick: one Pinocchio call and two compiled ones (numba, cached on disk after the first
compilation), instead of 16 Pinocchio calls and ~200 numpy operations. Independent of the
identification model as the reference is: Pinocchio's spatial algebra on the real topology and the
simulator's own kinematics; no closed-form dynamic model, no regressor.
"""
from __future__ import annotations

import numpy as np
import pinocchio as pin
from numba import njit

from orthoglide_sim.orthoglide import kinematics as kin
from orthoglide_sim.orthoglide.plant import ACTUATED, N_TREE, Plant
from orthoglide_sim.orthoglide.simulator import STROKE, SUBSTEPS, TICK, DriveModel, Integrator

# The smooth part X of one state, flat for the compiled code: a_0 (3), M_a^-1 (3 x 3 rows), G (15 x
# 3 rows)
N_SMOOTH = 12 + 3 * N_TREE
# module constants: frozen into the compiled code
_E, _FOOT, _R = kin.E_AXIS, kin.FOOT_BASE, kin.R_FOOT
_D4, _D6 = kin.D4, kin.D6


@njit(cache=True)
def _tree(q, Q, G):
    """kinematics.tree_state for one state, compiled: the tree configuration Q (15,) on the loop at
    actuator positions q (3,), and G (15, 3) with the tree velocities V = G qd. Returns False where
    the legs cannot meet (kinematics.platform_position raises there)."""
    S = np.empty((3, 3))
    for i in range(3):
        S[i] = _FOOT[i] + (q[i] + _D6) * _E[i]
    b, c = S[1] - S[0], S[2] - S[0]
    n = np.cross(b, c)
    nn = n @ n
    cc = S[0] + ((b @ b) * np.cross(c, n) + (c @ c) * np.cross(n, b)) / (2.0 * nn)
    h2 = _D4**2 - (cc - S[0]) @ (cc - S[0])
    if not h2 > 0.0:
        return False
    P = cc + np.sqrt(h2) * n / np.sqrt(nn)
    u = np.empty((3, 3))
    for i in range(3):
        u[i] = (P - S[i]) / _D4
    # dP = Jp dq
    Jp = np.linalg.solve(u, np.diag(np.array([u[0] @ _E[0], u[1] @ _E[1], u[2] @ _E[2]])))
    G[:] = 0.0
    for i in range(3):
        w = _R[i].T @ u[i]  # bar direction in the foot frame
        q3, q2 = np.arcsin(-w[1]), np.arctan2(-w[2], w[0])
        r = 5 * i
        Q[r], Q[r + 1], Q[r + 2], Q[r + 3], Q[r + 4] = q[i], q2, q3, -q3, -q2
        G[r, i] = 1.0
        for j in range(3):  # the bar's rate and the pivots' rates for a unit rate of actuator j
            ud = Jp[:, j].copy()
            if j == i:
                ud -= _E[i]
            wd = _R[i].T @ (ud / _D4)
            q3d = -wd[1] / np.cos(q3)
            q2d = (w[2] * wd[0] - w[0] * wd[2]) / (w[0] ** 2 + w[2] ** 2)
            G[r + 1, j], G[r + 2, j], G[r + 3, j], G[r + 4, j] = q2d, q3d, -q3d, -q2d
    return True


@njit(cache=True)
def _smooth_end(x, M, a0, G, X):
    """X = (a_0, M_a^-1 = (G^T M G)^-1, G) from the tree's mass matrix M (upper triangle, as
    Pinocchio leaves it) and the free acceleration a_0 (3,)."""
    Ms = np.triu(M) + np.triu(M, 1).T
    X[0:3] = a0
    X[3:12] = np.linalg.inv(G.T @ Ms @ G).ravel()
    X[12:] = G.ravel()


@njit(cache=True)
def _stage(s, q, qd, X, dX, current, fric, drive, dscal, drive_friction, V):
    """Actuator accelerations (3,) at time fraction s of the tick (smooth part X + s dX); the tree
    velocities G qd into V (15,)."""
    rhs = np.empty(3)
    for j in range(3):
        rhs[j] = drive[0, j] * current[j]
        # DriveModel.friction: (stribeck exp(-(qd/v_st)^2) + ripple sin(.)) tanh(qd/v_c)
        if drive_friction:
            level = drive[1, j] * np.exp(-((qd[j] * dscal[0]) ** 2)) + drive[2, j] * np.sin(
                q[j] * dscal[1] + drive[3, j]
            )
            rhs[j] -= level * np.tanh(qd[j] * dscal[2])
    for r in range(V.shape[0]):
        b = 12 + 3 * r
        g0, g1, g2 = X[b] + s * dX[b], X[b + 1] + s * dX[b + 1], X[b + 2] + s * dX[b + 2]
        v = g0 * qd[0] + g1 * qd[1] + g2 * qd[2]
        V[r] = v
        # fv v + fs tanh(v/v_s) + tauoff
        f = fric[0, r] * v + fric[1, r] * np.tanh(v * fric[2, r]) + fric[3, r]
        rhs[0] -= g0 * f
        rhs[1] -= g1 * f
        rhs[2] -= g2 * f
    out = np.empty(3)
    for i in range(3):
        out[i] = X[i] + s * dX[i]
        for j in range(3):
            out[i] += (X[3 + 3 * i + j] + s * dX[3 + 3 * i + j]) * rhs[j]
    return out


@njit(cache=True)
def _integrate_tick(x, X, dX, currents, fric, drive, dscal, drive_friction, stroke):
    """RK4 over one tick (currents.shape[0] steps), in place on the state x = (q, qd); returns the
    actuator accelerations at the tick's start and whether the state is finite and inside the
    stroke. currents (steps, 3, 3): the motor current at the start, middle and end of every step."""
    steps = currents.shape[0]
    h = 1.0 / steps  # in tick fractions
    dt = h * dscal[3]
    q, qd = x[0:3], x[3:6]
    V = np.empty(N_TREE)
    qdd0 = np.empty(3)
    for k in range(steps):
        s = k * h
        a1 = _stage(s, q, qd, X, dX, currents[k, 0], fric, drive, dscal, drive_friction, V)
        if k == 0:
            qdd0[:] = a1
        q2, qd2 = q + 0.5 * dt * qd, qd + 0.5 * dt * a1
        a2 = _stage(
            s + 0.5 * h, q2, qd2, X, dX, currents[k, 1], fric, drive, dscal, drive_friction, V
        )
        q3, qd3 = q + 0.5 * dt * qd2, qd + 0.5 * dt * a2
        a3 = _stage(
            s + 0.5 * h, q3, qd3, X, dX, currents[k, 1], fric, drive, dscal, drive_friction, V
        )
        q4, qd4 = q + dt * qd3, qd + dt * a3
        a4 = _stage(s + h, q4, qd4, X, dX, currents[k, 2], fric, drive, dscal, drive_friction, V)
        q += (dt / 6.0) * (qd + 2.0 * qd2 + 2.0 * qd3 + qd4)
        qd += (dt / 6.0) * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
    ok = np.all(np.isfinite(x)) and np.all(q >= stroke[0]) and np.all(q <= stroke[1])
    return qdd0, ok


@njit(cache=True)
def _predict(x, X, zero, currents, fric, drive, dscal, drive_friction, stroke, Q, G):
    """The tick integrated with X held (in place on x), then the tree (Q, G) at its end state."""
    _, ok = _integrate_tick(x, X, zero, currents, fric, drive, dscal, drive_friction, stroke)
    return ok and _tree(x[0:3], Q, G)


@njit(cache=True)
def _correct(x, X, X_end, M, a0, G, currents, fric, drive, dscal, drive_friction, stroke, Q):
    """X_end from the end state's Pinocchio results, then the tick integrated with X linear from X
    to X_end (in place on x), and the tree configuration Q at the new state."""
    _smooth_end(x, M, a0, G, X_end)
    qdd0, ok = _integrate_tick(
        x, X, X_end - X, currents, fric, drive, dscal, drive_friction, stroke
    )
    Gq = np.empty((N_TREE, 3))
    return qdd0, ok and _tree(x[0:3], Q, Gq)


class ReducedIntegrator(Integrator):
    """``simulator.Integrator``'s interface (q, qd, Q, V, current, ticks, tick(current)) on the
    reduced scheme of the module doc; same plant, drive, substeps and workspace checks."""

    def __init__(self, plant: Plant, drive: DriveModel, q0: np.ndarray, qd0: np.ndarray,
                 substeps: int = SUBSTEPS, current0: np.ndarray | None = None):
        super().__init__(plant, drive, q0, qd0, substeps, current0)
        self.x = np.concatenate([self.Q[ACTUATED], self.V[ACTUATED]])
        self._fric = np.array([plant.fv, plant.fs, 1.0 / plant.v_s, plant.tauoff], dtype=float)
        bc = lambda v: np.broadcast_to(np.asarray(v, dtype=float), (3,))  # noqa: E731
        self._drive = np.array([bc(drive.g_tau), bc(drive.stribeck), bc(drive.ripple_amplitude),
                                bc(drive.ripple_phase)])
        self._dscal = np.array([1.0 / drive.stribeck_velocity, 2.0 * np.pi / drive.ripple_lead,
                                1.0 / drive.coulomb_velocity, TICK])
        self._drive_friction = drive.has_friction
        self._stroke = np.array(STROKE, dtype=float)
        self._stages = np.zeros((self.substeps, 3, 3))
        self._zero, self._tau0 = np.zeros(N_SMOOTH), np.zeros(N_TREE)
        self._Qe, self._G = np.empty(N_TREE), np.empty((N_TREE, 3))
        self._X = self.reduce(self.x)  # X at the tick's start
        # the compiled functions loaded (or compiled) now, not in the first tick (~0.1 s each)
        args = self._compiled_args
        _predict(self.x.copy(), self._X, self._zero, *args, self._Qe, self._G)
        G0 = self._X[12:].reshape(N_TREE, 3).copy()
        _correct(
            self.x.copy(),
            self._X,
            np.empty(N_SMOOTH),
            self.plant.data.M,
            self._X[0:3].copy(),
            G0,
            *args,
            self._Qe,
        )

    @property
    def _compiled_args(self) -> tuple:
        """What the compiled steps take after the state: the stage currents, friction, drive,
        their scales, the drive's own friction on or off, the stroke."""
        return (self._stages, self._fric, self._drive, self._dscal, self._drive_friction,
                self._stroke)

    @property
    def q(self) -> np.ndarray:
        return self.x[0:3].copy()

    @property
    def qd(self) -> np.ndarray:
        return self.x[3:6].copy()

    def reduce(self, x: np.ndarray) -> np.ndarray:
        """X = (a_0, M_a^-1, G) (flat, N_SMOOTH) at the state x = (q, qd); sets the tree state Q,
        V."""
        G, Q = np.empty((N_TREE, 3)), np.empty(N_TREE)
        if not _tree(x[0:3], Q, G):
            kin.platform_position(x[0:3])  # raises WorkspaceError with the reason
        X = np.empty(N_SMOOTH)
        self.Q, self.V = Q, G @ x[3:6]
        a0 = self._free_acceleration(Q, self.V)
        _smooth_end(x, self.plant.data.M, a0, G, X)
        return X

    def _free_acceleration(self, Q: np.ndarray, V: np.ndarray) -> np.ndarray:
        """a_0 (3,) under zero joint forces; leaves crba's M (upper triangle) in the plant's
        data."""
        p = self.plant
        return pin.constraintDynamics(
            p.model, p.data, Q, V, self._tau0, p.constraints, p.constraint_data, p.prox
        )[ACTUATED]

    def tick(self, current: np.ndarray) -> np.ndarray:
        """Integrate one tick under the reference ``current`` (3,) A; returns the actuator
        accelerations (3,) at its start. Raises WorkspaceError as the reference does."""
        u = np.asarray(current, float)
        if self._decay is None:
            self._stages[:] = u
        else:  # motor current at (start, middle, end) of every RK4 step: u + (i0 - u) e^(-t/tau)
            i0 = u if self.current is None else self.current
            self._stages[:] = u + self._decay[:, :, None] * (i0 - u)
        args = self._compiled_args
        x, G, X_end, Q = self.x.copy(), self._G, np.empty(N_SMOOTH), np.empty(N_TREE)
        ok = _predict(x, self._X, self._zero, *args, Q, G)
        if ok:  # Pinocchio at the predicted end; M is read from its data by _correct
            a0 = self._free_acceleration(Q, G @ x[3:6])
            x = self.x.copy()
            qdd0, ok = _correct(x, self._X, X_end, self.plant.data.M, a0, G, *args, Q)
        if not ok:  # raise with the reason: not finite, out of the stroke, or no assembly
            Qa = np.zeros(N_TREE)
            Qa[ACTUATED] = x[0:3]
            self._check(Qa, x[3:6], current)
            kin.platform_position(x[0:3])
        self.x, self._X = x, X_end
        self.Q, self.V = Q, X_end[12:].reshape(N_TREE, 3) @ x[3:6]
        self.current = (
            u.copy() if self._decay is None else u + self._decay_tick * (self._stages[0, 0] - u)
        )
        self.ticks += 1
        return qdd0


def compile_now() -> None:
    """Compile (or load) the compiled functions into numba's cache: one tick of the nominal
    plant."""
    from orthoglide_sim.orthoglide.simulator import drive_model
    from orthoglide_sim.orthoglide.truth import load_parameters

    params = load_parameters()
    ReducedIntegrator(Plant(params), drive_model(params), np.full(3, 0.04), np.zeros(3)).tick(
        np.zeros(3)
    )


if __name__ == "__main__":  # make setup
    compile_now()
