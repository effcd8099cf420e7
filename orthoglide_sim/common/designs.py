"""The simulator's stored exciting trajectories (data/<name>.json), designed by the product's
designer (``orthoglide_ident.excite.design``, paper Sect. 3.2) inside a simulator's box.

A robot room's design command gives the product's model of its robot, the box its plant is run
in (position, velocity and acceleration per joint, over the robot file's and URDF's own limits:
efforts) and the payload of its loaded record; the unloaded run is written as ``exciting1``, the
loaded one as ``exciting2`` (what the records and bags track), each a ``FourierSeries`` with the
design's figures (the product's predicted gain σ and κ). The committed files stay as data: a
re-run gives other trajectories, and the records read the files.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
from pathlib import Path

import numpy as np

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.excite.limits import JointLimits, read_limits
from orthoglide_ident.model.robot import Payload

RUN_FILES = {"unloaded": "exciting1", "loaded": "exciting2"}  # run -> stored name
BOX_SOURCE = "the simulator's box"


def box_limits(robot, lower, upper, velocity, acceleration) -> JointLimits:
    """The robot's own limits (read_limits: URDF, robot file) with the box's position, velocity
    and acceleration (each (n,) or a scalar) in their place."""
    own = read_limits(robot)
    n = robot.n_joints
    box = {k: np.broadcast_to(np.asarray(v, float), (n,)).copy() for k, v in
           (("lower", lower), ("upper", upper), ("velocity", velocity),
            ("acceleration", acceleration))}
    sources = own.sources | {k: BOX_SOURCE for k in box}
    return dataclasses.replace(own, sources=sources, **box)


def add_design_arguments(ap: argparse.ArgumentParser, period: float, harmonics: int,
                         periods: int, payload_mass: float | None, out_dir: Path,
                         current_noise: float) -> None:
    """The product's design options a robot room's command passes on (its defaults;
    ``payload_mass`` None: the loaded record's payload, which the command gives)."""
    ap.add_argument("--period", type=float, default=period, help=f"s (default {period:g})")
    ap.add_argument("--harmonics", type=int, default=harmonics)
    ap.add_argument("--periods", type=int, default=periods, help="periods per run (prediction)")
    ap.add_argument("--payload-mass", type=float, default=payload_mass,
                    help="kg, a point mass at the payload frame for the loaded run (default "
                         + (f"{payload_mass:g})" if payload_mass else "the loaded record's)"))
    ap.add_argument("--restarts", type=int, default=20)
    ap.add_argument("--steps", type=int, default=None, help="random-walk steps (product default)")
    ap.add_argument("--search", choices=("walk", "gradient"), default="gradient")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--current-noise", type=float, default=current_noise,
                    help=f"A per joint, for the predicted σ (default {current_noise:g})")
    ap.add_argument("--out-dir", type=Path, default=out_dir)


def design_and_write(robot, limits: JointLimits, args: argparse.Namespace, prefix: str = "",
                     collision: str = "mesh", payload: Payload | None = None) -> list[Path]:
    """Design both runs with the product (``args`` of add_design_arguments; the loaded run with
    ``payload`` unless ``--payload-mass`` is given) and write them as
    ``<out-dir>/<prefix>exciting{1,2}.json``; the paths written."""
    from orthoglide_ident.excite.collision import CollisionModel
    from orthoglide_ident.excite.design import DesignOptions, design

    if args.payload_mass is not None or payload is None:
        payload = Payload(args.payload_mass)
    opt = DesignOptions(payload, np.full(robot.n_joints, args.current_noise),
                        args.period, args.periods, args.harmonics, args.seed, args.restarts,
                        args.steps, search=args.search)
    d = design(robot, limits, CollisionModel(robot, collision), opt, progress=print)
    pred = d.prediction
    figures = {"robot": robot.name, "joint_names": list(robot.joint_names),
               "criterion": "orthoglide_ident.excite.design", "seed": args.seed,
               "payload_kg": payload.mass, "current_noise_a": args.current_noise,
               "seconds_per_run": d.trajectory.duration,
               "predicted_gain_std_pct": (100 * pred.gain_rel_std).tolist(),
               "kappa": pred.condition_kept,
               "limits": {k: getattr(limits, k).tolist()
                          for k in ("lower", "upper", "velocity", "acceleration")}}
    paths = []
    for run, name in RUN_FILES.items():
        path = args.out_dir / f"{prefix}{name}.json"
        doc = d.trajectory.series(run).to_dict() | {"run": run} | figures
        try:
            path.write_text(json.dumps(doc, indent=1) + "\n")
        except OSError as exc:
            raise ConfigError(f"cannot write {path}: {exc.strerror or exc}") from None
        paths.append(path)
    print(f"wrote {', '.join(map(str, paths))}: worst gain σ "
          f"{100 * pred.worst_determined_gain():.3g} % ({d.trajectory.duration:g} s per run at "
          f"{args.current_noise:g} A), κ {pred.condition_kept:.4g}")
    return paths
