"""An exciting-trajectory file (orthoglide_ident.excite, ``excite run``'s input) from the arm's
designed trajectories (arm_excitation: ``exciting1`` unloaded, ``exciting2`` loaded), made to
start and end at rest (``rest_projection``) and checked to stay inside the arm's box: the "given
trajectory file" of the simulated workflow (``make demo-excite``) until ``excite design`` writes
one.

    python -m orthoglide_sim.excite_file --robot ur5_mount --periods 6 --payload-mass 2.5 --out traj.yaml
"""
from __future__ import annotations

import argparse
import sys

import numpy as np

from orthoglide_ident.errors import ConfigError, OrthoglideError
from orthoglide_ident.excite.trajectory import ExcitationRun, ExcitationTrajectory, rest_projection, save_trajectory
from orthoglide_sim.arm_excitation import designed_trajectory
from orthoglide_sim.arm_limits import motion_limits
from orthoglide_sim.arm_session import robot_truth

RUNS = {"unloaded": "exciting1", "loaded": "exciting2"}


BOX_FILL = 0.98  # of the box's half-widths and speeds the fitted run may use


def _fit_box(q0: np.ndarray, a: np.ndarray, b: np.ndarray, period: float, box) -> tuple[np.ndarray, ...]:
    """The projected run's range centred in the box and, where it no longer fits the box or its
    speeds (the projection moves the motion by a few %), scaled down to BOX_FILL of them."""
    run = ExcitationRun("unloaded", q0, a, b)
    q, qd, _ = ExcitationTrajectory("", ("",) * len(q0), period, 1, {"unloaded": run}).evaluate(
        "unloaded", np.arange(0.0, period, 1e-3))
    mid, half = (q.max(0) + q.min(0)) / 2, (q.max(0) - q.min(0)) / 2
    scale = min(1.0, BOX_FILL / max(np.max(half / box.half), np.max(np.abs(qd).max(0) / box.velocity)))
    return q0 - (mid - box.centre), scale * a, scale * b


def designed_excitation(robot: str, periods: int, payload_mass: float) -> ExcitationTrajectory:
    """Both runs of ``robot`` from its designed trajectories, at rest at both ends, ``periods``
    periods each; ConfigError if the projection leaves the arm's box or its speed table."""
    arm = robot_truth(robot).arm  # a serial arm's or a closed chain's (its actuated joints)
    box = motion_limits(arm)
    runs, period = {}, None
    for run, name in RUNS.items():
        f = designed_trajectory(arm, name)
        period = period or f.period
        if abs(f.period - period) > 1e-12:
            raise ConfigError(f"{robot}: {name} has another period ({f.period:g} s vs {period:g} s)")
        a, b = rest_projection(f.a, f.b)
        q0, a, b = _fit_box(np.array(f.q0, float), a, b, f.period, box)
        payload = {"mass": float(payload_mass), "frame": arm.payload_frame} if run == "loaded" else None
        runs[run] = ExcitationRun(run, q0, a, b, payload)
    traj = ExcitationTrajectory(arm.name, tuple(arm.joint_names), float(period), int(periods), runs)
    t = np.arange(0.0, traj.period_s, 1e-3)
    for run in runs:
        q, qd, _ = traj.evaluate(run, t)
        if np.any(np.abs(q - box.centre) > box.half) or np.any(np.abs(qd) > box.velocity):
            raise ConfigError(f"{robot}: the {run} run leaves the arm's box once at rest at its ends")
    return traj


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m orthoglide_sim.excite_file", description=__doc__.splitlines()[0])
    ap.add_argument("--robot", default="ur5_mount")
    ap.add_argument("--periods", type=int, default=6)
    ap.add_argument("--payload-mass", type=float, default=2.5, metavar="KG")
    ap.add_argument("--out", required=True)
    args = ap.parse_args(argv)
    try:
        save_trajectory(designed_excitation(args.robot, args.periods, args.payload_mass), args.out)
    except OrthoglideError as exc:
        print(f"excite_file: {exc}", file=sys.stderr)
        return 2
    print(args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
