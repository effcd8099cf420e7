"""A small synthetic n-joint robot model and records generated from it: a test fixture.

Not the Orthoglide: a RobotModel (model/robot.py) with its own simple dynamics, so that every
numerical step of the pipeline can be checked against known χ and g_τ without the full model or
the simulator, for 3 joints (the default, named like the Orthoglide's) or any other number.

Joint j force:  τ_j = m_j q̈_j + fv_j q̇_j + fs_j sign(q̇_j) + off_j + (m_p + m_7) (M(q) q̈ + G)_j
with M(q) = M0 + k q qᵀ (couples the joints like a platform) and G = g0 on the last joint.
Base parameters (4 n + 1): m_1..n, fv_1..n, fs_1..n, off_1..n, m_p; payload column = m_p's.

Records: q(t) is a smooth sum of sines; the controller's zero-order hold is reproduced by
v_τ[k] = mean of τ(t)/g_τ over [t_k, t_k + T) (Gauss-Legendre), so the data carry the half-sample
shift the pipeline corrects. Optional 1 µm quantisation of q and white current noise.
"""
from __future__ import annotations

import numpy as np

from orthoglide_ident.identify import Record
from orthoglide_ident.model.robot import ActuatedJoint, Payload, RobotModel

M0 = np.array([[1.0, 0.3, -0.2], [0.3, 1.2, 0.25], [-0.2, 0.25, 0.9]])
K_Q = 40.0  # 1/m²
G0 = 9.80665

NAMES = ["m_1", "m_2", "m_3", "fv_1", "fv_2", "fv_3", "fs_1", "fs_2", "fs_3",
         "off_1", "off_2", "off_3", "m_p"]
TRUE_CHI = np.array([9.0, 8.5, 7.0, 80.0, 85.0, 75.0, 30.0, 35.0, 25.0, 1.0, -0.8, 2.0, 1.5])
TRUE_GAINS = np.array([2170.0, 2100.0, 2070.0])
NOMINAL_GAIN = 637.0 * np.pi  # N/A, as the Orthoglide's manufacturer gives


def coupling(n: int) -> np.ndarray:
    """M0 for n joints: the 3-joint matrix above, or a fixed SPD matrix of the same kind."""
    if n == 3:
        return M0
    i = np.arange(n)
    return np.eye(n) + 0.25 * np.cos(np.add.outer(i, 2 * i)) / (1 + np.abs(np.subtract.outer(i, i)))


def true_chi(n: int) -> np.ndarray:
    """Known base parameters of the n-joint model (TRUE_CHI for 3 joints)."""
    if n == 3:
        return TRUE_CHI
    j = np.arange(n)
    return np.concatenate([9.0 - 0.3 * j, 80.0 + 2.0 * j, 30.0 - 1.5 * j,
                           np.cos(1.3 * j + 0.2), [1.5]])


def true_gains(n: int) -> np.ndarray:
    return TRUE_GAINS if n == 3 else 2000.0 + 40.0 * np.cos(np.arange(n) + 0.5)


class SyntheticModel(RobotModel):
    """A RobotModel with ``regressor(q, qd, qdd) -> (n N, 4 n + 1)``, rows joint by joint."""

    name = "synthetic"
    payload_frame = "platform"
    legs = None

    def __init__(self, n_joints: int = 3, kind: str = "prismatic"):
        names = [f"q1{j + 1}" for j in range(n_joints)] if n_joints == 3 else \
            [f"joint_{j + 1}" for j in range(n_joints)]
        self.joints = tuple(ActuatedJoint(nm, kind, NOMINAL_GAIN) for nm in names)
        self.M0 = coupling(n_joints)
        self.names = [f"{k}_{j + 1}" for k in ("m", "fv", "fs", "off") for j in range(n_joints)] \
            + ["m_p"]
        self.expressions = [""] * (4 * n_joints) + ["m_p (platform)"]
        self.standard_names = tuple(self.names)
        self.bodies = ()
        self.K = np.eye(len(self.names))

    def _platform(self, q: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        # (M0 + k q qᵀ) q̈ + G  → (N, n)
        col = qdd @ self.M0.T + K_Q * q * np.sum(q * qdd, axis=1, keepdims=True)
        col[:, -1] += G0
        return col

    def observation_block(self, q, qd, qdd, out=None) -> np.ndarray:
        q, qd, qdd = (np.atleast_2d(np.asarray(x, float)) for x in (q, qd, qdd))
        N, n = q.shape
        if out is None:
            out = np.empty((4 * n + 2, n, N))
        out[...] = 0.0
        for j in range(n):
            out[j, j] = qdd[:, j]
            out[n + j, j] = qd[:, j]
            out[2 * n + j, j] = np.sign(qd[:, j])
            out[3 * n + j, j] = 1.0
        out[4 * n] = out[4 * n + 1] = self._platform(q, qdd).T
        return out

    def with_payload(self, payload: Payload) -> SyntheticModel:
        return self

    def standard_regressor(self, q, qd, qdd) -> np.ndarray:
        return self.regressor(q, qd, qdd)

    def random_states(self, n: int, seed: int = 0):
        rng = np.random.default_rng(seed)
        return tuple(rng.normal(0.0, s, (n, self.n_joints)) for s in (0.05, 0.5, 5.0))

    def table(self) -> str:
        return "\n".join(self.names)

    def to_json(self) -> dict:
        return {"names": list(self.names)}

    def forces(self, q, qd, qdd, chi=None, payload_mass=0.0) -> np.ndarray:
        """τ (N, n) in N."""
        chi = true_chi(self.n_joints) if chi is None else chi
        N = np.atleast_2d(q).shape[0]
        tau = self.regressor(q, qd, qdd) @ chi + payload_mass * self.payload_mass_column(q, qd, qdd)
        return tau.reshape(self.n_joints, N).T


def trajectory(
    t: np.ndarray,
    seed: int = 0,
    amplitude: float = 0.06,
    f_max: float = 2.0,
    n_harmonics: int = 5,
    n_joints: int = 3,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Smooth exciting q(t), q̇, q̈ (N, n): sums of sines, ``amplitude`` m, up to ``f_max`` Hz."""
    rng = np.random.default_rng(seed)
    t = np.asarray(t, float)[:, None]
    q = np.zeros((t.shape[0], n_joints))
    qd = np.zeros_like(q)
    qdd = np.zeros_like(q)
    for _ in range(n_harmonics):
        f = rng.uniform(0.2, f_max, n_joints)
        a = rng.uniform(0.3, 1.0, n_joints) * amplitude / n_harmonics
        ph = rng.uniform(0, 2 * np.pi, n_joints)
        w = 2 * np.pi * f
        q += a * np.sin(w * t + ph)
        qd += a * w * np.cos(w * t + ph)
        qdd -= a * w * w * np.sin(w * t + ph)
    return q, qd, qdd


def synthetic_record(
    duration_s: float = 20.0, payload_mass: float = 0.0, seed: int = 0, noise: bool = True,
    g_tau: np.ndarray | None = None, chi: np.ndarray | None = None, rate_hz: float = 1000.0,
    current_noise_a: float = 0.002, quantum_m: float = 1e-6, amplitude: float = 0.06,
    f_max: float = 2.0, source: str | None = None, t0_ns: int = 1_700_000_000_000_000_000,
    zoh: bool = True, model=None, traj=None, steps_ns: np.ndarray | None = None,
) -> Record:
    """A tagged :class:`Record` under zero-order-hold current references.

    ``model`` (default :class:`SyntheticModel`) is a RobotModel (e.g. the Orthoglide base model,
    then ``chi`` are its base parameters; default χ and g_τ: the synthetic model's true ones);
    ``traj(t) -> (q, q̇, q̈)`` overrides the sums of sines. ``steps_ns``: the controller's own
    (uneven) tick steps instead of ``rate_hz``, each current held over its own step.
    """
    model = model if model is not None else SyntheticModel()
    n_j = model.n_joints
    chi = true_chi(n_j) if chi is None else chi
    g_tau = true_gains(n_j) if g_tau is None else g_tau
    if traj is None:
        def traj(t):
            return trajectory(t, seed, amplitude, f_max, n_joints=n_j)

    def forces(t):
        q_, qd_, qdd_ = traj(t)
        tau_ = model.regressor(q_, qd_, qdd_) @ chi
        if payload_mass:
            tau_ = tau_ + payload_mass * model.payload_mass_column(q_, qd_, qdd_)
        return tau_.reshape(n_j, -1).T

    T = 1.0 / rate_hz
    n = int(round(duration_s * rate_hz))
    k = np.arange(n)
    if steps_ns is None:
        t, h = k * T, np.full(n, T)
    else:  # t_k and the step held from it
        n = len(steps_ns)
        offs = np.concatenate([[0], np.cumsum(steps_ns)[:-1]]).astype(np.int64)
        t, h = offs * 1e-9, np.asarray(steps_ns) * 1e-9
    if zoh:
        # 4-point Gauss-Legendre mean over [t_k, t_k + h_k)
        xg, wg = np.polynomial.legendre.leggauss(4)
        tau = np.zeros((n, n_j))
        for x, w in zip(xg, wg):
            tau += 0.5 * w * forces((k + 0.5 + 0.5 * x) * T if steps_ns is None
                                    else t + (0.5 + 0.5 * x) * h)
    else:
        tau = forces(t)
    q, _, _ = traj(t)
    v = tau / np.asarray(g_tau)[None, :]
    if noise:
        rng = np.random.default_rng(10_000 + seed)
        v = v + current_noise_a * rng.standard_normal(v.shape)
        q = np.round(q / quantum_m) * quantum_m
    stamps = t0_ns + (offs if steps_ns is not None else (k * round(T * 1e9)).astype(np.int64))
    cond = "loaded" if payload_mass > 0 else "unloaded"
    name = source or f"synthetic-{cond}-{seed}"
    return Record.from_arrays(name, stamps, q, v, cond, payload_mass, model.joint_names)
