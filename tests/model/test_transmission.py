"""Drive chains (issue 33): each ros2_control transmission against its own formulas, N from the
robot YAML and from a URDF's <ros2_control> block, and bad descriptions.

The reference formulas below are ros2_control's transmission_interface ones
(simple_transmission.hpp, differential_transmission.hpp, four_bar_linkage_transmission.hpp),
written out here independently of model/transmission.py, which builds one matrix N from them.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.model.registry import ROBOTS_DIR, load_robot
from orthoglide_ident.model.transmission import Transmission, urdf_transmission

RNG = np.random.default_rng(7)
UR5_JOINTS = ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint",
              "wrist_2_joint", "wrist_3_joint")


def _two(xml: str, joints=("j1", "j2")) -> Transmission:
    return _from_urdf(f"<ros2_control name='hw' type='system'>{xml}</ros2_control>", joints)


def _from_urdf(block: str, joints, tmp=None) -> Transmission:
    import tempfile

    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "t.urdf"
        p.write_text(f"<robot name='t'>{block}</robot>")
        return urdf_transmission(p, joints)


def _elements(plugin: str, jr, ar, off) -> str:
    js = "".join(f"<joint name='j{k + 1}' role='joint{k + 1}'><mechanical_reduction>{r}"
                 f"</mechanical_reduction><offset>{o}</offset></joint>"
                 for k, (r, o) in enumerate(zip(jr, off)))
    acts = "".join(f"<actuator name='a{k + 1}' role='actuator{k + 1}'><mechanical_reduction>{r}"
                   f"</mechanical_reduction></actuator>" for k, r in enumerate(ar))
    return (f"<transmission name='t'><plugin>transmission_interface/{plugin}</plugin>"
            f"{acts}{js}</transmission>")


def _check_maps(t: Transmission, a2j, j2a, effort_a2j=None, effort_j2a=None) -> None:
    """Position, velocity (and effort) both ways against the reference functions, on random
    samples; power in = power out for the effort map the identification uses."""
    n = len(t.joints)
    q_j, qd_j, tau_m = RNG.normal(size=(3, 20, n))
    q_a = np.array([j2a["pos"](x) for x in q_j])
    assert np.allclose(t.to_actuator_position(q_j), q_a, rtol=1e-12, atol=1e-12)
    assert np.allclose(t.to_joint_position(q_a), [a2j["pos"](x) for x in q_a], atol=1e-12)
    assert np.allclose(t.to_joint_position(q_a), q_j, atol=1e-12)
    assert np.allclose(t.to_actuator_rate(qd_j), [j2a["vel"](x) for x in qd_j], atol=1e-12)
    qd_a = t.to_actuator_rate(qd_j)
    assert np.allclose(t.to_joint_rate(qd_a), [a2j["vel"](x) for x in qd_a], atol=1e-12)
    tau_j = t.to_joint_effort(tau_m)
    assert np.allclose(np.sum(tau_j * qd_j, 1), np.sum(tau_m * qd_a, 1), atol=1e-12)
    assert np.allclose(t.to_actuator_effort(tau_j), tau_m, atol=1e-12)
    if effort_a2j is not None:
        assert np.allclose(tau_j, [effort_a2j(x) for x in tau_m], atol=1e-12)
        assert np.allclose(t.to_actuator_effort(tau_j), [effort_j2a(x) for x in tau_j], atol=1e-12)


def test_simple_transmission_with_a_negative_reduction():
    n, o = -48.0, 0.2
    t = _from_urdf("<ros2_control name='hw'>" + _elements("SimpleTransmission", [n], [1], [o])
                   .replace("role='actuator1'", "").replace("role='joint1'", "")
                   + "</ros2_control>", ("j1",))
    assert t.actuators == ("a1",) and np.allclose(t.N, [[n]])
    _check_maps(t, {"pos": lambda a: a / n + o, "vel": lambda a: a / n},
                {"pos": lambda j: n * (j - o), "vel": lambda j: n * j},
                lambda a: n * a, lambda j: j / n)


def test_differential_transmission():
    ar, jr, off = (40.0, -35.0), (2.0, 0.5), (0.1, -0.3)
    t = _two(_elements("DifferentialTransmission", jr, ar, off))
    a2j = {"pos": lambda a: np.array([(a[0] / ar[0] + a[1] / ar[1]) / (2 * jr[0]) + off[0],
                                      (a[0] / ar[0] - a[1] / ar[1]) / (2 * jr[1]) + off[1]]),
           "vel": lambda a: np.array([(a[0] / ar[0] + a[1] / ar[1]) / (2 * jr[0]),
                                      (a[0] / ar[0] - a[1] / ar[1]) / (2 * jr[1])])}
    j2a = {"pos": lambda j: np.array([(jr[0] * (j[0] - off[0]) + jr[1] * (j[1] - off[1])) * ar[0],
                                      (jr[0] * (j[0] - off[0]) - jr[1] * (j[1] - off[1])) * ar[1]]),
           "vel": lambda j: np.array([(jr[0] * j[0] + jr[1] * j[1]) * ar[0],
                                      (jr[0] * j[0] - jr[1] * j[1]) * ar[1]])}
    eff_a2j = lambda a: np.array([jr[0] * (ar[0] * a[0] + ar[1] * a[1]),  # noqa: E731
                                  jr[1] * (ar[0] * a[0] - ar[1] * a[1])])
    eff_j2a = lambda j: np.array([(j[0] / jr[0] + j[1] / jr[1]) / (2 * ar[0]),  # noqa: E731
                                  (j[0] / jr[0] - j[1] / jr[1]) / (2 * ar[1])])
    _check_maps(t, a2j, j2a, eff_a2j, eff_j2a)


def test_four_bar_linkage_transmission():
    """Positions and velocities as ros2_control maps them; the effort is Nᵀ (virtual work).
    ros2_control's own four-bar effort formula is not the transpose of its velocity map (it
    does not conserve power), so it is not the identification's: shown, not followed."""
    ar, jr, off = (-30.0, 25.0), (1.5, 2.0), (0.05, 0.4)
    t = _two(_elements("FourBarLinkageTransmission", jr, ar, off))
    a2j = {"pos": lambda a: np.array([a[0] / (jr[0] * ar[0]) + off[0],
                                      (a[1] / ar[1] - a[0] / (jr[0] * ar[0])) / jr[1] + off[1]]),
           "vel": lambda a: np.array([a[0] / (jr[0] * ar[0]),
                                      (a[1] / ar[1] - a[0] / (jr[0] * ar[0])) / jr[1]])}
    j2a = {"pos": lambda j: np.array([(j[0] - off[0]) * jr[0] * ar[0],
                                      ((j[0] - off[0]) + (j[1] - off[1]) * jr[1]) * ar[1]]),
           "vel": lambda j: np.array([j[0] * jr[0] * ar[0], (j[0] + j[1] * jr[1]) * ar[1]])}
    _check_maps(t, a2j, j2a)
    tau_a = np.array([0.3, -0.7])
    ros2 = np.array(
        [jr[0] * ar[0] * tau_a[0], jr[1] * (ar[1] * tau_a[1] - jr[0] * ar[0] * tau_a[0])]
    )
    assert not np.allclose(t.to_joint_effort(tau_a), ros2)


def _ur5_with_ros2_control(tmp_path: Path, block: str) -> Path:
    text = (ROBOTS_DIR / "ur5.urdf").read_text()
    p = tmp_path / "ur5_tx.urdf"
    p.write_text(text.replace("</robot>", f"<ros2_control name='hw' type='system'>{block}"
                                          "</ros2_control></robot>"))
    return p


def test_n_from_a_urdf_ros2_control_block(tmp_path):
    """A simple transmission (negative) on the base joint and a differential wrist: the robot
    is loaded in actuator space, motors named by the block, untouched joints 1:1."""
    simple = _elements("SimpleTransmission", [-48], [1], [0.1]).replace("j1", "shoulder_pan_joint")
    diff = (
        _elements("DifferentialTransmission", [1, 1], [32, 32], [0, 0])
        .replace("j1", "wrist_2_joint")
        .replace("j2", "wrist_3_joint")
        .replace("a1", "m5")
        .replace("a2", "m6")
    )
    robot = load_robot(_ur5_with_ros2_control(tmp_path, simple.replace("'t'", "'t0'") + diff))
    t = robot.transmission
    assert robot.joint_names == ("a1", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint",
                                 "m5", "m6")
    N = np.eye(6)
    N[0, 0], N[4:, 4:] = -48, [[32, 32], [32, -32]]
    assert np.allclose(t.N, N) and np.allclose(t.offset, [4.8, 0, 0, 0, 0, 0])


def _yaml_robot(tmp_path: Path, transmission) -> Path:
    data = {"name": "ur5_t", "description": str(ROBOTS_DIR / "ur5.urdf"),
            "nominal_gains": [0.1] * 6, "transmission": transmission}
    p = tmp_path / "robot.yaml"
    p.write_text(yaml.safe_dump(data))
    return p


def test_n_from_the_robot_yaml(tmp_path):
    """The issue's coupled wrist: the last motor turns with q5 + q6, a negative gear ratio."""
    N = [[32, 0, 0, 0, 0, 0], [0, 32, 0, 0, 0, 0], [0, 0, 45, 0, 0, 0], [0, 0, 0, -48, 0, 0],
         [0, 0, 0, 0, 45, 0], [0, 0, 0, 0, 32, 32]]
    robot = load_robot(_yaml_robot(tmp_path, {"actuators": [f"m{k}" for k in range(1, 7)],
                                              "reduction": N, "offset": [0, 0, 0, 0.5, 0, 0]}))
    t = robot.transmission
    assert robot.joint_names == tuple(f"m{k}" for k in range(1, 7)) and t.joints == UR5_JOINTS
    assert np.allclose(t.N, N) and t.position_side == "joint" and t.effort_side == "actuator"
    q_j = RNG.normal(size=(4, 6))
    assert np.allclose(t.to_actuator_position(q_j)[:, 5], 32 * (q_j[:, 4] + q_j[:, 5]))
    assert np.allclose(t.to_actuator_position(q_j)[:, 3], -48 * q_j[:, 3] + 0.5)


@pytest.mark.parametrize(
    "transmission, words",
    [
        ({"reduction": [[1, 0], [0, 1]]}, "must be 6 × 6"),
        ({"reduction": [[32, 32, 0, 0, 0, 0]] * 6}, "singular"),
        ({"reduction": np.eye(6).tolist(), "actuators": ["m"] * 6}, "lists a name twice"),
        ({"reduction": np.eye(6).tolist(), "gear": 3}, "unknown keys ['gear']"),
        (
            {"reduction": np.eye(6).tolist(), "position_side": "motor"},
            "position_side is joint|actuator",
        ),
        ({"reduction": [[1, "a"]]}, "every entry must be a number"),
        ({"actuators": ["m1"]}, "reduction is missing"),
    ],
)
def test_bad_yaml_transmissions_say_why_in_one_line(tmp_path, transmission, words):
    path = _yaml_robot(tmp_path, transmission)
    with pytest.raises(ConfigError) as err:
        load_robot(path)
    msg = str(err.value)
    assert words in msg and str(path) in msg and "\n" not in msg


@pytest.mark.parametrize("block, words", [
    (_elements("SimpleTransmission", [2], [1], [0]).replace("j1", "no_such_joint"),
     "names ['no_such_joint'], not actuated joints"),
    (_elements("HarmonicTransmission", [2], [1], [0]), "type 'transmission_interface/Harmonic"),
    (_elements("DifferentialTransmission", [1], [1], [0]), "needs 2 <joint> element(s)"),
    (_elements("SimpleTransmission", [0], [1], [0]).replace("j1", "elbow_joint"),
     "mechanical_reduction is zero"),
])
def test_bad_urdf_transmissions_say_why_in_one_line(tmp_path, block, words):
    with pytest.raises(ConfigError) as err:
        load_robot(_ur5_with_ros2_control(tmp_path, block))
    msg = str(err.value)
    assert words in msg and "ur5_tx.urdf" in msg and "\n" not in msg
