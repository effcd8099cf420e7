"""Computed torque control (CTC) with the identified model (paper Sect. 5.2, Table 4).

The paper's CTC is a model-based feed-forward on top of a linear part with the same bandwidth
(100 rad/s) as the PID controllers it is compared with. Here, per actuator j at tick k:

    e_k       = q_d(t_k) - q_meas[k]                          position error, m
    v_est[k]  = (q_meas[k] - q_meas[k-1]) / T                  backward difference, m/s
    I_k       = I_{k-1} + e_k T                                integral of the error, m s
    tau_ff[k] = W_b(q_d, qd_d, qdd_d) chi_b + W_kl m_7         IDIM along the reference, N (eq. 29)
    tau[k]    = tau_ff[k] + Kp e_k + Ki I_k + Kd (qd_d(t_k) - v_est[k])
    v_tau[k]  = tau[k] / g_tau                                 eq. (17) inverted, A

The linear part is the simulator's "pid_ff" law (triple closed-loop pole at OMEGA = 100 rad/s on a
nominal foot mass of 10 kg: Kp = 3 M w^2, Kd = 3 M w, Ki = M w^3), so CTC, simple PID and PID with
velocity feed-forward differ only by the feed-forward, as in the paper. chi_b are the identified
base parameters (names of ``base_model().names``; parameters absent from a result, e.g. cancelled
as non-essential, count as 0), m_7 the payload mass put in the model (the paper uses the nominal
weighed mass), g_tau the drive gains (identified, manufacturer's 2001 N/A, or any others).

v_tau[k] is held over [t_k, t_k+1) (zero-order hold): by default the feed-forward is evaluated on
the reference at t_k + T/2, the middle of the hold, as the identification does (``zoh_shift``).

Pure numpy, no ROS: ``feedforward`` is vectorised over samples; ``CTC`` evaluates the reference
and the feed-forward in blocks ahead and applies the feedback per tick in a few microseconds.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Callable, Mapping, Sequence

import numpy as np

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.model.base import base_model

if TYPE_CHECKING:
    from orthoglide_ident.results import IdentificationResult

TICK = 1.0e-3  # s, controller period (1 kHz)
G_TAU_MANUFACTURER = 637.0 * math.pi  # N/A, ~2001.2
JOINT_NAMES = ("q11", "q12", "q13")
FF_CHUNK = 4096  # samples per call of the regressor in ``feedforward`` (bounds memory)

Reference = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray, np.ndarray]]
"""t (N,) s -> (q_d, qd_d, qdd_d), each (N, 3) in m, m/s, m/s² (e.g. a sim trajectory's evaluate)."""


@dataclass(frozen=True)
class LinearGains:
    """PID gains of the linear part, per actuator: N/m, N s/m, N/(m s)."""

    kp: float
    kd: float
    ki: float

    @classmethod
    def from_bandwidth(cls, omega: float = 100.0, m_nominal: float = 10.0) -> "LinearGains":
        """Triple closed-loop pole at ``omega`` (rad/s) on a mass ``m_nominal`` (kg): the
        simulator's gains by default (Kp = 3.0e5, Kd = 3.0e3, Ki = 1.0e7)."""
        if not (omega > 0 and m_nominal > 0 and math.isfinite(omega) and math.isfinite(m_nominal)):
            raise ConfigError(f"omega and m_nominal must be positive, got {omega}, {m_nominal}")
        return cls(3.0 * m_nominal * omega**2, 3.0 * m_nominal * omega, m_nominal * omega**3)


@dataclass(frozen=True)
class CTCParameters:
    """What the CTC needs from an identification: g_tau (3,) N/A, chi_b (n_b,) in
    ``base_model().names`` order (absent parameters 0), payload mass m_7 in kg."""

    drive_gains: np.ndarray
    chi_b: np.ndarray
    payload_mass: float
    names: tuple[str, ...] = field(default=())  # the names the values came with

    @classmethod
    def from_values(cls, names: Sequence[str], values: Sequence[float], drive_gains: Sequence[float],
                    payload_mass: float) -> "CTCParameters":
        """Validate and order: unknown or repeated names, non-finite values, gains that are not 3
        positive numbers or a negative payload mass raise ConfigError."""
        bm_names = base_model().names
        index = {n: i for i, n in enumerate(bm_names)}
        names = [str(n) for n in names]
        try:
            values = np.asarray(values, dtype=float).ravel()
            g = np.asarray(drive_gains, dtype=float).ravel()
            m7 = float(payload_mass)
        except (TypeError, ValueError) as exc:
            raise ConfigError(f"identified parameters are not numbers: {exc}") from None
        if len(names) != len(values):
            raise ConfigError(f"{len(names)} parameter names but {len(values)} values")
        if not names:
            raise ConfigError("no dynamic parameters given: run an identification first")
        unknown = [n for n in names if n not in index]
        if unknown:
            raise ConfigError(f"unknown base parameter name(s) {', '.join(unknown[:5])}: expected names of the "
                              f"Orthoglide base model (e.g. {', '.join(bm_names[:3])})")
        if len(set(names)) != len(names):
            raise ConfigError("repeated base parameter names")
        if not np.all(np.isfinite(values)):
            raise ConfigError("non-finite base parameter value(s)")
        if g.shape != (3,) or not np.all(np.isfinite(g)) or np.any(g <= 0):
            raise ConfigError(f"drive_gains must be 3 positive numbers (N/A), got {g.tolist()}")
        if not (math.isfinite(m7) and m7 >= 0):
            raise ConfigError(f"payload mass must be a finite mass >= 0 kg, got {payload_mass}")
        chi_b = np.zeros(len(bm_names))
        chi_b[[index[n] for n in names]] = values
        return cls(g, chi_b, m7, tuple(names))

    @classmethod
    def from_result(cls, result: IdentificationResult, payload_mass: float | None = None,
                    drive_gains: Sequence[float] | None = None, essential: bool = False) -> "CTCParameters":
        """From an ``IdentificationResult``; ``payload_mass`` (kg) is the payload on the robot now
        (default: the result's, known or estimated), ``drive_gains`` override the result's (e.g. the
        manufacturer's); ``essential`` takes the essential-parameter result (Sect. 5.2)."""
        if essential:
            if result.essential is None:
                raise ConfigError("the identification has no essential-parameter result (identify --essential)")
            result = result.essential
        if payload_mass is None:
            payload_mass = result.payload_mass.value if result.payload_mass is not None else 0.0
        gains = [g.value for g in result.drive_gains] if drive_gains is None else drive_gains
        return cls.from_values([p.name for p in result.parameters], [p.value for p in result.parameters],
                               gains, payload_mass)

    @classmethod
    def from_message_fields(cls, fields: Mapping[str, Any], payload_mass: float | None = None) -> "CTCParameters":
        """From the fields of orthoglide_msgs/IdentifiedParameters (names, values, drive_gains,
        payload_mass; ``IdentificationResult.message_fields()`` or a received message's)."""
        try:
            names, values, gains = fields["names"], fields["values"], fields["drive_gains"]
            m7 = fields.get("payload_mass", 0.0) if payload_mass is None else payload_mass
        except (KeyError, TypeError) as exc:
            raise ConfigError(f"identified parameters lack field {exc}") from None
        return cls.from_values(list(names), list(values), list(gains), m7)

    def with_gains(self, drive_gains: Sequence[float]) -> "CTCParameters":
        """The same model with other drive gains (N/A)."""
        return CTCParameters.from_values(self.names or base_model().names, self._values(), drive_gains,
                                         self.payload_mass)

    def with_payload(self, payload_mass: float) -> "CTCParameters":
        return CTCParameters.from_values(self.names or base_model().names, self._values(), self.drive_gains,
                                         payload_mass)

    def _values(self) -> np.ndarray:
        if not self.names:
            return self.chi_b
        index = {n: i for i, n in enumerate(base_model().names)}
        return self.chi_b[[index[n] for n in self.names]]


def feedforward(q_d: np.ndarray, qd_d: np.ndarray, qdd_d: np.ndarray, params: CTCParameters) -> np.ndarray:
    """IDIM forces along a reference: tau (N, 3) N = W_b chi_b + W_kl m_7 (eq. 29), evaluated in
    chunks of FF_CHUNK samples. q_d, qd_d, qdd_d: (N, 3) m, m/s, m/s²."""
    q_d, qd_d, qdd_d = (np.atleast_2d(np.asarray(a, dtype=float)) for a in (q_d, qd_d, qdd_d))
    if not (q_d.shape == qd_d.shape == qdd_d.shape and q_d.shape[1:] == (3,)):
        raise ConfigError(f"reference arrays must all be (N, 3), got {q_d.shape}, {qd_d.shape}, {qdd_d.shape}")
    bm = base_model()
    N = len(q_d)
    tau = np.empty((N, 3))
    for s in range(0, N, FF_CHUNK):
        sl = slice(s, min(s + FF_CHUNK, N))
        W, w_m7 = bm.observation(q_d[sl], qd_d[sl], qdd_d[sl])  # (3 n, n_b), rows joint by joint
        tau[sl] = (W @ params.chi_b + w_m7 * params.payload_mass).reshape(3, -1).T
    return tau


class CTC:
    """Per-tick CTC along a reference ``reference(t)`` sampled at t_k = k T.

    ``command(k, q_meas)`` -> v_tau (3,) A. The reference and the feed-forward are computed in
    blocks of ``block`` ticks (one vectorised regressor call each), so a tick costs a few array
    operations. ``ff_lead`` (s): the feed-forward uses the reference at t_k + ff_lead (default
    T/2, the middle of the zero-order hold). ``feedforward_on=False`` gives the "pid_ff" law
    (v_tau = feedback / g_tau) with the same machinery.
    """

    def __init__(self, params: CTCParameters, reference: Reference, gains: LinearGains | None = None,
                 tick: float = TICK, block: int = 1000, ff_lead: float | None = None,
                 feedforward_on: bool = True):
        if not (tick > 0) or block < 1:
            raise ConfigError(f"tick must be > 0 s and block >= 1, got {tick}, {block}")
        self.params = params
        self.reference = reference
        self.gains = gains or LinearGains.from_bandwidth()
        self.tick = float(tick)
        self.block = int(block)
        self.ff_lead = 0.5 * self.tick if ff_lead is None else float(ff_lead)
        self.feedforward_on = feedforward_on
        self._k0 = None  # first tick of the buffered block
        self.reset()

    def set_params(self, params: CTCParameters) -> None:
        """Use another model or gains from the next tick on (the feed-forward buffer is recomputed)."""
        self.params = params
        self._k0 = None

    def reset(self) -> None:
        """Forget the integral and the previous measurement (the next tick assumes v_est = qd_d)."""
        self.integral = np.zeros(3)
        self.q_meas_prev: np.ndarray | None = None

    def _fill(self, k0: int) -> None:
        t = (k0 + np.arange(self.block)) * self.tick
        self._q_d, self._qd_d, _ = (np.asarray(a, float) for a in self.reference(t))
        if self.feedforward_on:
            self._tau_ff = feedforward(*self.reference(t + self.ff_lead), self.params)
        else:
            self._tau_ff = np.zeros((self.block, 3))
        self._k0 = k0

    def setpoint(self, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(q_d, qd_d, tau_ff) at tick k, from the buffer (computing the block holding k if needed)."""
        if self._k0 is None or not (self._k0 <= k < self._k0 + self.block):
            self._fill(k)
        i = k - self._k0
        return self._q_d[i], self._qd_d[i], self._tau_ff[i]

    def force(self, k: int, q_meas: np.ndarray) -> np.ndarray:
        """tau[k] (3,) N for the measured position q_meas (3,) m at tick k; updates the state."""
        q_meas = np.asarray(q_meas, dtype=float)
        q_d, qd_d, tau_ff = self.setpoint(k)
        e = q_d - q_meas
        v_est = qd_d if self.q_meas_prev is None else (q_meas - self.q_meas_prev) / self.tick
        self.integral = self.integral + e * self.tick
        self.q_meas_prev = q_meas
        g = self.gains
        return tau_ff + g.kp * e + g.ki * self.integral + g.kd * (qd_d - v_est)

    def command(self, k: int, q_meas: np.ndarray) -> np.ndarray:
        """v_tau[k] (3,) A = tau[k] / g_tau (eq. 17)."""
        return self.force(k, q_meas) / self.params.drive_gains
