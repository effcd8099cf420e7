"""xacro descriptions expanded in-process (model/xacro_files.py) on a vendor-style fixture:
tests/fixtures/xacro_vendor holds two packages (an arm and a gripper) written as vendors write
them: ``$(find pkg)`` includes nested three deep, a type argument choosing ``config/<type>/*.yaml``
read through ``xacro.load_yaml`` (with ``!degrees``), macros with a prefix, a block parameter, a
``<ros2_control>`` block with mock hardware and a mimic joint. The reference is the URDF expanded
by hand (acme_arm_a3_by_hand.urdf), loaded by the plain URDF path."""
from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.model.registry import load_robot
from orthoglide_ident.model.xacro_files import expand, parse_xacro_args

FIXTURE = Path(__file__).resolve().parents[1] / "fixtures" / "xacro_vendor"
ARM = FIXTURE / "acme_arm_description" / "urdf" / "acme_arm.urdf.xacro"
BY_HAND = FIXTURE / "acme_arm_a3_by_hand.urdf"


@pytest.fixture(autouse=True)
def _own_cache(tmp_path, monkeypatch):
    """Expanded files in this test's folder; no package path from the environment."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    monkeypatch.setenv("AMENT_PREFIX_PATH", str(tmp_path / "no_prefix"))


def _same_base_model(a, b) -> None:
    assert a.names == b.names
    assert a.joint_names == b.joint_names
    np.testing.assert_allclose(a.K, b.K, atol=1e-9)  # the regrouping coefficients (eq. 21)
    np.testing.assert_allclose(a.standard_values(), b.standard_values(), atol=1e-9)
    np.testing.assert_allclose(a.base_values(a.standard_values()),
                               b.base_values(b.standard_values()), atol=1e-9)
    for ja, jb in zip(a.joints, b.joints):
        assert (ja.kind, ja.lower, ja.upper) == pytest.approx((jb.kind, jb.lower, jb.upper))


def test_the_vendor_style_xacro_gives_the_hand_expanded_model():
    robot = load_robot(ARM, package_dirs=[FIXTURE])
    by_hand = load_robot(BY_HAND)
    assert robot.name == "acme_arm"
    assert robot.description.path.suffix == ".urdf"
    assert "finger_right_joint" in robot.mimics  # the gripper's mimic joint, kept
    _same_base_model(robot, by_hand)


def test_the_type_argument_picks_its_parameter_files(tmp_path):
    a5 = load_robot(ARM, {"arm_type": "a5"}, package_dirs=[FIXTURE])
    links = yaml.safe_load((FIXTURE / "acme_arm_description/config/a5/"
                            "physical_parameters.yaml").read_text())["links"]
    chi = dict(zip(a5.standard_names, a5.standard_values()))
    # body labels 1..3: shoulder, upper_arm, forearm (+ the 0.4 kg gripper base fixed to it)
    assert chi["m_1"] == pytest.approx(links["shoulder"]["mass"])
    assert chi["m_2"] == pytest.approx(links["upper_arm"]["mass"])
    assert chi["m_3"] == pytest.approx(links["forearm"]["mass"] + 0.4)
    # the same from a robot file's xacro_args, the package found through ROS_PACKAGE_PATH
    rf = tmp_path / "acme.yaml"
    rf.write_text(f"description: {ARM}\nxacro_args: {{arm_type: a5}}\nnominal_gains: 2.0\n")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("ROS_PACKAGE_PATH", str(FIXTURE))
        from_file = load_robot(rf)
    _same_base_model(from_file, a5)
    assert from_file.nominal_gains.tolist() == [2.0] * 4


def test_packages_found_through_the_ament_index(tmp_path, monkeypatch):
    prefix = tmp_path / "install"
    for pkg in ("acme_arm_description", "acme_gripper_description"):
        shutil.copytree(FIXTURE / pkg, prefix / "share" / pkg)
        marker = prefix / "share/ament_index/resource_index/packages" / pkg
        marker.parent.mkdir(parents=True, exist_ok=True)
        marker.write_text("")
    monkeypatch.setenv("AMENT_PREFIX_PATH", str(prefix))
    text = expand(prefix / "share/acme_arm_description/urdf/acme_arm.urdf.xacro")
    # package:// meshes rewritten to the files found (the expanded URDF lives in a cache)
    mesh = prefix / "share/acme_arm_description/meshes/a3/base.stl"
    assert f'filename="{mesh.resolve()}"' in text


@pytest.mark.parametrize("args, dirs, words", [
    ({}, [], ["package 'acme_arm_description' not found", "ament index", "--package-dir"]),
    ({"arm_type": "a7"}, [FIXTURE], ["no such file", "config/a7/kinematics.yaml"]),
    ({"arm_typ": "a5"}, [FIXTURE], ["['arm_typ'] are not declared", "arm_type"]),
])
def test_a_missing_package_file_or_argument_is_named(args, dirs, words):
    with pytest.raises(ConfigError) as err:
        load_robot(ARM, args, package_dirs=dirs)
    msg = str(err.value)
    assert "\n" not in msg and str(ARM) in msg
    for w in words:
        assert w in msg


def test_a_required_argument_without_default(tmp_path):
    top = tmp_path / "arm.urdf.xacro"
    top.write_text('<robot xmlns:xacro="http://www.ros.org/wiki/xacro" name="r">'
                   '<link name="$(arg ur_type)"/></robot>')
    with pytest.raises(ConfigError, match=r"xacro argument 'ur_type' is not given and has no "
                                          r"default: give --xacro-arg ur_type:=VALUE"):
        expand(top)


def test_xacro_arg_grammar():
    assert parse_xacro_args(["ur_type:=ur10e", "prefix:="]) == {"ur_type": "ur10e", "prefix": ""}
    with pytest.raises(ConfigError, match="expected NAME:=VALUE"):
        parse_xacro_args(["ur_type=ur10e"])


def _cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "orthoglide_ident.cli", *args],
                          capture_output=True, text=True, timeout=120)


def test_the_cli_takes_a_xacro_with_its_arguments():
    ok = _cli("model", "--robot", str(ARM), "--xacro-arg", "arm_type:=a5",
              "--package-dir", str(FIXTURE))
    assert ok.returncode == 0, ok.stderr
    assert "34 base parameters of robot acme_arm" in ok.stdout
    bad = _cli("model", "--robot", str(ARM))
    assert bad.returncode == 2
    assert bad.stderr.count("\n") == 1 and "package 'acme_arm_description' not found" in bad.stderr
