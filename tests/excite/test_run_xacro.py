"""``excite run`` takes a .xacro robot as identify and excite design do (issue 45): ``--robot``
with ``--xacro-arg NAME:=VALUE`` (repeatable) and ``--package-dir``, through the one grammar
(flags.py, model/registry.py). The reference is the robot loaded directly by load_robot."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
from trajectories import small_trajectory  # noqa: E402

from orthoglide_ident.cli import build_parser  # noqa: E402
from orthoglide_ident.errors import ConfigError  # noqa: E402
from orthoglide_ident.excite import plan as plan  # noqa: E402
from orthoglide_ident.excite.run_command import run_robot  # noqa: E402
from orthoglide_ident.model.registry import load_robot  # noqa: E402

FIXTURE = Path(__file__).resolve().parents[1] / "fixtures" / "xacro_vendor"
ARM = FIXTURE / "acme_arm_description" / "urdf" / "acme_arm.urdf.xacro"
JOINTS = ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "finger_left_joint")


@pytest.fixture(autouse=True)
def _own_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    monkeypatch.setenv("AMENT_PREFIX_PATH", str(tmp_path / "no_prefix"))


def _args(*extra: str):
    return build_parser().parse_args(["excite", "run", "t.yaml", "--condition", "unloaded",
                                      "--robot", str(ARM), "--package-dir", str(FIXTURE),
                                      *extra])


def test_excite_run_expands_the_xacro_with_its_arguments():
    args = _args("--xacro-arg", "arm_type:=a5", "--xacro-arg", "prefix:=left_")
    ref = load_robot(ARM, {"arm_type": "a5", "prefix": "left_"}, package_dirs=[FIXTURE])
    middle = np.array([(j.lower + j.upper) / 2 for j in ref.joints])
    traj = small_trajectory("acme_arm", tuple("left_" + j for j in JOINTS), middle, 4.0,
                            amplitude=0.005)
    robot = run_robot(args, traj)
    a3 = load_robot(ARM, {"prefix": "left_"}, package_dirs=[FIXTURE])
    assert tuple(robot.joint_names) == tuple(ref.joint_names) == traj.joints
    np.testing.assert_allclose(robot.standard_values(), ref.standard_values(), atol=1e-12)
    assert not np.allclose(robot.standard_values(), a3.standard_values())  # the type took
    plan.check_run(traj, "unloaded", robot, "t.yaml")  # the prefixed joints are the run's


def test_excite_run_without_the_argument_names_the_mismatch():
    args = _args()  # no prefix: the trajectory's prefixed joints are not this robot's
    traj = small_trajectory("acme_arm", tuple("left_" + j for j in JOINTS), np.zeros(4))
    with pytest.raises(ConfigError, match="moves joints left_shoulder_pan_joint"):
        plan.check_run(traj, "unloaded", run_robot(args, traj), "t.yaml")


def test_a_bad_xacro_argument_is_one_line():
    args = _args("--xacro-arg", "arm_type=a5")
    with pytest.raises(ConfigError, match="expected NAME:=VALUE"):
        run_robot(args, small_trajectory("acme_arm", JOINTS, np.zeros(4)))
