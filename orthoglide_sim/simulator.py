"""Sampled-data simulation: 1 kHz controller with zero-order hold, plant integrated at 10 kHz (RK4).

Integration: RK4 at 10 kHz. The configuration-dependent terms of the Lagrange equations (M, dM/dq,
dV/dq, J_t and their first derivatives) are evaluated once per window of GEOMETRY_TICKS = 2 ticks,
at the predicted middle of the window, and expanded to first order inside it (plant.forward_dynamics_local): this is what
makes the plant run several times faster than real time; ``exact=True`` uses the full equations at
every stage.

Timing of one controller tick k (t_k = k T, T = 1 ms):
  1. the encoder is read: q_meas[k] = round(q(t_k) / 1 um) * 1 um;
  2. the controller computes the current reference v_tau[k] (A) from q_meas and the reference;
  3. during [t_k, t_k+1) the drive applies tau = g_tau_true * (v_tau[k] + n[k]) (n: current noise,
     held with the reference) plus, if switched on, the ball-screw force ripple;
  4. the plant is integrated with SUBSTEPS RK4 steps.
(q_meas[k], v_tau[k]) carry the same stamp t_k.

Controllers (all with the same linear part, a triple closed-loop pole at OMEGA = 100 rad/s on a
nominal foot mass M_NOMINAL = 10 kg): Kp = 3 M w^2, Kd = 3 M w, Ki = M w^3, so
Kp = 3.0e5 N/m, Kd = 3.0e3 N s/m, Ki = 1.0e7 N/(m s):
  - "pid":    F = Kp e + Ki int(e) - Kd v_est                       (simple PID, D on measurement)
  - "pid_ff": F = Kp e + Ki int(e) + Kd (qd_ref - v_est)            (PID with velocity feed-forward)
  - "external": v_tau given per tick (e.g. received on a topic).
v_est is the backward difference of the quantised position. The force command is converted to a
current with the manufacturer's gain 637 pi ~ 2001 N/A: v_tau = F / 2001.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import partial
from typing import NamedTuple

import jax

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

from orthoglide_sim import plant as pl  # noqa: E402
from orthoglide_sim.true_parameters import G_TAU_MANUFACTURER  # noqa: E402

TICK = 1.0e-3  # s, controller period (1 kHz)
SUBSTEPS = 10  # RK4 steps per tick: 10 kHz integration
ENCODER_RESOLUTION = 1.0e-6  # m
CURRENT_NOISE_STD = 1.0e-3  # A, white, held over the tick
OMEGA = 100.0  # rad/s, bandwidth of the linear part
M_NOMINAL = 10.0  # kg
KP = 3.0 * M_NOMINAL * OMEGA**2
KD = 3.0 * M_NOMINAL * OMEGA
KI = M_NOMINAL * OMEGA**3
CONTROLLERS = ("pid", "pid_ff", "external")


class DriveModel(NamedTuple):
    """What lies between the current reference and the plant (jax pytree)."""

    g_tau: jnp.ndarray  # (3,) true drive gains N/A
    ripple_amplitude: jnp.ndarray  # () N, 0 = off
    ripple_lead: jnp.ndarray  # () m
    ripple_phase: jnp.ndarray  # (3,) rad


def drive_model(params, ripple: bool | None = None) -> DriveModel:
    """DriveModel from TrueParameters (ripple on/off taken from params unless given)."""
    r = params.screw_ripple
    on = r["enabled"] if ripple is None else ripple
    return DriveModel(jnp.asarray(params.g_tau, dtype=jnp.float64),
                      jnp.asarray(r["amplitude"] if on else 0.0, dtype=jnp.float64),
                      jnp.asarray(r["lead"], dtype=jnp.float64),
                      jnp.array([0.0, 2.1, 4.2]))


def _ripple(q, drive: DriveModel):
    return drive.ripple_amplitude * jnp.sin(2.0 * jnp.pi * q / drive.ripple_lead + drive.ripple_phase)


GEOMETRY_TICKS = 2  # ticks sharing one evaluation of the configuration-dependent terms


def window_geometry(x, p: pl.PlantParams, ticks: int = GEOMETRY_TICKS) -> pl.Geometry:
    """Geometry at the predicted middle of a window of ``ticks`` ticks starting at state x."""
    return pl.geometry(x[:3] + 0.5 * ticks * TICK * x[3:], p)


def _rk4_tick(x, force, p: pl.PlantParams, drive: DriveModel, substeps: int, exact: bool = False,
              geo: pl.Geometry | None = None):
    """Integrate the state x = (q, qd) (6,) over one tick under a held actuator force (3,).

    Returns (x at the end of the tick, qdd at its start). Default: the configuration-dependent terms
    ``geo`` (evaluated at the predicted middle of the tick when not given) are expanded to first
    order (plant.forward_dynamics_local); ``exact=True`` evaluates the full Lagrange equations at
    every RK4 stage (40 times slower; for validation).
    """
    h = TICK / substeps
    if exact:
        def f(x):
            qdd = pl._forward_one(x[:3], x[3:], force + _ripple(x[:3], drive), p, "smooth")
            return jnp.concatenate([x[3:], qdd])
    else:
        if geo is None:
            geo = window_geometry(x, p, 1)

        def f(x):
            q = [x[0], x[1], x[2]]
            qd = [x[3], x[4], x[5]]
            tau = force + _ripple(x[:3], drive)
            qdd = pl.forward_dynamics_local(q, qd, [tau[0], tau[1], tau[2]], geo, p)
            return jnp.stack(qd + qdd)

    def step(x, _):
        k1 = f(x)
        k2 = f(x + 0.5 * h * k1)
        k3 = f(x + 0.5 * h * k2)
        k4 = f(x + h * k3)
        return x + (h / 6.0) * (k1 + 2 * k2 + 2 * k3 + k4), k1[3:]

    x, qdds = jax.lax.scan(step, x, None, length=substeps)
    return x, qdds[0]


def quantise(q, resolution: float = ENCODER_RESOLUTION):
    return jnp.round(q / resolution) * resolution


class ControllerState(NamedTuple):
    q_meas_prev: jnp.ndarray  # (3,)
    integral: jnp.ndarray  # (3,) integral of the position error, m s


def pid_current(ctrl: ControllerState, q_meas, q_ref, qd_ref, ff: float):
    """One controller tick: (new state, v_tau (3,) in A)."""
    e = q_ref - q_meas
    integral = ctrl.integral + e * TICK
    v_est = (q_meas - ctrl.q_meas_prev) / TICK
    force = KP * e + KI * integral + KD * (ff * qd_ref - v_est)
    return ControllerState(q_meas, integral), force / G_TAU_MANUFACTURER


@partial(jax.jit, static_argnames=("ff", "substeps", "exact"))
def run_closed_loop(x0, ctrl0: ControllerState, q_ref, qd_ref, noise, p: pl.PlantParams, drive: DriveModel,
                    ff: float = 0.0, substeps: int = SUBSTEPS, exact: bool = False):
    """Whole record in one scan. q_ref, qd_ref, noise: (N, 3), N a multiple of GEOMETRY_TICKS.
    Returns per-tick arrays (N, 3): q_meas, v_tau, true q, true qd, true qdd (at t_k, under the held
    force), and the final state."""

    def tick(x, ctrl, inp, geo):
        qr, qdr, n = inp
        q_meas = quantise(x[:3])
        ctrl, v_tau = pid_current(ctrl, q_meas, qr, qdr, ff)
        force = drive.g_tau * (v_tau + n)
        x_next, qdd = _rk4_tick(x, force, p, drive, substeps, exact, geo)
        return x_next, ctrl, (q_meas, v_tau, x[:3], x[3:], qdd)

    def window(carry, inp):  # GEOMETRY_TICKS ticks sharing one geometry evaluation
        x, ctrl = carry
        geo = None if exact else window_geometry(x, p)
        outs = []
        for j in range(GEOMETRY_TICKS):
            x, ctrl, out = tick(x, ctrl, [a[j] for a in inp], geo)
            outs.append(out)
        return (x, ctrl), tuple(jnp.stack([o[k] for o in outs]) for k in range(5))

    N = q_ref.shape[0]
    xs = tuple(a.reshape(N // GEOMETRY_TICKS, GEOMETRY_TICKS, 3) for a in (q_ref, qd_ref, noise))
    (x, ctrl), out = jax.lax.scan(window, (x0, ctrl0), xs)
    return tuple(o.reshape(N, 3) for o in out), x, ctrl


@partial(jax.jit, static_argnames=("substeps",))
def external_tick(x, v_tau, noise, p: pl.PlantParams, drive: DriveModel, substeps: int = SUBSTEPS):
    """External mode: apply the current v_tau (3,) A for one tick; returns (q_meas at t_k, x_next)."""
    force = drive.g_tau * (v_tau + noise)
    return quantise(x[:3]), _rk4_tick(x, force, p, drive, substeps)[0]


@partial(jax.jit, static_argnames=("ff",))
def controller_tick(x, ctrl: ControllerState, q_ref, qd_ref, noise, p: pl.PlantParams, drive: DriveModel,
                    ff: float = 0.0):
    """One tick of the internal controllers for the driver node: (q_meas, v_tau, x_next, ctrl)."""
    q_meas = quantise(x[:3])
    ctrl, v_tau = pid_current(ctrl, q_meas, q_ref, qd_ref, ff)
    x_next = _rk4_tick(x, drive.g_tau * (v_tau + noise), p, drive, SUBSTEPS)[0]
    return q_meas, v_tau, x_next, ctrl


def initial_state(q0, qd0, qdd0, p: pl.PlantParams, drive: DriveModel):
    """Plant state on the reference, controller integrator pre-loaded with the force needed there."""
    q0, qd0, qdd0 = (jnp.asarray(v, dtype=jnp.float64) for v in (q0, qd0, qdd0))
    tau0 = pl._inverse_one(q0, qd0, qdd0, p, "smooth")
    x0 = jnp.concatenate([q0, qd0])
    q_meas = quantise(q0)
    ctrl0 = ControllerState(q_meas - qd0 * TICK, tau0 / KI)
    return x0, ctrl0


@dataclass
class ClosedLoopResult:
    q_meas: np.ndarray
    v_tau: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray


CHUNK = 1000  # ticks per compiled scan: one compilation serves records of any length


def simulate_closed_loop(q_ref, qd_ref, qdd_ref, p: pl.PlantParams, drive: DriveModel, controller: str = "pid",
                         noise: np.ndarray | None = None, exact: bool = False) -> ClosedLoopResult:
    """Run the plant under "pid" or "pid_ff" along a sampled reference (N, 3) at 1 kHz.

    The plant starts on the reference (q, qd at t_0) with the controller's integrator pre-loaded.
    """
    if controller not in ("pid", "pid_ff"):
        raise ValueError(f"controller must be 'pid' or 'pid_ff' for a recorded run, got {controller!r}")
    q_ref, qd_ref = np.asarray(q_ref, float), np.asarray(qd_ref, float)
    N = len(q_ref)
    if noise is None:
        noise = np.zeros_like(q_ref)
    x, ctrl = initial_state(q_ref[0], qd_ref[0], qdd_ref[0], p, drive)
    pad = (-N) % CHUNK
    padded = [np.concatenate([a, np.repeat(a[-1:], pad, axis=0)]) for a in (q_ref, qd_ref, np.asarray(noise, float))]
    outs = []
    for start in range(0, N + pad, CHUNK):
        sl = slice(start, start + CHUNK)
        out, x, ctrl = run_closed_loop(x, ctrl, *(jnp.asarray(a[sl]) for a in padded), p, drive,
                                       ff=1.0 if controller == "pid_ff" else 0.0, exact=exact)
        outs.append([np.asarray(o) for o in out])
    return ClosedLoopResult(*(np.concatenate([o[k] for o in outs])[:N] for k in range(5)))
