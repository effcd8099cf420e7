"""Exciting trajectories on a robot with locked joints (issue 43): the example-robot-data Panda,
its fingers locked at 0.03 m. The collision bodies of the locked fingers sit where the full URDF
puts them at that opening (Pinocchio's own geometry of the full tree: the reference), the design
writes the locks into the trajectory file, and ``excite check`` refuses the file for a robot
that locks them elsewhere."""
from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
import yaml

from orthoglide_ident.cli import main
from orthoglide_ident.excite.collision import CollisionModel
from orthoglide_ident.model.registry import load_robot

L = pytest.importorskip("locked_panda")
if not L.installed():
    pytest.skip("example-robot-data (requirements.txt) is not installed", allow_module_level=True)


def test_the_locked_fingers_collision_bodies_hold_their_opening(tmp_path):
    robot = load_robot(L.robot_file(tmp_path))
    coll = CollisionModel(robot, "mesh", [str(L.share_dir())])
    full = pin.buildModelFromUrdf(str(L.urdf_path()))
    geom = pin.buildGeomFromUrdf(full, str(L.urdf_path()), pin.GeometryType.COLLISION,
                                 package_dirs=[str(L.share_dir())])
    q = np.random.default_rng(2).uniform(-1.0, 1.0, 7)
    got, want = pin.GeometryData(coll.geom), pin.GeometryData(geom)
    pin.updateGeometryPlacements(robot.model, robot.model.createData(), coll.geom, got, q)
    pin.updateGeometryPlacements(full, full.createData(), geom, want,
                                 np.r_[q, L.FINGER, L.FINGER])
    names = [g.name for g in geom.geometryObjects]
    fingers = [n for n in names if "finger" in n]
    assert len(fingers) >= 2 and [g.name for g in coll.geom.geometryObjects][:len(names)] == names
    for k, name in enumerate(names):
        assert np.allclose(got.oMg[k].homogeneous, want.oMg[k].homogeneous, atol=1e-12), name


def test_design_keeps_the_locks_and_check_refuses_other_locks(tmp_path, capsys):
    traj = tmp_path / "traj.yaml"
    robot = str(L.robot_file(tmp_path))
    assert main(["excite", "design", "--robot", robot, "--out", str(traj), "--payload-mass",
                 "2", "--restarts", "1", "--steps", "1", "--periods", "1",
                 "--collision", "skip"]) == 0
    assert yaml.safe_load(traj.read_text())["locked_joints"] == {
        L.FINGERS[0]: L.FINGER, L.FINGERS[1]: L.FINGER}
    assert main(["excite", "check", str(traj), "--robot", robot, "--collision", "skip"]) == 0
    capsys.readouterr()
    other = str(L.robot_file(tmp_path, finger=0.02))
    assert main(["excite", "check", str(traj), "--robot", other, "--collision", "skip"]) != 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"{traj} was designed with locked joints" in err[0]
    assert "panda_finger_joint1': 0.02" in err[0], err
