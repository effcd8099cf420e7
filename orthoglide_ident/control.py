"""Computed torque control (CTC) with the identified model: its model part (paper Sect. 5.2, Table
4).

The paper's CTC is the IDIM along the reference on top of a linear part with the same bandwidth
(100 rad/s) as the PID controllers it is compared with. Split as robot controllers are, the linear
part stays in the controller (the driver's PID with velocity feed-forward, at its tick), and the
model part is computed here, ahead of the tick it is for:

    tau_ff[k] = W_b(q_d, qd_d, qdd_d) chi_b + W_kl m_7       IDIM along the reference, N (eq. 29)
    v_ff[k]   = tau_ff[k] / g_tau                            eq. (17) inverted, A

v_tau[k] is held over [t_k, t_k+1) (zero-order hold), so the reference is taken in the middle of
the hold, t_k + T/2, as the identification does (``zoh_shift``). chi_b are the identified base
parameters (names of the robot model's ``names``, model/robot.py; parameters absent from a
result, e.g. cancelled as non-essential, count as 0), m_7 the payload mass put in the model (the
paper uses the nominal weighed mass), g_tau the drive gains (identified, the manufacturer's —
the Orthoglide's 2001 N/A — or any others). The robot is any RobotModel (default the
Orthoglide); every size comes from it.

A robot with a transmission (issue 33) is identified in actuator space: ``feedforward_currents``
maps the joint-side reference to the motors (``model_reference``) and returns one current per
motor, v_m = diag(g)⁻¹ N⁻ᵀ τ_j plus the motors' own inertia and friction.

Pure numpy, no ROS: ``feedforward`` is vectorised over samples; the ctc node calls
``feedforward_currents`` on batches of setpoints.
"""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.model.robot import RobotModel

if TYPE_CHECKING:
    from orthoglide_ident.results import IdentificationResult

FF_CHUNK = 4096  # samples per call of the regressor in ``feedforward`` (bounds memory)


@dataclass(frozen=True)
class CTCParameters:
    """What the CTC needs from an identification: g_tau (n_j,) N/A or N·m/A, chi_b (n_b,) in
    ``model.names`` order (absent parameters 0), payload mass m_7 in kg, and the robot model."""

    drive_gains: np.ndarray
    chi_b: np.ndarray
    payload_mass: float
    names: tuple[str, ...] = field(default=())  # the names the values came with
    model: RobotModel = field(kw_only=True, compare=False)  # the robot (passed, never defaulted)

    @property
    def robot(self) -> RobotModel:
        return self.model

    @classmethod
    def from_values(
        cls,
        names: Sequence[str],
        values: Sequence[float],
        drive_gains: Sequence[float],
        payload_mass: float,
        model: RobotModel,
    ) -> CTCParameters:
        """Validate and order: unknown or repeated names, non-finite values, gains that are not
        one positive number per joint or a negative payload mass raise ConfigError."""
        robot = model
        bm_names = robot.names
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
            raise ConfigError(
                f"unknown base parameter name(s) {', '.join(unknown[:5])}: expected names of the "
                f"{robot.name} base model (e.g. {', '.join(bm_names[:3])})"
            )
        if len(set(names)) != len(names):
            raise ConfigError("repeated base parameter names")
        if not np.all(np.isfinite(values)):
            raise ConfigError("non-finite base parameter value(s)")
        if g.shape != (robot.n_joints,) or not np.all(np.isfinite(g)) or np.any(g <= 0):
            raise ConfigError(f"drive_gains must be {robot.n_joints} positive numbers "
                              f"({', '.join(robot.gain_units)}), got {g.tolist()}")
        if not (math.isfinite(m7) and m7 >= 0):
            raise ConfigError(f"payload mass must be a finite mass >= 0 kg, got {payload_mass}")
        chi_b = np.zeros(len(bm_names))
        chi_b[[index[n] for n in names]] = values
        return cls(g, chi_b, m7, tuple(names), model=model)

    @classmethod
    def from_result(cls, result: IdentificationResult, payload_mass: float | None = None,
                    drive_gains: Sequence[float] | None = None, essential: bool = False, *,
                    model: RobotModel) -> CTCParameters:
        """From an ``IdentificationResult``; ``payload_mass`` (kg) is the payload on the robot now
        (default: the result's, known or estimated), ``drive_gains`` override the result's (e.g. the
        manufacturer's); ``essential`` takes the essential-parameter result (Sect. 5.2)."""
        if essential:
            if result.essential is None:
                raise ConfigError(
                    "the identification has no essential-parameter result (identify --essential)"
                )
            result = result.essential
        if payload_mass is None:
            payload_mass = result.payload_mass.value if result.payload_mass is not None else 0.0
        gains = [g.value for g in result.drive_gains] if drive_gains is None else drive_gains
        return cls.from_values(
            [p.name for p in result.parameters],
            [p.value for p in result.parameters],
            gains,
            payload_mass,
            model,
        )

    @classmethod
    def from_message_fields(cls, fields: Mapping[str, Any], payload_mass: float | None = None, *,
                            model: RobotModel) -> CTCParameters:
        """From the fields of orthoglide_msgs/IdentifiedParameters (names, values, drive_gains,
        payload_mass; ``IdentificationResult.message_fields()`` or a received message's)."""
        try:
            names, values, gains = fields["names"], fields["values"], fields["drive_gains"]
            m7 = fields.get("payload_mass", 0.0) if payload_mass is None else payload_mass
        except (KeyError, TypeError) as exc:
            raise ConfigError(f"identified parameters lack field {exc}") from None
        return cls.from_values(list(names), list(values), list(gains), m7, model)

    def with_gains(self, drive_gains: Sequence[float]) -> CTCParameters:
        """The same model with other drive gains (N/A or N·m/A)."""
        return CTCParameters.from_values(self.names or self.robot.names, self._values(),
                                         drive_gains, self.payload_mass, self.model)

    def _values(self) -> np.ndarray:
        if not self.names:
            return self.chi_b
        index = {n: i for i, n in enumerate(self.robot.names)}
        return self.chi_b[[index[n] for n in self.names]]


def feedforward(
    q_d: np.ndarray, qd_d: np.ndarray, qdd_d: np.ndarray, params: CTCParameters
) -> np.ndarray:
    """IDIM forces along a reference: tau (N, n_j) N or N·m = W_b chi_b + W_kl m_7 (eq. 29),
    evaluated in chunks of FF_CHUNK samples. q_d, qd_d, qdd_d: (N, n_j) in the joints' units."""
    robot = params.robot
    n_j = robot.n_joints
    q_d, qd_d, qdd_d = (np.atleast_2d(np.asarray(a, dtype=float)) for a in (q_d, qd_d, qdd_d))
    if not (q_d.shape == qd_d.shape == qdd_d.shape and q_d.shape[1:] == (n_j,)):
        raise ConfigError(f"reference arrays must all be (N, {n_j}), got {q_d.shape}, "
                          f"{qd_d.shape}, {qdd_d.shape}")
    N = len(q_d)
    tau = np.empty((N, n_j))
    for s in range(0, N, FF_CHUNK):
        sl = slice(s, min(s + FF_CHUNK, N))
        X = robot.observation_block(q_d[sl], qd_d[sl], qdd_d[sl])  # (n_b + 1, n_j, n)
        tau[sl] = (np.tensordot(params.chi_b, X[:-1], axes=1) + params.payload_mass * X[-1]).T
    return tau


def model_reference(q_d: np.ndarray, qd_d: np.ndarray, qdd_d: np.ndarray,
                    robot: RobotModel) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A joint-side reference in the model's coordinates: for a robot with a transmission
    (model/transmission.py, identified in actuator space) the motors' q_m = N q_j + offset,
    q̇_m = N q̇_j, q̈_m = N q̈_j; else the reference as it is."""
    ref = tuple(np.atleast_2d(np.asarray(x, dtype=float)) for x in (q_d, qd_d, qdd_d))
    t = robot.transmission
    if t is None:
        return ref
    return t.to_actuator_position(ref[0]), t.to_actuator_rate(ref[1]), t.to_actuator_rate(ref[2])


def feedforward_currents(q_d: np.ndarray, qd_d: np.ndarray, qdd_d: np.ndarray,
                         params: CTCParameters) -> np.ndarray:
    """Model feed-forward currents v_ff (N - 1, n_j) A for ticks 0..N-2 of a joint-side reference
    sampled at N consecutive ticks: the IDIM force (eq. 29) in the middle of each tick's
    zero-order hold (the mean of two consecutive samples, as the identification evaluates the
    model at t_k + T/2), divided by the drive gains (eq. 17). This is the model part of the
    paper's CTC; the linear part (PID with velocity feed-forward, 100 rad/s) is the robot
    controller's own.

    With a transmission the columns are the motors': the actuator-space model's rows are
    N⁻ᵀ τ_j plus each motor's own terms (model/actuator_space.py), so this is
    v_m = diag(g)⁻¹ (N⁻ᵀ τ_j + ia q̈_m + fv q̇_m + fs sign(q̇_m) + off) per motor."""
    ref = model_reference(q_d, qd_d, qdd_d, params.robot)
    mid = [0.5 * (a[:-1] + a[1:]) for a in ref]
    return feedforward(*mid, params) / params.drive_gains
