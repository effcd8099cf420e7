"""A bag's tag says whose signals it holds (orthoglide.position_side, orthoglide.effort_side):
identify reads the bag as tagged, whatever the robot file's transmission says (the tag was
written with the signals; the file says what a hardware publishes by default), and says so in
the log and the record's sources; a bag without the tag is read as the robot file says, as
before; motor-side positions of a robot without a transmission are refused, naming the bag."""
from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
import pytest
import yaml

from orthoglide_ident.bags import write_bag
from orthoglide_ident.errors import BagError
from orthoglide_ident.identify import read_record
from orthoglide_ident.model.registry import ROBOTS_DIR, load_robot

JOINTS = ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint",
          "wrist_2_joint", "wrist_3_joint")
MOTORS = ("m1", "m2", "m3", "m4", "m5", "m6")
N = np.array([[32, 0, 0, 0, 0, 0], [0, -32, 0, 0, 0, 0], [0, 0, 45, 0, 0, 0],
              [0, 0, 0, -48, 0, 0], [0, 0, 0, 0, 45, 0], [0, 0, 0, 0, 32, 32]], float)
OFFSET = np.array([0.5, 0.0, -1.0, 0.0, 0.0, 2.0])  # rad, motor side
T = np.arange(200) * 1e-3
Q_J = 0.3 * np.sin(np.outer(T, np.arange(1, 7)))
Q_M = Q_J @ N.T + OFFSET
V = np.cos(np.outer(T, np.arange(1, 7)))  # A, or N·m at the joints


def _robot(tmp: Path, **sides) -> Path:
    """The UR5 with the coupled wrist's N, motors m1..m6; ``sides``: the file's
    position_side / effort_side (absent: joint / actuator)."""
    data = yaml.safe_load((ROBOTS_DIR / "ur5.yaml").read_text())
    data.pop("excitation")
    tx = {"actuators": list(MOTORS), "reduction": N.tolist(), "offset": OFFSET.tolist(), **sides}
    data.update(name="ur5_sides", description=str(ROBOTS_DIR / "ur5.urdf"), transmission=tx)
    path = tmp / f"ur5_{'_'.join(sides.values()) or 'default'}.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def _bag(tmp: Path, name: str, q: np.ndarray, q_names, v: np.ndarray, v_names, **tags) -> Path:
    """A ros2_control bag (/joint_states) whose positions are ``q_names``' and currents (efforts)
    ``v_names``': one joint_states topic carries both, so names are those of q (the currents
    padded under them)."""
    names = tuple(q_names)
    assert tuple(v_names) == names
    return write_bag(tmp / name, (T * 1e9).astype(np.int64), q, v, "unloaded", 0.0, names,
                     layout="joint_states", **tags)


def test_motor_side_positions_tagged_win_over_a_joint_side_robot_file(tmp_path, caplog):
    """The file says joint-side positions (the default); the bag is tagged actuator and holds
    the motor encoders under the motors' names: read as the motors' (not mapped again), said
    in the log and the sources."""
    model = load_robot(_robot(tmp_path))
    bag = _bag(tmp_path, "motors", Q_M, MOTORS, V, MOTORS, position_side="actuator")
    with caplog.at_level(logging.INFO, logger="orthoglide_ident.identify"):
        rec = read_record(bag, model)
    np.testing.assert_allclose(rec.q, Q_M, rtol=0, atol=1e-12)
    assert np.array_equal(rec.v_tau, V)
    assert "positions actuator-side as the bag is tagged (the robot file says joint)" in rec.sources
    assert "mapped" not in rec.sources
    said = [r.getMessage() for r in caplog.records]
    assert any(str(bag) in m and "positions read actuator-side as the bag's tag says" in m
               for m in said), said


def test_joint_side_positions_tagged_win_over_an_actuator_side_robot_file(tmp_path):
    """The reverse: the file says the hardware publishes the motors' positions, the bag is
    tagged joint and holds q_j under the joints' names: mapped to the motors,
    q_m = N q_j + offset."""
    model = load_robot(_robot(tmp_path, position_side="actuator"))
    bag = _bag(tmp_path, "joints", Q_J, JOINTS, V, JOINTS, position_side="joint",
               effort_side="joint")
    rec = read_record(bag, model)
    np.testing.assert_allclose(rec.q, Q_M, rtol=0, atol=1e-12)
    assert "joint-side positions mapped to the motors" in rec.sources
    # effort_side joint (the file says actuator): v_m = N⁻ᵀ v_j
    np.testing.assert_allclose(rec.v_tau, V @ np.linalg.inv(N), rtol=1e-12, atol=1e-15)
    assert "efforts joint-side as the bag is tagged (the robot file says actuator)" in rec.sources


def test_a_tag_that_agrees_or_is_absent_reads_as_the_robot_file_says(tmp_path):
    """Today's behaviour (a hardware publishing both signals joint-side, as the file says)."""
    model = load_robot(_robot(tmp_path, effort_side="joint"))
    untagged = read_record(_bag(tmp_path, "plain", Q_J, JOINTS, V, JOINTS), model)
    agreeing = read_record(_bag(tmp_path, "same", Q_J, JOINTS, V, JOINTS,
                                position_side="joint"), model)
    for rec in (untagged, agreeing):
        np.testing.assert_allclose(rec.q, Q_M, rtol=0, atol=1e-12)
        assert "as the bag is tagged" not in rec.sources
    assert agreeing.sources == untagged.sources
    # tagged joint-side positions under the motors' names: the channels the tag asks for
    # are missing, said with the names (not read as the motors')
    bad = _bag(tmp_path, "misnamed", Q_J, MOTORS, V, MOTORS, position_side="joint")
    with pytest.raises(BagError, match=f"{bad}: .*shoulder_pan_joint"):
        read_record(bad, model)


def test_motor_side_positions_of_a_robot_without_a_transmission_are_refused(tmp_path):
    """Nothing maps a motor's position to its joint: a one-line reason naming the bag. Joint-side
    tags on such a robot are what it reads anyway."""
    plain = tmp_path / "ur5_plain.urdf"
    plain.write_text((ROBOTS_DIR / "ur5.urdf").read_text())
    model = load_robot(plain)
    bag = _bag(tmp_path, "motors", Q_M, JOINTS, V, JOINTS, position_side="actuator")
    with pytest.raises(BagError) as exc:
        read_record(bag, model)
    msg = str(exc.value)
    assert msg.startswith(f"{bag}: tagged orthoglide.position_side actuator") and "\n" not in msg
    assert "has no transmission" in msg
    ok = _bag(tmp_path, "joints", Q_J, JOINTS, V, JOINTS, position_side="joint",
              effort_side="actuator")
    rec = read_record(ok, model)
    np.testing.assert_allclose(rec.q, Q_J, rtol=0, atol=1e-12)
