"""The example-robot-data Panda with its fingers locked (issue 43): drive gains against the truth.

    python bench/locked_panda.py [SECONDS]

Simulates an unloaded and a loaded record (2 kg at the TCP, off joint 7's axis) of the 7 arm
joints with tests/locked_panda.py's generator (Pinocchio's RNEA on the full URDF, the fingers
held at 0.03 m, rotor inertia, viscous and Coulomb friction, currents held over 1 ms), at
several current noise levels, identifies them by IDIM-TLS through the robot file (fingers
locked) and prints, per joint, the gain's error in % over its σ in %, then the error in σ
(three draws of the noise per level). Then what the Panda as it comes
gives without locked_joints: the bare URDF and a robot file naming the 7 arm joints only.
"""
from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
import locked_panda as L  # noqa: E402

from orthoglide_ident.errors import OrthoglideError  # noqa: E402
from orthoglide_ident.identify import IdentifyOptions, identify_records  # noqa: E402
from orthoglide_ident.model.registry import load_robot  # noqa: E402

NOISES_A = (0.002, 0.01, 0.02, 0.05)
NOISE_SEEDS = (0, 1, 2)  # draws of the current noise per level


def row(robot, seconds: float, noise: float, seed: int) -> None:
    """One identification: per joint the gain's error / its σ, in %, then in σ."""
    try:
        res = identify_records(L.records(seconds, noise, noise_seed=seed), model=robot,
                               options=IdentifyOptions.of(lag_model="off"))
    except OrthoglideError as exc:
        print(f"{noise:>8g}  noise draw {seed}: refused: {exc}")
        return
    g = np.array([x.value for x in res.drive_gains])
    s = np.array([x.rel_std for x in res.drive_gains])
    e = g / L.TRUE_GAINS - 1
    print(f"{noise:>8g}  " + "  ".join(
        f"{100 * x:+.3f}%/{100 * y:.3f}%" for x, y in zip(e, s)) + f"   draw {seed}")
    print(f"{'':>8}  " + "  ".join(f"{x / y:>+15.2f}σ" for x, y in zip(e, s))
          + ("" if res.complete else "   " + res.not_determined_text()))


def main_bench(seconds: float) -> None:
    with tempfile.TemporaryDirectory() as d:
        robot = load_robot(L.robot_file(Path(d)))
        print(f"robot {robot.name}: {robot.n_joints} joints, {robot.n_b} base parameters; "
              + "; ".join(f"{lj.name} locked at {lj.value:g} {lj.unit}"
                          for lj in robot.locked_joints))
        print(f"{seconds:g} s + {seconds:g} s at 1 kHz, IDIM-TLS, lag_model off")
        print(f"{'noise A':>8}  " + "  ".join(f"{j[-6:]:>16}" for j in robot.joint_names))
        for noise in NOISES_A:
            for seed in NOISE_SEEDS:
                row(robot, seconds, noise, seed)
        print("the Panda as it comes, without locked_joints:")
        bare = load_robot(L.urdf_path())
        print(f"  bare URDF: actuated {', '.join(bare.joint_names)}")
        arm = Path(d) / "arm.yaml"
        arm.write_text(f"description: {L.urdf_path()}\nactuated_joints: [{', '.join(L.ARM)}]\n")
        try:
            load_robot(arm)
            print("  the 7 arm joints named: loads (fingers locked at 0)")
        except OrthoglideError as exc:
            print(f"  the 7 arm joints named: {exc}")


if __name__ == "__main__":
    main_bench(float(sys.argv[1]) if len(sys.argv) > 1 else 20.0)
