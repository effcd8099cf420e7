"""The Orthoglide's exciting trajectories (paper Sect. 3.2, refs [24, 25]; Fig. 4): the stored
pair's predicted gain σ, its platform's peaks, the safe workspace box, and the design command.

The committed pair (data/exciting1.json unloaded, exciting2.json loaded with 1.983 kg; 6
harmonics of a 1.5 s period) was designed together for the drive gains by an optimiser of the
simulator's own (σ of the gains, eqs. 35-36 linearised, and their bias under an unknown 0.15 ms
current-loop lag; the figures are in the files), since replaced by the product's designer. The
files stay as the records' and sample bags' data.

:func:`predicted_gain_std` is the σ of the gains the identification reaches from the two
records: the product's prediction (``orthoglide_ident.excite.prediction.predict``, eq. 39 at
small noise) with the simulator's parameter table as the a priori base parameters (it enters
only through the size of the currents) and the manufacturer's gains.

``python -m orthoglide_sim.orthoglide.excitation`` designs a new pair with
``orthoglide_ident.excite.design`` on the Orthoglide's general description
(``orthoglide_general``, the same robot as the closed form), inside the safe box (≤ V_MAX,
≤ A_MAX per actuator), and writes it as exciting1/2.json (common/designs.py): the same as
``orthoglide-ident excite design --robot orthoglide_general --joint-limits BOX.yaml --collision
skip --payload-mass 1.983 --period 1.5 --periods 20 --harmonics 6 --current-noise 0.001``.
"""
from __future__ import annotations

import argparse
import sys

import numpy as np

from orthoglide_ident.errors import OrthoglideError, WorkspaceError
from orthoglide_ident.excite import FourierSeries
from orthoglide_sim.common.designs import add_design_arguments, box_limits, design_and_write
from orthoglide_sim.common.trajectories import A_MAX, DATA_DIR, Q_CENTER, Q_HALF, V_MAX
from orthoglide_sim.orthoglide import kinematics as kin

DESIGN_PAYLOAD_KG = 1.983  # the weighed payload of the loaded record (Sect. 5.2)
DESIGN_NOISE_A = 1.0e-3  # A, white current noise per 1 kHz sample: sets the scale of the σ
DESIGN_SECONDS = 30.0  # s of each record: sets the scale of the σ
PERIOD, HARMONICS, PERIODS = 1.5, 6, 20  # the committed pair's; 20 periods: 30 s per record
GENERAL = "orthoglide_general"  # the description the product's designer needs (a URDF's)
# half the range a design may use about Q_CENTER: a little inside the safe box (at its edge the
# general model's loop closures fail during the gradient polish)
POSITION_HALF = 0.95 * Q_HALF


def predicted_gain_std(unloaded: FourierSeries, loaded: FourierSeries, n: int = 240,
                       gains: np.ndarray | None = None) -> np.ndarray:
    """Relative σ (%) of the three gains from a DESIGN_SECONDS unloaded record and a loaded one
    (DESIGN_PAYLOAD_KG), white current noise DESIGN_NOISE_A on every 1 kHz sample; ``n``
    samples of one period each; ``gains`` a priori (default the manufacturer's)."""
    from orthoglide_ident.excite.prediction import RunSamples, predict
    from orthoglide_ident.model.registry import load_robot
    from orthoglide_ident.model.robot import Payload
    from orthoglide_sim.orthoglide.truth import load_parameters

    robot = load_robot("orthoglide")
    runs = []
    for traj, payload in ((unloaded, None), (loaded, Payload(DESIGN_PAYLOAD_KG))):
        t = np.linspace(0.0, traj.period, n, endpoint=False)
        runs.append(RunSamples(*traj.evaluate(t), DESIGN_SECONDS, payload))
    chi = robot.base_values(load_parameters().standard_vector())
    return 100.0 * predict(robot, runs, DESIGN_NOISE_A, chi_b=chi, gains=gains).gain_rel_std


def platform_peaks(traj, duration: float | None = None, n: int = 4000) -> tuple[float, float]:
    """Peak platform speed (m/s) and acceleration (m/s²) along a trajectory: dP/dt = J_p qd in
    closed form, d²P/dt² by central differences of it over the dense time grid."""
    t = np.linspace(0.0, duration or traj.period, n, endpoint=False)
    q, qd, _ = traj.evaluate(t)
    v = kin.platform_velocity(q, qd)
    a = np.gradient(v, t, axis=0)
    return float(np.linalg.norm(v, axis=1).max()), float(np.linalg.norm(a, axis=1).max())


def workspace_report(
    lo: float = Q_CENTER - Q_HALF, hi: float = Q_CENTER + Q_HALF, n: int = 11
) -> dict:
    """Worst singularity margins over a grid of the actuator box [lo, hi]^3."""
    g = np.linspace(lo, hi, n)
    Q = np.array(np.meshgrid(g, g, g)).reshape(3, -1).T
    try:
        serial, parallel, inv_cond = kin.singularity_margins(Q)
    except WorkspaceError:
        return {"box": (lo, hi), "assembled_everywhere": False}
    return {"box": (lo, hi), "assembled_everywhere": True,
            "min_bar_axis_cosine": float(serial.min()), "min_det_u": float(parallel.min()),
            "max_cond_Jp": float(np.max(1.0 / inv_cond))}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m orthoglide_sim.orthoglide.excitation", description=__doc__.splitlines()[0]
    )
    add_design_arguments(ap, PERIOD, HARMONICS, PERIODS, DESIGN_PAYLOAD_KG, DATA_DIR,
                         DESIGN_NOISE_A)
    args = ap.parse_args(argv)
    print("workspace:", workspace_report())
    try:
        from orthoglide_ident.model.registry import load_robot

        robot = load_robot(GENERAL)
        limits = box_limits(robot, Q_CENTER - POSITION_HALF, Q_CENTER + POSITION_HALF, V_MAX,
                            A_MAX)
        design_and_write(robot, limits, args, collision="skip")  # no collision geometry
    except OrthoglideError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
