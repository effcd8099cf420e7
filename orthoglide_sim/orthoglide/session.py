"""Tick-by-tick simulation of the robot and its controller for the driver node (no ROS here).

One controller tick k has three phases, so that the node can publish between them:

    q_meas = session.measure()          encoder reading at t_k (1 um)
    v_tau  = session.control()          the controller's current for [t_k, t_k+1), limited
    session.advance()                   the plant integrated over the tick (Pinocchio, RK4;
    ``plant``)

Controllers ("pid", "pid_ff", "ctc", "external", see orthoglide_sim.orthoglide.simulator): "ctc"
adds the
model feed-forward current offered for tick k (``offer_feedforward``) to the "pid_ff" law;
A tick whose own feed-forward has not arrived holds the last one for at most FF_HOLD_TICKS (the
model current of the reference 20 ms earlier: 4-5x closer than none), then runs on PID + velocity
feed-forward alone until a fresh one comes: never a model current of a tick long past.
"external" applies the latest current command (``offer_command``, zero-order hold) and holds the
robot with its PID until the first command and whenever commands stop for INPUT_TIMEOUT_TICKS. The
reference
(``Reference``) is known ``lead`` ticks ahead, so a controller outside the driver can compute its
feed-forward before the tick it is for. Payload, trajectory and controller can change while the
session runs (a person mounting a payload, an operator switching the motion): trajectories blend
smoothly into each other inside the safe box.

Safety: every current is limited per joint (``current_limit``, A); a non-finite command, or a
plant that leaves its stroke, puts the session in ``fault`` (the simulated robot stops, brakes on)
with the reason; ``reset()`` puts it back at rest on the reference.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from orthoglide_ident.errors import ConfigError, OrthoglideError
from orthoglide_sim.common.closed_loop import quantise
from orthoglide_sim.common.reference import Reference
from orthoglide_sim.orthoglide import simulator as sm
from orthoglide_sim.orthoglide.plant import Plant
from orthoglide_sim.orthoglide.reduced_plant import ReducedIntegrator
from orthoglide_sim.orthoglide.truth import TrueParameters, load_parameters

DEFAULT_CURRENT_LIMIT = 1.0  # A per joint (~2 kN, 5x the peak force of the exciting motions)
INPUT_TIMEOUT_TICKS = 100  # an outside command older than this is not used
# a tick without its own feed-forward holds the last one this many ticks at most: on test1/test2
# the model current held 20 ticks is off by 0.007-0.008 A rms (max 0.045-0.051 A) where none at all
# is off by 0.033-0.035 A rms (max 0.056-0.080 A); from 30-50 ticks on the held one's worst error
# passes that of none (velocity reversals flip the friction), and at 100 (the bound before) it is
# 0.070-0.073 A; then PID + velocity feed-forward alone
FF_HOLD_TICKS = 20
# The plant's integration: "reduced" (Pinocchio reduced to the actuators once per tick, the RK4
# steps
# compiled: reduced_plant, the driver's default) or "tree" (the reference: Pinocchio's constraint
# dynamics on the 15-joint tree at every RK4 stage, simulator.Integrator, ~8x the CPU)
INTEGRATORS = {"reduced": ReducedIntegrator, "tree": sm.Integrator}


def parse_payload(value: object) -> str | float:
    """ROS parameter 'payload': none, 1.983, 1.136 or a custom mass in kg (string or number)."""
    v = str(value).strip().lower()
    if v in ("none", "", "0", "0.0"):
        return "none"
    if v in ("1.983", "1.136"):
        return v
    try:
        mass = float(v)
    except ValueError:
        raise ConfigError(
            f"payload must be none, 1.983, 1.136 or a mass in kg, got {value!r}"
        ) from None
    if not (0.0 < mass < 20.0):
        raise ConfigError(f"payload mass must be in (0, 20) kg, got {value!r}")
    return mass


@dataclass
class DriverStats:
    """What the driver counts: saturated ticks, ticks without a fresh feed-forward (``ff_missing``:
    the last one held, ``ff_expired`` of them past FF_HOLD_TICKS: none), applied command ages in
    ticks (external mode: age 1 = the command computed from the previous tick)."""

    saturated: int = 0
    ff_missing: int = 0
    ff_expired: int = 0
    ff_used: int = 0
    command_ages: dict[int, int] = field(default_factory=dict)
    no_command: int = 0

    def age_summary(self) -> str:
        n = sum(self.command_ages.values())
        if not n:
            return "no command applied"
        ages = sorted(self.command_ages.items())
        within_1 = sum(c for a, c in ages if a <= 1)
        return (
            f"{n} commands applied, {100 * within_1 / n:.2f} % from the previous tick or newer, "
            f"ages {', '.join(f'{a}: {c}' for a, c in ages[:6])}{' ...' if len(ages) > 6 else ''}"
        )


class DriverSession:
    """The simulated robot and its 1 kHz controller, one tick at a time (see the module doc)."""

    def __init__(
        self,
        payload: str | float = "none",
        trajectory: str = "exciting",
        controller: str = "pid",
        params: TrueParameters | None = None,
        seed: int = 0,
        noise: bool = True,
        current_limit: float | list[float] = DEFAULT_CURRENT_LIMIT,
        lead: int = 50,
        plant: str = "reduced",
    ):
        self.params = params or load_parameters()
        if plant not in INTEGRATORS:
            raise ConfigError(f"plant must be one of {', '.join(INTEGRATORS)}, got {plant!r}")
        self.integrator = INTEGRATORS[plant]
        self.controller = self._checked_controller(controller)
        self.payload = parse_payload(payload)
        self.reference = Reference(trajectory)
        self.current_limit = self._checked_limit(current_limit)
        if not (isinstance(lead, int) and 0 <= lead <= 10_000):
            raise ConfigError(
                f"setpoint lead must be an integer number of ticks in [0, 10000], got {lead!r}"
            )
        self.lead = lead
        self.rng = np.random.default_rng(seed)
        self.noise = bool(noise)
        self.drive = sm.drive_model(self.params)
        self.stats = DriverStats()
        self.k = 0
        self.fault: str | None = None
        self._feedforward: dict[int, np.ndarray] = {}
        self._ff_last: tuple[int, np.ndarray] = (-FF_HOLD_TICKS - 1, np.zeros(3))  # none yet
        self._command: tuple[int, np.ndarray] | None = None
        self._v_tau = np.zeros(3)
        self._start_at_rest_on_reference()

    # ---- configuration (may change while running) ------------------------------------------------
    @staticmethod
    def _checked_controller(controller: str) -> str:
        if controller not in sm.CONTROLLERS:
            raise ConfigError(
                f"controller must be one of {', '.join(sm.CONTROLLERS)}, got {controller!r}"
            )
        return controller

    @staticmethod
    def _checked_limit(limit: float | list[float]) -> np.ndarray:
        lim = (
            np.broadcast_to(np.asarray(limit, dtype=float), (3,)).copy()
            if np.size(limit) in (1, 3)
            else None
        )
        if lim is None or not np.all(np.isfinite(lim)) or np.any(lim <= 0):
            raise ConfigError(
                f"current_limit must be one or three positive currents in A, got {limit!r}"
            )
        return lim

    def set_controller(self, controller: str) -> None:
        self.controller = self._checked_controller(controller)

    def set_current_limit(self, limit: float | list[float]) -> None:
        self.current_limit = self._checked_limit(limit)

    def set_payload(self, payload: object) -> None:
        """Mount another payload (kg or a named one); the motion goes on from the same state."""
        self.payload = parse_payload(payload)
        q, qd = self.sim.q, self.sim.qd
        self.plant = Plant(self.params, self.payload)
        self.sim = self.integrator(self.plant, self.drive, q, qd)

    def set_trajectory(self, name: str) -> int:
        """Blend into trajectory ``name`` after the setpoints already published; returns its first
        tick."""
        k_start = self.k + self.lead + 1
        self.reference.switch(name, k_start)
        return k_start

    def _start_at_rest_on_reference(self) -> None:
        q0, qd0, qdd0 = (v[0] for v in self.reference.evaluate(self.k))
        self.plant = Plant(self.params, self.payload)
        self.sim = self.integrator(self.plant, self.drive, q0, qd0)
        self.pid = sm.preloaded_pid(self.plant, q0, qd0, qdd0,
                                   velocity_ff=self.controller != "pid")

    def reset(self) -> None:
        """Clear a fault: the robot is put back on the reference of the current tick."""
        self.fault = None
        self._command = None
        self._start_at_rest_on_reference()

    # ---- inputs from outside controllers ---------------------------------------------------------
    def offer_command(self, k_from: int, current) -> None:
        """External mode: current (3,) A computed from the joint state of tick ``k_from``."""
        current = np.asarray(current, dtype=float)
        if current.shape != (3,) or not np.all(np.isfinite(current)):
            self._stop(
                f"refused current command {np.asarray(current).tolist()} computed at tick "
                f"{k_from}: "
                ""
                ""
                ""
                ""
                "not three finite currents"
            )
            return
        if self._command is None or k_from >= self._command[0]:
            self._command = (k_from, current)

    def offer_feedforward(self, k_for: int, current) -> None:
        """CTC mode: the model feed-forward current (3,) A for tick ``k_for``."""
        current = np.asarray(current, dtype=float)
        if current.shape != (3,) or not np.all(np.isfinite(current)):
            if self.controller == "ctc":
                self._stop(
                    f"refused feed-forward {current.tolist()} for tick {k_for}: not three finite "
                    "currents"
                )
            return
        if k_for >= self.k:
            self._feedforward[k_for] = current

    def has_feedforward(self, k: int) -> bool:
        return k in self._feedforward

    def has_command_from(self, k: int) -> bool:
        return self._command is not None and self._command[0] >= k

    def ready_ahead(self, limit: int) -> int:
        """How many ticks from k on can be computed now without waiting for an input (``limit``
        at most): under pid and pid_ff every one, under ctc those whose feed-forward is in (one
        after another), under external none (its command comes from the tick's own state)."""
        if self.fault or self.controller == "external":
            return 0
        if self.controller != "ctc":
            return max(limit, 0)
        n = 0
        while n < limit and self.k + n in self._feedforward:
            n += 1
        return n

    # ---- one tick --------------------------------------------------------------------------------
    def step(self) -> tuple[np.ndarray, np.ndarray]:
        """Tick k whole: its encoder reading and current (q_meas, v_tau), the plant advanced to
        k + 1 (or stopped: ``fault``)."""
        q = self.measure()
        v = self.control(q)
        self.advance()
        return q, v

    def measure(self) -> np.ndarray:
        """q_meas (3,) m of tick k: the 1 um encoder reading."""
        return quantise(self.sim.q, sm.ENCODER_RESOLUTION)

    def setpoint(self, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(q_d, qd_d, qdd_d) (3,) each, of tick k (any tick up to k + lead is final)."""
        return self.reference.at(k)

    def control(self, q_meas: np.ndarray) -> np.ndarray:
        """The current v_tau (3,) A held over [t_k, t_k+1): the controller's law, then the limit."""
        q_d, qd_d, _ = self.setpoint(self.k)
        self.pid.velocity_ff = self.controller != "pid"
        v = self.pid.current(q_meas, q_d, qd_d)  # the PID keeps its state in every mode (bumpless)
        if self.controller == "ctc":
            v = v + self._take_feedforward()
        else:
            self._feedforward.pop(self.k, None)  # received while another controller runs: not kept
        if self.controller == "external":
            v = self._take_command(v)
        limited = np.clip(v, -self.current_limit, self.current_limit)
        if np.any(limited != v):
            self.stats.saturated += 1
        self._v_tau = limited
        return limited

    def _take_feedforward(self) -> np.ndarray:
        ff = self._feedforward.pop(self.k, None)
        for stale in [k for k in self._feedforward if k < self.k]:
            del self._feedforward[stale]
        if ff is None:  # hold the last one a few ticks: a tick late beats no model at all
            self.stats.ff_missing += 1
            if self.k - self._ff_last[0] <= FF_HOLD_TICKS:
                return self._ff_last[1]
            self.stats.ff_expired += 1  # too old: PID + velocity feed-forward alone
            return np.zeros(3)
        self.stats.ff_used += 1
        self._ff_last = (self.k, ff)
        return ff

    def _take_command(self, v_pid: np.ndarray) -> np.ndarray:
        """The latest outside command; the driver's own PID holds the robot on its reference until
        the first one arrives and whenever the latest is older than INPUT_TIMEOUT_TICKS."""
        if self._command is None or self.k - self._command[0] > INPUT_TIMEOUT_TICKS:
            self.stats.no_command += 1
            return v_pid
        age = self.k - self._command[0]
        self.stats.command_ages[age] = self.stats.command_ages.get(age, 0) + 1
        return self._command[1]

    def advance(self) -> None:
        """Integrate the plant over the tick under v_tau (+ current noise); k -> k + 1."""
        noise = self.rng.normal(0.0, sm.CURRENT_NOISE_STD, 3) if self.noise else 0.0
        try:
            self.sim.tick(self._v_tau + noise)
        except OrthoglideError as e:
            self._stop(str(e))
            return
        self.k += 1
        self.reference.settle(self.k)

    def _stop(self, reason: str) -> None:
        if self.fault is None:
            self.fault = reason

