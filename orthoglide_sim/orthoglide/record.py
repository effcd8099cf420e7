"""Simulated records: what the robot's controller would log (q, v_tau at 1 kHz) plus the truth.

    rec = simulate(60.0, payload="1.983", trajectory="exciting", controller="pid")
    rec = simulate(30.0, payload="1.983", trajectory="exciting2", profile="realistic")

``profile``: a plant profile of true_parameters ("nominal", the default, or "realistic":
current-loop
lag, Stribeck breakaway, screw friction ripple, 2 mA current noise; see config/plant.yaml).

``python -m orthoglide_sim.orthoglide.record --help`` writes a record as a .npz file.
"""
from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from orthoglide_ident.errors import ConfigError, OrthoglideError
from orthoglide_ident.model.orthoglide.geometry import JOINT_NAMES
from orthoglide_sim.common.trajectories import get_trajectory
from orthoglide_sim.orthoglide import simulator as sm
from orthoglide_sim.orthoglide.plant import Plant
from orthoglide_sim.orthoglide.truth import PlantProfile, TrueParameters, load_parameters


@dataclass
class SimRecord:
    """One simulated run. Arrays are per controller tick (1 kHz); (N, 3) columns q11, q12, q13."""

    stamps_ns: np.ndarray  # (N,) int64, t_k in ns from start_ns
    q: np.ndarray  # (N, 3) m, encoder-quantised positions seen by the controller
    v_tau: np.ndarray  # (N, 3) A, current references (held over [t_k, t_k+1))
    q_true: np.ndarray  # (N, 3) m
    qd_true: np.ndarray  # (N, 3) m/s
    qdd_true: np.ndarray  # (N, 3) m/s² at t_k under the held force
    q_ref: np.ndarray  # (N, 3) m, reference
    payload_mass: float  # kg (0 when unloaded)
    payload_vector: np.ndarray  # (10,) xx_7..m_7
    params: TrueParameters
    g_tau: np.ndarray  # (3,) true drive gains N/A
    trajectory: str
    controller: str
    joint_names: tuple[str, ...] = JOINT_NAMES
    profile: str = "nominal"  # plant profile (true_parameters.PlantProfile)

    @property
    def tau_true(self) -> np.ndarray:
        """Force applied by the drives apart from noise: g_tau * v_tau (N, 3), N."""
        return self.v_tau * self.g_tau


@dataclass
class _Run:
    """What every simulated run needs: plant and drive parameters, reference, noise, stamps."""

    params: TrueParameters
    prof: PlantProfile
    chi_l: np.ndarray  # (10,) the payload's standard parameters
    plant: Plant
    drive: sm.DriveModel
    reference: tuple[np.ndarray, np.ndarray, np.ndarray]  # q_ref, qd_ref, qdd_ref (N, 3)
    current_noise: np.ndarray  # (N, 3) A
    encoder_noise: np.ndarray | None  # (N, 3) m
    stamps: np.ndarray  # (N,) ns

    def record(self, res: sm.ClosedLoopResult, trajectory: str, controller: str) -> SimRecord:
        """The record of this run's closed loop."""
        return SimRecord(self.stamps, res.q_meas, res.v_tau, res.q, res.qd, res.qdd,
                         self.reference[0], float(self.chi_l[9]), self.chi_l, self.params,
                         np.asarray(self.params.g_tau, float), trajectory, controller,
                         profile=self.prof.name)


def _setup(duration_s, payload, trajectory, seed, params, noise, start_ns, ripple,
           profile) -> _Run:
    """The run's plant, drive, reference, noise and stamps."""
    if not (duration_s > 0):
        raise ConfigError(f"duration must be positive, got {duration_s}")
    params = params or load_parameters()
    prof = params.plant_profile(profile)
    chi_l = params.payload_vector(payload)
    plant = Plant(params, payload)
    drive = sm.drive_model(params, ripple, prof)
    N = int(round(duration_s / sm.TICK))
    reference = get_trajectory(trajectory).evaluate(np.arange(N) * sm.TICK)
    rng = np.random.default_rng(seed)
    current_noise = rng.normal(0.0, prof.current_noise_std, (N, 3)) if noise else np.zeros((N, 3))
    encoder_noise = rng.normal(0.0, prof.encoder_noise_std, (N, 3)) \
        if noise and prof.encoder_noise_std > 0 else None
    stamps = start_ns + np.arange(N, dtype=np.int64) * int(round(sm.TICK * 1e9))
    return _Run(params, prof, chi_l, plant, drive, reference, current_noise, encoder_noise, stamps)


def simulate(duration_s: float, payload: str | float = "none", trajectory: str = "exciting",
             controller: str = "pid", seed: int = 0, params: TrueParameters | None = None,
             noise: bool = True, start_ns: int = 0, ripple: bool | None = None,
             feedforward: np.ndarray | None = None, profile: str | None = None) -> SimRecord:
    """Simulate the robot tracking ``trajectory`` for ``duration_s`` seconds under ``controller``.

    payload: "none", "1.983", "1.136" or a mass in kg; controller: "pid", "pid_ff" or "ctc" (then
    ``feedforward`` (N, 3) A is the model current added at each tick, e.g.
    ``orthoglide_ident.control.feedforward_currents``); profile: plant profile ("nominal",
    "realistic", or one defined in the parameters' YAML; default ``params.profile``);
    noise: current and encoder noise of the profile (encoder quantisation is always on); ripple:
    screw ripple (default from the profile, see simulator.drive_model). Raises ConfigError on bad
    arguments.
    """
    if controller not in ("pid", "pid_ff", "ctc"):
        raise ConfigError(f"controller must be pid, pid_ff or ctc for a record, got {controller!r}")
    run = _setup(duration_s, payload, trajectory, seed, params, noise, start_ns, ripple, profile)
    res = sm.simulate_closed_loop(*run.reference, run.plant, run.drive, controller,
                                  run.current_noise, feedforward, run.prof.encoder_resolution,
                                  run.encoder_noise)
    return run.record(res, trajectory, controller)


def simulate_external(duration_s: float, command: Callable[[int, np.ndarray], np.ndarray],
                      payload: str | float = "none", trajectory: str = "test1", seed: int = 0,
                      params: TrueParameters | None = None, noise: bool = True, start_ns: int = 0,
                      ripple: bool | None = None, profile: str | None = None) -> SimRecord:
    """Like ``simulate`` with an external controller: ``command(k, q_meas[k]) -> v_tau[k]`` (A) is
    called at every tick (e.g. ``orthoglide_ident.control.CTC.command``) and held over the tick.

    The plant starts on ``trajectory`` at t = 0 (q, qd); the trajectory is only the reference the
    controller is expected to follow (q_ref in the record). About 0.2 ms of wall time per tick.
    """
    run = _setup(duration_s, payload, trajectory, seed, params, noise, start_ns, ripple, profile)
    q_ref, qd_ref, _ = run.reference
    sim = sm.Integrator(run.plant, run.drive, q_ref[0], qd_ref[0])
    res = sm.run_integrator(sim, command, run.current_noise, run.prof.encoder_resolution,
                            run.encoder_noise)
    return run.record(res, trajectory, "external")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m orthoglide_sim.orthoglide.record",
        description="Simulate a record of the Orthoglide and save it as .npz.",
    )
    ap.add_argument("output", help="output .npz file")
    ap.add_argument("--duration", type=float, default=10.0, help="seconds (default 10)")
    ap.add_argument("--payload", default="none", help="none, 1.983, 1.136 or a mass in kg")
    ap.add_argument(
        "--trajectory", default="exciting", help="exciting, exciting2, test1, test2 or a .json"
    )
    ap.add_argument("--controller", default="pid", choices=["pid", "pid_ff"])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument(
        "--params", default=None, help="YAML overriding the true parameters (config/plant.yaml)"
    )
    ap.add_argument(
        "--profile",
        default=None,
        help="plant profile: nominal, realistic or one named in --params (default: the YAML's or "
             "nominal)",
    )
    ap.add_argument(
        "--no-noise", action="store_true", help="switch the current and encoder noise off"
    )
    args = ap.parse_args(argv)
    try:
        rec = simulate(args.duration, args.payload, args.trajectory, args.controller, args.seed,
                       load_parameters(args.params), noise=not args.no_noise, profile=args.profile)
    except OrthoglideError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    np.savez_compressed(
        args.output,
        stamps_ns=rec.stamps_ns,
        q=rec.q,
        v_tau=rec.v_tau,
        q_true=rec.q_true,
        qd_true=rec.qd_true,
        qdd_true=rec.qdd_true,
        g_tau=rec.g_tau,
        payload_mass=rec.payload_mass,
        joint_names=np.array(rec.joint_names),
        profile=rec.profile,
    )
    print(
        f"{args.output}: {len(rec.stamps_ns)} ticks, payload {rec.payload_mass} kg, g_tau "
        f"{rec.g_tau.tolist()}, "
        f"profile {rec.profile}"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
