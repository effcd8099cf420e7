"""A small synthetic 3-joint model and records generated from it: a test fixture.

Not the Orthoglide: a stand-in with the same interface as the base model (``names``,
``expressions``, ``regressor``, ``payload_mass_column``) so that every numerical step of the
pipeline can be checked against known χ and g_τ without the full model or the simulator.

Joint j force:  τ_j = m_j q̈_j + fv_j q̇_j + fs_j sign(q̇_j) + off_j + (m_p + m_7) (M(q) q̈ + G)_j
with M(q) = M0 + k q qᵀ (couples the joints like a platform) and G = (0, 0, g0) on joint 3.
Base parameters (13): m_1..3, fv_1..3, fs_1..3, off_1..3, m_p; payload column = column of m_p.

Records: q(t) is a smooth sum of sines; the controller's zero-order hold is reproduced by
v_τ[k] = mean of τ(t)/g_τ over [t_k, t_k + T) (Gauss-Legendre), so the data carry the half-sample
shift the pipeline corrects. Optional 1 µm quantisation of q and white current noise.
"""
from __future__ import annotations

import numpy as np

from orthoglide_ident.identify.pipeline import Record

M0 = np.array([[1.0, 0.3, -0.2], [0.3, 1.2, 0.25], [-0.2, 0.25, 0.9]])
K_Q = 40.0  # 1/m²
G0 = 9.80665

NAMES = ["m_1", "m_2", "m_3", "fv_1", "fv_2", "fv_3", "fs_1", "fs_2", "fs_3",
         "off_1", "off_2", "off_3", "m_p"]
TRUE_CHI = np.array([9.0, 8.5, 7.0, 80.0, 85.0, 75.0, 30.0, 35.0, 25.0, 1.0, -0.8, 2.0, 1.5])
TRUE_GAINS = np.array([2170.0, 2100.0, 2070.0])


class SyntheticModel:
    """Base-model stand-in: ``regressor(q, qd, qdd) -> (3 N, 13)``, rows joint by joint."""

    names = NAMES
    expressions = [""] * 12 + ["m_p (platform)"]
    legs = None

    def _platform(self, q: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        # (M0 + k q qᵀ) q̈ + G  → (N, 3)
        col = qdd @ M0.T + K_Q * q * np.sum(q * qdd, axis=1, keepdims=True)
        col[:, 2] += G0
        return col

    def regressor(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        q, qd, qdd = (np.atleast_2d(np.asarray(x, float)) for x in (q, qd, qdd))
        n = q.shape[0]
        W = np.zeros((3, n, 13))
        for j in range(3):
            W[j, :, j] = qdd[:, j]
            W[j, :, 3 + j] = qd[:, j]
            W[j, :, 6 + j] = np.sign(qd[:, j])
            W[j, :, 9 + j] = 1.0
        W[:, :, 12] = self._platform(q, qdd).T
        return W.reshape(3 * n, 13)

    def payload_mass_column(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        q, qdd = np.atleast_2d(q), np.atleast_2d(qdd)
        return self._platform(q, qdd).T.reshape(-1)

    def forces(self, q, qd, qdd, chi=TRUE_CHI, payload_mass=0.0) -> np.ndarray:
        """τ (N, 3) in N."""
        n = np.atleast_2d(q).shape[0]
        tau = self.regressor(q, qd, qdd) @ chi + payload_mass * self.payload_mass_column(q, qd, qdd)
        return tau.reshape(3, n).T


def trajectory(t: np.ndarray, seed: int = 0, amplitude: float = 0.06, f_max: float = 2.0,
               n_harmonics: int = 5) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Smooth exciting q(t), q̇, q̈ (N, 3): sums of sines, ``amplitude`` m, up to ``f_max`` Hz."""
    rng = np.random.default_rng(seed)
    t = np.asarray(t, float)[:, None]
    q = np.zeros((t.shape[0], 3))
    qd = np.zeros_like(q)
    qdd = np.zeros_like(q)
    for _ in range(n_harmonics):
        f = rng.uniform(0.2, f_max, 3)
        a = rng.uniform(0.3, 1.0, 3) * amplitude / n_harmonics
        ph = rng.uniform(0, 2 * np.pi, 3)
        w = 2 * np.pi * f
        q += a * np.sin(w * t + ph)
        qd += a * w * np.cos(w * t + ph)
        qdd -= a * w * w * np.sin(w * t + ph)
    return q, qd, qdd


def synthetic_record(
    duration_s: float = 20.0, payload_mass: float = 0.0, seed: int = 0, noise: bool = True,
    g_tau: np.ndarray = TRUE_GAINS, chi: np.ndarray = TRUE_CHI, rate_hz: float = 1000.0,
    current_noise_a: float = 0.002, quantum_m: float = 1e-6, amplitude: float = 0.06,
    f_max: float = 2.0, source: str | None = None, t0_ns: int = 1_700_000_000_000_000_000,
    zoh: bool = True, model=None, traj=None,
) -> Record:
    """A tagged :class:`Record` under zero-order-hold current references.

    ``model`` (default :class:`SyntheticModel`) is anything with ``regressor`` and
    ``payload_mass_column`` (e.g. the Orthoglide base model, then ``chi`` are its base
    parameters); ``traj(t) -> (q, q̇, q̈)`` overrides the sums of sines.
    """
    model = model if model is not None else SyntheticModel()
    if traj is None:
        def traj(t):
            return trajectory(t, seed, amplitude, f_max)

    def forces(t):
        q_, qd_, qdd_ = traj(t)
        tau_ = model.regressor(q_, qd_, qdd_) @ chi
        if payload_mass:
            tau_ = tau_ + payload_mass * model.payload_mass_column(q_, qd_, qdd_)
        return tau_.reshape(3, -1).T

    T = 1.0 / rate_hz
    n = int(round(duration_s * rate_hz))
    k = np.arange(n)
    if zoh:
        # 4-point Gauss-Legendre mean over [t_k, t_k + T)
        xg, wg = np.polynomial.legendre.leggauss(4)
        tau = np.zeros((n, 3))
        for x, w in zip(xg, wg):
            tau += 0.5 * w * forces((k + 0.5 + 0.5 * x) * T)
    else:
        tau = forces(k * T)
    q, _, _ = traj(k * T)
    v = tau / np.asarray(g_tau)[None, :]
    if noise:
        rng = np.random.default_rng(10_000 + seed)
        v = v + current_noise_a * rng.standard_normal(v.shape)
        q = np.round(q / quantum_m) * quantum_m
    stamps = t0_ns + (k * round(T * 1e9)).astype(np.int64)
    cond = "loaded" if payload_mass > 0 else "unloaded"
    name = source or f"synthetic-{cond}-{seed}"
    return Record.from_arrays(name, stamps, q, v, cond, payload_mass)
