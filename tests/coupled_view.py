"""A model-consistent robot with a transmission for the view's tests (issue 33): the UR5 behind
a coupled wrist (the last motor turns with q5 + q6, gear ratios 32 .. -48, motor-side offsets),
its description's links with rotor inertia and viscous friction on each motor
(model/actuator_space.py), and a record of it: joint-side positions at the ticks, each motor's
current balancing its row at mid-tick (the zero-order hold the identification assumes).

    model, chi = coupled_model(tmp)          # ActuatorSpaceRobot, its base values
    stamps, q_j, v_m = coupled_record(model, chi, seconds=3.0, t0_ns=0)
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import yaml

from orthoglide_ident.model.registry import ROBOTS_DIR, load_robot

MOTORS = ("m1", "m2", "m3", "m4", "m5", "m6")
N_WRIST = np.array([[32, 0, 0, 0, 0, 0], [0, 32, 0, 0, 0, 0], [0, 0, 45, 0, 0, 0],
                    [0, 0, 0, -48, 0, 0], [0, 0, 0, 0, 45, 0], [0, 0, 0, 0, 32, 32]], float)
OFFSET = np.array([0.0, 0.0, 0.0, 1.0, 0.0, -2.0])  # rad, motor side
G_MOTORS = np.array([0.134, 0.126, 0.102, 0.096, 0.104, 0.097])  # N·m/A
IA = np.array([3e-5, 3e-5, 1.5e-5, 1.2e-5, 1.2e-5, 1.2e-5])  # kg·m², rotors
FV = np.full(6, 2e-4)  # N·m·s/rad, motor side


def coupled_robot_file(folder: Path) -> Path:
    data = yaml.safe_load((ROBOTS_DIR / "ur5.yaml").read_text())
    data.pop("excitation", None)
    data.update(
        name="ur5_coupled_view",
        description=str(ROBOTS_DIR / "ur5.urdf"),
        nominal_gains=[0.13] * 6,
        transmission={
            "actuators": list(MOTORS),
            "reduction": N_WRIST.tolist(),
            "offset": OFFSET.tolist(),
        },
    )
    path = Path(folder) / "ur5_coupled_view.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def coupled_model(folder: Path):
    """(the robot file's model, its base values with the motors' ia and fv)."""
    model = load_robot(str(coupled_robot_file(folder)))
    chi_st = model.standard_values()
    for a, name in enumerate(MOTORS):
        chi_st[model.standard_names.index(f"ia_{name}")] = IA[a]
        chi_st[model.standard_names.index(f"fv_{name}")] = FV[a]
    return model, model.base_values(chi_st)


def coupled_record(model, chi, seconds: float = 3.0, t0_ns: int = 0):
    """(stamps ns, joint-side positions, motor currents A) of smooth sinusoids (no reversal of
    a motor is needed: no Coulomb term)."""
    t = np.arange(int(seconds * 1000)) * 1e-3
    w, amp = np.array([1.1, 0.9, 1.3, 1.7, 2.1, 1.9]), np.array([0.4, 0.3, 0.4, 0.6, 0.6, 0.8])
    q0 = np.array([0.0, -1.2, 1.2, -1.5, 0.0, 0.0])

    def q_j(s, d=0):
        return amp * w ** d * np.sin(np.outer(s, w) + d * np.pi / 2) + (q0 if d == 0 else 0)

    tr, tm = model.transmission, t + 0.5e-3
    rows = model.regressor(tr.to_actuator_position(q_j(tm)), tr.to_actuator_rate(q_j(tm, 1)),
                           tr.to_actuator_rate(q_j(tm, 2)))
    v = (rows @ chi).reshape(6, -1).T / G_MOTORS
    return t0_ns + (t * 1e9).astype(np.int64), q_j(t), v
