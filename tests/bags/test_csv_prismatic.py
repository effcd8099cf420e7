"""``--angle-unit deg`` converts revolute joints only: a prismatic joint's positions (m) and
velocities (m/s) are kept as they are (issue 48: every position column was scaled by π/180)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from orthoglide_ident import bags
from orthoglide_ident.bags.csv_import import ColumnMap, read_csv
from orthoglide_ident.cli import main
from orthoglide_ident.errors import ConfigError


def _mixed_csv(tmp_path):
    """A SCARA-like log: j1 revolute in degrees, j2 prismatic in metres."""
    t = np.arange(40) * 0.01
    q1_deg, q2_m = 30.0 * np.sin(t), 0.2 + 0.05 * np.cos(t)
    qd1_deg, qd2_m = 30.0 * np.cos(t), -0.05 * np.sin(t)
    path = tmp_path / "scara.csv"
    rows = np.column_stack([t, q1_deg, q2_m, qd1_deg, qd2_m, 0.1 * t, -0.2 * t])
    np.savetxt(path, rows, delimiter=",", fmt="%.17g",
               header="t,j1.q,j2.q,j1.qd,j2.qd,j1.effort,j2.effort", comments="")
    return path, (q1_deg, q2_m, qd1_deg, qd2_m)


def test_degrees_convert_the_revolute_joint_only(tmp_path):
    path, (q1_deg, q2_m, qd1_deg, qd2_m) = _mixed_csv(tmp_path)
    got = read_csv(path, ColumnMap(angle_unit="deg", prismatic=("j2",), velocity="{joint}.qd",
                                   effort_unit="A"))
    assert np.allclose(got.q[:, 0], q1_deg * math.pi / 180, rtol=1e-15, atol=0)
    assert np.array_equal(got.q[:, 1], q2_m) and np.array_equal(got.qd[:, 1], qd2_m)
    assert np.allclose(got.qd[:, 0], qd1_deg * math.pi / 180, rtol=1e-15, atol=0)


def test_the_import_flag_keeps_the_prismatic_joints_metres(tmp_path, capsys):
    path, (_, q2_m, _, _) = _mixed_csv(tmp_path)
    assert main(["import", str(path), "--out", str(tmp_path / "bag"), "--effort-unit", "A",
                 "--angle-unit", "deg", "--prismatic", "j2"]) == 0
    q = bags.read_bag(tmp_path / "bag").positions.position
    assert np.allclose(q[:, 1], q2_m, rtol=1e-15, atol=0)


def test_a_prismatic_joint_not_in_the_log_is_refused(tmp_path):
    path, _ = _mixed_csv(tmp_path)
    with pytest.raises(ConfigError, match=r"prismatic joints \['j3'\]"):
        read_csv(path, ColumnMap(angle_unit="deg", prismatic=("j3",), effort_unit="A"))
