"""The identified URDF of a robot with a transmission (issue 33, model/urdf_transmission.py):
read back by model/transmission.py it gives the same N and offsets; the rigid part loads in
Pinocchio with the identified inertials; a coupling ros2_control has no transmission for is a
comment and a warning line."""
from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
import pytest
import yaml

from orthoglide_ident.model.registry import ROBOTS_DIR, load_robot
from orthoglide_ident.model.transmission import urdf_transmission
from orthoglide_ident.model.urdf_transmission import blocks, ros2_control_form

UR5_JOINTS = ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint",
              "wrist_2_joint", "wrist_3_joint")
MOTORS = ("m1", "m2", "m3", "m4", "m5", "m6")
SIMPLE = (-32.0, 32.0, -45.0, 48.0, 45.0, -32.0)
DIFFERENTIAL = [[20.0, 20.0], [30.0, -30.0]]  # a1 = 20, a2 = 30, j1 = j2 = 1 (joints 5, 6)
WRIST = [[45.0, 0.0], [32.0, 32.0]]  # the coupled wrist: the last motor turns with q5 + q6


def _n(wrist) -> np.ndarray:
    N = np.diag(SIMPLE)
    N[4:, 4:] = wrist
    return N


def _robot(tmp: Path, N: np.ndarray, offset, stem: str):
    data = yaml.safe_load((ROBOTS_DIR / "ur5.yaml").read_text())
    data.pop("excitation")
    data.update(name=f"ur5_{stem}", description=str(ROBOTS_DIR / "ur5.urdf"),
                transmission={"actuators": list(MOTORS), "reduction": N.tolist(),
                              "offset": list(offset)})
    path = tmp / f"{stem}.yaml"
    path.write_text(yaml.safe_dump(data))
    return load_robot(path)


def _identified(robot, tmp: Path, stem: str) -> tuple[Path, np.ndarray, np.ndarray]:
    """The URDF of the description's inertials with distinct motor terms and gains."""
    chi = robot.standard_values()
    first = len(robot.rigid_columns)
    chi[first:] = 1e-3 * (1.0 + np.arange(len(chi) - first))
    gains = 0.1 + 0.01 * np.arange(robot.n_joints)
    path = tmp / f"{stem}.urdf"
    path.write_text(robot.identified_urdf(chi, gains))
    return path, chi, gains


@pytest.mark.parametrize("wrist, stem", [(np.diag(SIMPLE[4:]), "simple"),
                                         (DIFFERENTIAL, "differential"), (WRIST, "four_bar")])
def test_written_transmissions_read_back_as_the_same_n(tmp_path, wrist, stem):
    offset = [0.5, -1.0, 0.25, 2.0, -0.75, 1.5]
    robot = _robot(tmp_path, _n(wrist), offset, stem)
    path, chi, _ = _identified(robot, tmp_path, stem)
    back = urdf_transmission(path, UR5_JOINTS)
    assert back.actuators == MOTORS
    np.testing.assert_allclose(back.N, robot.transmission.N, rtol=1e-14, atol=0)
    np.testing.assert_allclose(back.offset, offset, rtol=1e-14, atol=1e-15)
    again = load_robot(path)  # the URDF alone: its own transmission, the identified inertials
    np.testing.assert_allclose(again.transmission.N, robot.transmission.N, rtol=1e-14)
    rigid = again.standard_values()[:len(again.rigid_columns)]
    np.testing.assert_allclose(rigid, chi[:len(robot.rigid_columns)], rtol=1e-9, atol=1e-12)


def test_simple_drive_terms_are_reflected_to_the_joint_and_kept_per_motor(tmp_path):
    robot = _robot(tmp_path, np.diag(SIMPLE), [0.0] * 6, "reflected")
    path, chi, gains = _identified(robot, tmp_path, "reflected")
    text = path.read_text()
    values = dict(zip(robot.standard_names, chi))
    n = SIMPLE[3]
    assert f'damping="{float(n * n * values["fv_m4"])!r}"' in text
    assert f'friction="{float(abs(n) * values["fs_m4"])!r}"' in text
    assert f"motor m4 (identified, motor side): ia = {values['ia_m4']:.6g}" in text
    assert f"g_tau = {gains[3]:.6g} N·m/A" in text
    assert "m1 0.1 N·m/A" in text  # the header names the motors' gains


def test_a_coupling_without_a_ros2_control_transmission_is_a_comment_and_a_warning(
        tmp_path, caplog):
    N = np.diag(SIMPLE)
    N[3:, 3:] = [[48.0, 0.0, 0.0], [10.0, 45.0, 0.0], [10.0, 32.0, 32.0]]
    robot = _robot(tmp_path, N, [0.0] * 6, "three")
    with caplog.at_level(logging.WARNING, "orthoglide_ident"):
        path, _, _ = _identified(robot, tmp_path, "three")
    assert any("have no ros2_control transmission" in r.getMessage() for r in caplog.records)
    text = path.read_text()
    assert "NOT A ros2_control TRANSMISSION" in text and "motor m6 (identified" in text
    back = urdf_transmission(path, UR5_JOINTS)  # the three simple ones; the rest 1:1
    np.testing.assert_array_equal(back.N[:3, :3], N[:3, :3])
    np.testing.assert_array_equal(back.N[3:, 3:], np.eye(3))


def test_blocks_and_forms():
    assert blocks(_n(WRIST)) == [([0], [0]), ([1], [1]), ([2], [2]), ([3], [3]),
                                 ([4, 5], [4, 5])]
    assert ros2_control_form(np.array(DIFFERENTIAL))[0] == "DifferentialTransmission"
    assert ros2_control_form(np.array(WRIST))[0] == "FourBarLinkageTransmission"
    assert ros2_control_form(np.array([[0.0, 45.0], [32.0, 32.0]]))[0] == \
        "FourBarLinkageTransmission"  # rows or joints swapped
    assert ros2_control_form(np.array([[1.0, 2.0], [3.0, 4.0]])) is None


def test_a_urdf_s_own_ros2_control_block_keeps_its_hardware_and_gets_the_new_transmissions(
        tmp_path):
    """A bare URDF robot whose <ros2_control> has a <hardware> and its transmissions: written
    back with the same hardware and one identified transmission per motor, not two sets."""
    import xml.etree.ElementTree as ET

    blocks_xml = "".join(
        f"<transmission name='t{k}'><plugin>transmission_interface/SimpleTransmission</plugin>"
        f"<actuator name='{j}_motor' role='actuator1'/><joint name='{j}' role='joint1'>"
        f"<mechanical_reduction>{n}</mechanical_reduction><offset>0.1</offset></joint>"
        f"</transmission>" for k, (j, n) in enumerate(zip(UR5_JOINTS, SIMPLE)))
    source = tmp_path / "ur5_hw.urdf"
    source.write_text((ROBOTS_DIR / "ur5.urdf").read_text().replace(
        "</robot>", "<ros2_control name='hw' type='system'><hardware><plugin>my/Hardware"
        f"</plugin></hardware>{blocks_xml}</ros2_control></robot>"))
    robot = load_robot(source)
    path, _, _ = _identified(robot, tmp_path, "hw")
    root = ET.parse(path).getroot()
    (rc,) = root.findall("ros2_control")
    assert rc.findtext("hardware/plugin") == "my/Hardware"
    assert len(rc.findall("transmission")) == 6
    back = urdf_transmission(path, UR5_JOINTS)
    np.testing.assert_allclose(back.N, np.diag(SIMPLE), rtol=1e-15)
    np.testing.assert_allclose(back.offset, robot.transmission.offset, rtol=1e-14)
