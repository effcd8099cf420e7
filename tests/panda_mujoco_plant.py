"""The example-robot-data Panda (fingers locked) as a MuJoCo plant, end to end: design, simulate,
identify (issue 48). A test and bench fixture.

The plant is not the identification model: MuJoCo loads the Panda's URDF itself (the fingers
welded at their locked opening, orthoglide_sim.arms.plant), with its own true parameters drawn by
``orthoglide_sim.arms.truth.default_truth`` (every link's inertial perturbed, rotor inertia,
viscous and Coulomb friction (MuJoCo's soft friction loss), an offset torque, drive gains 2-6 %
off the nominal 5 N·m/A), and integrates its own dynamics under a 1 kHz PID following the
designed trajectory, with 0.5 % white current noise and 2^19-count encoders.

    run = end_to_end(Path(tmp), DESIGN_FAST)     # RunFigures: gains, σ, truth, stage times
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

import locked_panda as L
import numpy as np
from live_helpers import as_record

from orthoglide_ident.cli import main as cli
from orthoglide_ident.excite.trajectory import load_trajectory
from orthoglide_ident.identify import identify_records
from orthoglide_ident.model.registry import load_robot
from orthoglide_sim.arms.description import load_arm
from orthoglide_sim.arms.record import simulate_arm
from orthoglide_sim.arms.truth import load_truth
from orthoglide_sim.demos.designed_runs import stop_limits

PAYLOAD = "2.0"  # the truth's 2 kg off-centre body at the payload frame (truth.PAYLOADS)
# rad/s, the PID's bandwidth: at the UR5's 100 the Panda's joints 1-4 (rotor inertia 0.19 kg·m²,
# the gains tuned at the run's start pose) ring in a limit cycle against their 17.4 A limit
# (joint 1 saturated 29 % of the ticks, tick-to-tick current change 8.5 A rms; at 50: none, 0.12 A)
OMEGA = 50.0
DESIGN_DEFAULTS: tuple[str, ...] = ()  # excite design as it comes: 12 periods of 5 s per run
DESIGN_FAST = ("--periods", "2", "--restarts", "3", "--steps", "30")  # 10 s per run


@dataclass
class RunFigures:
    """What one end-to-end run gives: per joint (n,) and the stages' wall times in s."""

    joints: tuple[str, ...]
    gains: np.ndarray  # identified, N·m/A
    rel_std: np.ndarray  # their relative σ
    determined: np.ndarray  # bool
    truth: np.ndarray  # the plant's g_tau
    nominal: np.ndarray  # the robot file's
    seconds: dict[str, float] = field(default_factory=dict)
    run_s: float = 0.0
    saturated_ticks: int = 0
    warnings: list[str] = field(default_factory=list)

    @property
    def error(self) -> np.ndarray:
        return self.gains / self.truth - 1


def design(folder: Path, robot_file: Path, options: tuple[str, ...], seed: int) -> Path:
    """``orthoglide-ident excite design`` for the 2 kg payload: the trajectory file."""
    out = folder / "panda_traj.yaml"
    rc = cli(["excite", "design", "--robot", str(robot_file), "--payload-mass",
              str(float(PAYLOAD)), "--seed", str(seed), "--out", str(out),
              "--package-dir", str(L.share_dir()), *options])
    if rc != 0:
        raise RuntimeError(f"excite design exited {rc}")
    return out


def end_to_end(folder: Path, options: tuple[str, ...] = DESIGN_FAST, seed: int = 0) -> RunFigures:
    """Design, simulate the unloaded and the loaded run on the MuJoCo plant, identify by
    IDIM-TLS through the robot file; each stage timed."""
    robot_file = L.robot_file(folder)
    t = [time.perf_counter()]
    traj = load_trajectory(design(folder, robot_file, options, seed))
    t.append(time.perf_counter())
    truth = load_truth(load_arm(robot_file))
    recs = [simulate_arm(traj.duration, payload=payload, trajectory=traj.series(run),
                         seed=seed + k, truth=truth, limits=stop_limits(traj, run), omega=OMEGA)
            for k, (run, payload) in enumerate((("unloaded", None), ("loaded", PAYLOAD)))]
    t.append(time.perf_counter())
    model = load_robot(robot_file)
    res = identify_records([as_record(r, r.trajectory + str(r.seed)) for r in recs], model=model)
    t.append(time.perf_counter())
    return RunFigures(
        model.joint_names, np.array([g.value for g in res.drive_gains]),
        np.array([g.rel_std for g in res.drive_gains]),
        np.array([g.determined for g in res.drive_gains]), truth.drive_array("g_tau"),
        np.asarray(model.nominal_gains, float),
        dict(zip(("design", "simulate", "identify"), np.diff(t))), traj.duration,
        sum(r.saturated_ticks for r in recs), list(res.warnings))
