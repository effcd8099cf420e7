"""identify/joint_units.py: a motor's equations in joint-side units (s_a = max_j |N_aj|): the
scale of the robot and of a partial answer's subsystem, each column's power by its name (the
column layout's, lag included), none without a transmission (the paper's solve, bit for bit)."""
from __future__ import annotations

import numpy as np
import yaml

from orthoglide_ident.identify.columns.layout import column_layout, plain_layout
from orthoglide_ident.identify.observe import joint_units
from orthoglide_ident.identify.solve.partial import Subsystem
from orthoglide_ident.model.registry import ROBOTS_DIR, load_robot

N = [[32, 0, 0, 0, 0, 0], [0, -32, 0, 0, 0, 0], [0, 0, 45, 0, 0, 0], [0, 0, 0, -48, 0, 0],
     [0, 0, 0, 0, 45, 0], [0, 0, 0, 0, 32, -40]]
S = np.array([32.0, 32.0, 45.0, 48.0, 45.0, 40.0])


def _model(tmp_path):
    data = yaml.safe_load((ROBOTS_DIR / "ur5.yaml").read_text())
    data.pop("excitation")
    data.update(name="ur5_units", description=str(ROBOTS_DIR / "ur5.urdf"),
                transmission={"actuators": [f"m{k}" for k in range(1, 7)], "reduction": N})
    path = tmp_path / "ur5_units.yaml"
    path.write_text(yaml.safe_dump(data))
    return load_robot(path)


def test_the_scale_is_each_motor_s_largest_reduction(tmp_path):
    model = _model(tmp_path)
    np.testing.assert_array_equal(joint_units.transmission_scale(model), S)
    np.testing.assert_array_equal(joint_units.equation_scale(model), S)
    sub = Subsystem(model, np.array([0, 3, 5]), np.arange(len(model.names)), plain_layout(model))
    np.testing.assert_array_equal(joint_units.transmission_scale(sub), S[[0, 3, 5]])
    plain = load_robot(ROBOTS_DIR / "ur5.yaml")
    assert joint_units.equation_scale(plain) is None
    assert joint_units.column_scale(plain, len(plain.names)) is None


def test_each_motor_column_gets_its_kind_s_power(tmp_path):
    """ia, fv: 1/s², fs, tauoff, a lag: 1/s, the gains 1/s, rigid and payload columns 1."""
    model = _model(tmp_path)
    names = column_layout(model, lag=True).names
    c = joint_units.column_scale(model, len(names), names)
    assert c.shape == (len(names) + 7,)
    for k, name in enumerate(names):
        kind, _, motor = name.partition("_")
        a = int(motor[1:]) - 1 if motor in [f"m{i}" for i in range(1, 7)] else None
        if a is None:
            assert c[k] == 1.0, name
        else:
            power = {"ia": 2, "fv": 2, "fs": 1, "tauoff": 1, "lag": 1}[kind]
            assert c[k] == S[a] ** -power, name
    assert any(n.startswith("lag_m") for n in names) and any(n.startswith("fv_m") for n in names)
    np.testing.assert_array_equal(c[len(names):-1], 1.0 / S)
    assert c[-1] == 1.0
