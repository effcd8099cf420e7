"""The coupled-wrist plant checked against a second implementation: Pinocchio's RNEA of the same
rigid bodies with the drive chain's equations written out (coupled_truth's docstring):

    Nᵀ (g ⊙ v - off - Ia ⊙ q̈_m - fv ⊙ q̇_m - fs ⊙ sign q̇_m) = RNEA(q, q̇, q̈),   q̇_m = N q̇, q̈_m = N q̈

at recorded states and currents, q̈ from MuJoCo's forward dynamics (tendons, armature, actuators,
soft friction). Away from zero motor velocity both sides agree to round-off; within the soft
friction's band the friction solved for, f = g ⊙ v - off - Ia ⊙ q̈_m - fv ⊙ q̇_m - N⁻ᵀ RNEA, stays
within ±fs.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from orthoglide_sim.arms.pinocchio_truth import truth_model
from orthoglide_sim.coupled.plant import CoupledPlant
from orthoglide_sim.coupled.record import CoupledRecord


@dataclass
class Balance:
    """Per sampled tick (k, n): the balance's error (N·m, joint side), the motor friction solved
    for (N·m, motor side), the smallest |q̇_m| (k,); the largest |RNEA| (N·m) and fs (n,)."""

    error: np.ndarray
    friction: np.ndarray
    slowest: np.ndarray
    tau_max: float
    coulomb: np.ndarray

    def sliding_error(self, band: float) -> tuple[float, float]:
        """Largest |error| / tau_max over the ticks where every |q̇_m| > ``band`` rad/s, and the
        share of such ticks."""
        s = self.slowest > band
        return float(np.abs(self.error[s]).max() / self.tau_max) if s.any() else np.nan, float(
            s.mean()
        )


def torque_balance(rec: CoupledRecord, step: int = 5) -> Balance:
    """The balance at every ``step``-th tick of ``rec`` (its true states and plant currents)."""
    t, N = rec.truth, rec.truth.reduction
    plant = CoupledPlant(t, rec.payload)
    model, _ = truth_model(t.rigid, rec.payload)
    data = model.createData()
    g, ia, fv, fs, off = (
        t.motor_array(k) for k in ("gain", "inertia", "viscous", "coulomb", "offset")
    )
    err, friction, slowest, tau_max = [], [], [], 0.0
    for k in range(0, rec.q_true.shape[0], step):
        q, qd, i = rec.q_true[k], rec.qd_true[k], rec.current[k]
        qdd = plant.acceleration(q, qd, i)
        qdm, qddm = N @ qd, N @ qdd
        tau = pin.rnea(model, data, q, qd, qdd)
        driving = g * i - off - ia * qddm - fv * qdm  # what is left for the rigid arm and friction
        err.append(N.T @ (driving - fs * np.sign(qdm)) - tau)
        friction.append(driving - np.linalg.solve(N.T, tau))
        slowest.append(np.abs(qdm).min())
        tau_max = max(tau_max, float(np.abs(tau).max()))
    return Balance(np.array(err), np.array(friction), np.array(slowest), tau_max, fs)
