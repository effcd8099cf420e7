"""``--robot`` to a RobotModel (model/registry.py), and bad robot files: every mistake a one-line
ConfigError that says what is wrong, never a traceback from the parsers."""
from __future__ import annotations

import shutil
from pathlib import Path

import pytest
import yaml

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.model.orthoglide.base import BaseModel
from orthoglide_ident.model.pinocchio_model import PinocchioRobot
from orthoglide_ident.model.registry import ROBOTS_DIR, bundled_robots, load_robot, read_yaml

FIVE_BAR = read_yaml(ROBOTS_DIR / "five_bar.yaml")


def test_bundled_robots():
    assert {"orthoglide", "orthoglide_general", "ur5", "five_bar"} <= set(bundled_robots())
    assert isinstance(load_robot(""), BaseModel) and isinstance(load_robot("orthoglide"), BaseModel)
    assert isinstance(load_robot("five_bar"), PinocchioRobot)
    assert load_robot(ROBOTS_DIR / "five_bar.yaml") is load_robot(str(ROBOTS_DIR / "five_bar.yaml"))


def test_a_bare_urdf_actuates_every_movable_joint():
    ur5 = load_robot(ROBOTS_DIR / "ur5.urdf")
    assert ur5.n_joints == 6 and ur5.nominal_gains.tolist() == [1.0] * 6
    assert ur5.payload_frame == "wrist_3_link"  # the last movable joint's link
    assert ur5.names == load_robot("ur5").names


def five_bar_file(tmp_path: Path, urdf: str | None = None, **changes) -> Path:
    """A copy of the five-bar's YAML (and URDF, or the text given), keys changed (None: removed)."""
    data = dict(FIVE_BAR)
    for key, value in changes.items():
        if value is None:
            data.pop(key, None)
        else:
            data[key] = value
    if urdf is None:
        shutil.copy(ROBOTS_DIR / "five_bar.urdf", tmp_path / "five_bar.urdf")
    else:
        (tmp_path / "five_bar.urdf").write_text(urdf)
    path = tmp_path / "robot.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def one_line_error(path: Path, match: str) -> str:
    with pytest.raises(ConfigError, match=match) as err:
        load_robot(path)
    assert "\n" not in str(err.value)
    return str(err.value)


def test_a_file_that_is_not_xml(tmp_path):
    one_line_error(five_bar_file(tmp_path, urdf="<robot name='x'><link name="),
                   r"five_bar.urdf is not valid XML \(.*line 1")


def test_a_urdf_that_does_not_parse(tmp_path):
    bad = ('<robot name="x"><link name="a"/><link name="b"/><joint name="j" type="revolute">'
           '<parent link="a"/><child link="b"/></joint></robot>')
    one_line_error(five_bar_file(tmp_path, urdf=bad),
                   "is not a valid URDF: Joint \\[j\\] is of type REVOLUTE but it does not "
                   "specify limits")


def test_a_missing_description(tmp_path):
    one_line_error(five_bar_file(tmp_path, description="nowhere.urdf"),
                   "nowhere.urdf: no such file")
    one_line_error(five_bar_file(tmp_path, description=None), "description: the URDF or MJCF file")


def test_an_actuated_joint_that_does_not_exist(tmp_path):
    msg = one_line_error(five_bar_file(tmp_path, actuated_joints=["joint_1", "joint_9"]),
                         "actuated joint 'joint_9' is not a movable joint of five_bar.urdf")
    assert "joint_1, joint_3, joint_2, joint_4" in msg


def test_a_loop_frame_that_does_not_exist(tmp_path):
    one_line_error(five_bar_file(tmp_path, loops=[{"frame_a": "tip", "frame_b": "tool"}]),
                   "loop tip-tool: the description has no frame .* named 'tool'")
    hinge = [{"frame_a": "tip", "frame_b": "tip_2", "type": "hinge"}]
    one_line_error(five_bar_file(tmp_path, loops=hinge), "type 'hinge' is not point or frame")


def test_a_loop_that_does_not_close(tmp_path):
    """tip_2 moved 1 m out along the distal link: the two legs cannot meet."""
    urdf = (ROBOTS_DIR / "five_bar.urdf").read_text().replace(
        '<parent link="distal_2" />\n    <child link="tip_2" />\n    <origin xyz="0.3 0 0"',
        '<parent link="distal_2" />\n    <child link="tip_2" />\n    <origin xyz="1.3 0 0"')
    assert "1.3 0 0" in urdf
    one_line_error(five_bar_file(tmp_path, urdf=urdf),
                   "the loops do not close at the reference configuration .*check the loops' "
                   "frames")


def test_loops_that_leave_the_wrong_mobility(tmp_path):
    one_line_error(five_bar_file(tmp_path, actuated_joints=["joint_1"], nominal_gains=None),
                   "the loops leave 2 degrees of freedom .* but 1 joints are actuated")
    one_line_error(five_bar_file(tmp_path, loops=None),
                   r"joints \['joint_3', 'joint_4'\] move but are neither actuated nor closed "
                   "by a loop")


def test_keys_of_the_wrong_kind(tmp_path):
    def bad(match: str, **changes) -> None:
        one_line_error(five_bar_file(tmp_path, **changes), match)

    bad(r"unknown keys \['actuated_joint'\]", actuated_joint=["joint_1"])
    bad("3 nominal_gains for 2 actuated", nominal_gains=[0.5, 0.5, 0.5])
    bad("gravity: expected 3 numbers", gravity=[0, -9.8])
    bad("payload frame 'gripper' is not a frame", payload_frame="gripper")
    bad("reference_configuration names 'joint_9'", reference_configuration={"joint_9": 1.0})
    bad("passive_friction: expected true or false", passive_friction="yes")
    bad(r"column_order group \['1', '2'\] mixes bodies with different parameters",
        column_order=[["1", "2"]])
    bad("fixed body 'distal_1' is moved by a joint of its own", fixed_bodies=["distal_1"])
    bad("fixed body 'gripper': .* no link", fixed_bodies=["gripper"])
    bad(r"body_labels names \['elbow'\]", body_labels={"elbow": "5"})


def test_a_yaml_that_is_not_a_mapping(tmp_path):
    path = tmp_path / "robot.yaml"
    path.write_text("- just\n- a list\n")
    one_line_error(path, "expected a mapping of keys")
