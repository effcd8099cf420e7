"""``--robot FILE.xml``: an MJCF read by Pinocchio (joints, bodies, inertials), its joints'
armature, damping and frictionloss taken as the nominal ia, fv, fs (and said). The reference is
MuJoCo's own inverse dynamics of the same file (tests/fixtures/mjcf/three_link.xml)."""
from __future__ import annotations

import logging
import subprocess
import sys
from pathlib import Path

import mujoco
import numpy as np
import pytest

from orthoglide_ident.model import registry
from orthoglide_ident.model.registry import load_robot

MJCF = Path(__file__).resolve().parents[1] / "fixtures" / "mjcf" / "three_link.xml"
JOINTS = ("j1", "j2", "j3", "s4")


def test_the_mjcf_model_is_mujocos(caplog):
    registry._load.cache_clear()  # loaded here, so that what it says is seen
    with caplog.at_level(logging.INFO, logger="orthoglide_ident"):
        robot = load_robot(MJCF)
    assert robot.joint_names == JOINTS
    assert [j.kind for j in robot.joints] == ["revolute"] * 3 + ["prismatic"]
    m = mujoco.MjModel.from_xml_path(str(MJCF))
    named = dict(zip(robot.standard_names, robot.standard_values()))
    for k, j in enumerate(JOINTS, 1):  # nominal drive terms: the file's own
        dof = m.joint(j).dofadr[0]
        assert named[f"ia_{k}"] == pytest.approx(m.dof_armature[dof])
        assert named[f"fv_{k}"] == pytest.approx(m.dof_damping[dof])
        assert named[f"fs_{k}"] == pytest.approx(m.dof_frictionloss[dof])
        assert named[f"m_{k}"] == pytest.approx(m.body_mass[m.joint(j).bodyid[0]])
    # the whole model, inertials and armature and damping: MuJoCo's inverse dynamics
    off = mujoco.mjtDisableBit
    m.opt.disableflags |= off.mjDSBL_FRICTIONLOSS | off.mjDSBL_CONTACT | off.mjDSBL_LIMIT
    d = mujoco.MjData(m)
    q, qd, qdd = robot.random_states(30, seed=4)
    chi = robot.standard_values()
    chi[[i for i, n in enumerate(robot.standard_names) if n.startswith(("fs_", "tauoff_"))]] = 0
    tau = (robot.standard_regressor(q, qd, qdd) @ chi).reshape(robot.n_joints, -1).T
    for k in range(q.shape[0]):
        d.qpos[:], d.qvel[:], d.qacc[:] = q[k], qd[k], qdd[k]
        mujoco.mj_inverse(m, d)
        np.testing.assert_allclose(d.qfrc_inverse, tau[k], rtol=1e-9, atol=1e-9)
    said = " ".join(r.getMessage() for r in caplog.records)
    assert "armature/damping/frictionloss taken as the nominal ia/fv/fs" in said
    assert "j1 0.05/0.8/0.4" in said


def test_the_cli_takes_an_mjcf():
    p = subprocess.run([sys.executable, "-m", "orthoglide_ident.cli", "model", "--robot",
                        str(MJCF)], capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    assert "base parameters of robot three_link" in p.stdout
    assert "s4 (prismatic, actuated)" in p.stdout
