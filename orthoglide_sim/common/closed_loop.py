"""The one closed loop every simulated robot runs: encoder, PID, zero-order hold, plant.

Per controller tick k (t_k = k TICK):

1. the encoder reads q_meas[k] = quantise(q_seen(t_k) + encoder noise) (``quantise``);
2. the controller computes the current reference v_tau[k] (A) from q_meas[k] (``PID``, or any
   law ``control(k, q_meas)``: a model feed-forward added, an outside command);
3. the drive applies v_tau[k] + n[k] (current noise, held with the reference) over [t_k, t_k+1):
   the robot's ``advance`` integrates its plant over the tick and stops it (WorkspaceError) if
   it leaves its workspace.

(q_meas[k], v_tau[k]) carry the same stamp t_k. What differs between robots is only what the
encoder sees (a joint, a motor behind a spring, a motor of a coupled wrist) and how the plant is
integrated (Pinocchio RK4 on the Orthoglide's tree, MuJoCo for the arms and chains): the robot's
``read`` and ``advance``.

The PID is the paper's linear part (Sect. 5.2): a triple closed-loop pole at -omega tuned on an
inertia J (a nominal mass for the Orthoglide, each joint's diagonal inertia for an arm):
Kp = 3 J omega², Kd = 3 J omega, Ki = J omega³; D on the backward difference of the quantised
position (optionally low-passed), with or without velocity feed-forward; the torque converted to
a current with the controller's nominal gain, optionally clipped to a current limit.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

TICK = 1.0e-3  # s, the controller period (1 kHz)
OMEGA = 100.0  # rad/s, bandwidth of the PID's linear part (triple pole)


def quantise(q: np.ndarray, resolution: float | np.ndarray) -> np.ndarray:
    """Encoder reading: q rounded to the nearest count of ``resolution`` (per joint or one)."""
    return np.round(np.asarray(q) / resolution) * resolution


def triple_pole(inertia, omega: float = OMEGA) -> tuple:
    """(Kp, Ki, Kd) placing a triple pole at -omega on ``inertia`` (scalar or per joint)."""
    return 3 * inertia * omega**2, inertia * omega**3, 3 * inertia * omega


@dataclass
class PID:
    """The controller's linear part (see the module docstring); arrays (n,) or scalars."""

    kp: np.ndarray | float
    ki: np.ndarray | float
    kd: np.ndarray | float
    nominal_gain: np.ndarray | float  # the gain the controller converts torque to current with
    q_prev: np.ndarray  # last encoder reading
    integral: np.ndarray  # ∫ e dt
    velocity_ff: bool = True  # False: D on the measurement alone (Kd acts on -v_est)
    current_limit: np.ndarray | None = None  # A; None: no clipping
    velocity_filter: float | None = None  # s, first-order low-pass of v_est; None: none
    v_filtered: np.ndarray | None = None  # the low-passed velocity estimate

    @classmethod
    def tuned(cls, inertia, nominal_gain, q_prev: np.ndarray, torque0: np.ndarray,
              omega: float = OMEGA, velocity_ff: bool = True,
              current_limit: np.ndarray | None = None, velocity_filter: float | None = None,
              v0: np.ndarray | None = None) -> PID:
        """Triple pole at -omega on ``inertia``; the integrator pre-loaded with the torque
        ``torque0`` the reference needs at t_0 (the plant starts on the reference); ``v0``: the
        filtered velocity's start (with ``velocity_filter``)."""
        kp, ki, kd = triple_pole(inertia, omega)
        return cls(kp, ki, kd, nominal_gain, q_prev, torque0 / ki, velocity_ff, current_limit,
                   velocity_filter, None if v0 is None else np.asarray(v0, float).copy())

    def current(self, q_meas: np.ndarray, q_ref: np.ndarray, qd_ref: np.ndarray,
                dt: float = TICK) -> np.ndarray:
        """One tick of length ``dt``: the current reference v_tau (n,) A."""
        e = q_ref - q_meas
        self.integral = self.integral + e * dt
        v_est = (q_meas - self.q_prev) / dt
        self.q_prev = q_meas
        if self.velocity_filter is not None:
            self.v_filtered = self.v_filtered + dt / (dt + self.velocity_filter) * (
                v_est - self.v_filtered)
            v_est = self.v_filtered
        qd_term = qd_ref if self.velocity_ff else 0.0
        v = (self.kp * e + self.ki * self.integral + self.kd * (qd_term - v_est)) / \
            self.nominal_gain
        if self.current_limit is None:
            return v
        return np.clip(v, -self.current_limit, self.current_limit)


@dataclass
class LoopResult:
    """Per tick (N, n): what the controller logged and what the plant did."""

    q_meas: np.ndarray  # encoder readings
    v_tau: np.ndarray  # current references, A (held over [t_k, t_k+1))
    current: np.ndarray  # currents in the motors over the tick: v_tau + noise, A
    q: np.ndarray  # true positions at t_k
    qd: np.ndarray  # true velocities at t_k
    logged: np.ndarray | None  # what the robot's advance returned per tick (None: nothing)
    saturated: int  # ticks at which some joint's current reference reached its limit


# read() -> (q, qd, q_seen): the true state at t_k and what the encoder sees
Read = Callable[[], tuple[np.ndarray, np.ndarray, np.ndarray]]
# advance(k, current) -> None or a per-tick quantity to log; integrates [t_k, t_k+1)
Advance = Callable[[int, np.ndarray], np.ndarray | None]


def run_closed_loop(read: Read, control: Callable[[int, np.ndarray], np.ndarray],
                    advance: Advance, noise: np.ndarray, resolution: float | np.ndarray,
                    encoder_noise: np.ndarray | None = None,
                    current_limit: np.ndarray | None = None) -> LoopResult:
    """Run N = len(noise) ticks (module docstring). ``noise`` (N, n) A: current noise held with
    each tick's reference; ``encoder_noise`` (N, n): added to what the encoder sees before it
    rounds; ``current_limit``: saturated ticks are counted against it."""
    N, n = np.shape(noise)
    out = LoopResult(*(np.empty((N, n)) for _ in range(5)), logged=None, saturated=0)
    for k in range(N):
        out.q[k], out.qd[k], seen = read()
        if encoder_noise is not None:
            seen = seen + encoder_noise[k]
        out.q_meas[k] = quantise(seen, resolution)
        v = control(k, out.q_meas[k])
        out.v_tau[k] = v
        out.current[k] = v + noise[k]
        if current_limit is not None:
            out.saturated += bool(np.any(np.abs(v) >= current_limit))
        logged = advance(k, out.current[k])
        if logged is not None:
            if out.logged is None:
                out.logged = np.empty((N, *np.shape(logged)))
            out.logged[k] = logged
    return out
