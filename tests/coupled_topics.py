"""The coupled-wrist arm's topics as a ros2_control hardware with its transmission publishes them
(issue 33), for tests/nodes/test_identification_transmission.py and bench/live_vs_offline_hog.py.

The independent plant (orthoglide_sim/coupled: MuJoCo, motor tendons, the last motor turning with
q5 + q6) runs unloaded on exciting1 and with the payload on exciting2; /joint_states carries the
joint-side positions under the joints' names, /dynamic_joint_states each motor's position and
current under the motors' names (the robot YAML's ``actuators``), CDR-encoded.

    robot_yaml, truth, runs = coupled_topics(out_dir, seconds=15.0)
    runs["loaded"].payload_mass, runs["loaded"].stamps_ns, runs["loaded"].joint_states, ...
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml

from orthoglide_ident.bags.encoding import encode_dynamic_joint_states, encode_joint_states

MOTORS = [f"m{k + 1}" for k in range(6)]
START_NS = 1_796_000_000 * 10**9  # the first run's first stamp; the second 100 s later


@dataclass
class CoupledRun:
    """One run's messages, one of each topic per tick."""

    condition: str
    payload_mass: float
    stamps_ns: np.ndarray
    joint_states: list[bytes]
    dynamic_joint_states: list[bytes]


def coupled_topics(out: Path, seconds: float, payload: str = "2.0"):
    """The robot YAML (motors m1 .. m6, positions joint-side) written into ``out``, the plant's
    truth and the two runs (``unloaded``, ``loaded``) of ``seconds`` each."""
    from orthoglide_sim.coupled.record import simulate_coupled, write_robot_files
    from orthoglide_sim.coupled.truth import default_coupled_truth

    truth = default_coupled_truth()
    joint_yaml, _ = write_robot_files(out, truth)
    robot = yaml.safe_load(joint_yaml.read_text())
    robot["transmission"]["actuators"] = MOTORS
    path = out / "ur5_coupled_m.yaml"
    path.write_text(yaml.safe_dump(robot, sort_keys=False))
    runs = {}
    for i, (name, load, trajectory) in enumerate((("unloaded", None, "exciting1"),
                                                  ("loaded", payload, "exciting2"))):
        rec = simulate_coupled(seconds, payload=load, trajectory=trajectory, seed=i, truth=truth)
        stamps = rec.stamps_ns + START_NS + i * 100 * 10**9
        js = encode_joint_states(truth.arm.joint_names, stamps, rec.q_joint)
        djs = encode_dynamic_joint_states(MOTORS, [["position", "current"]] * 6, stamps,
                                          {"position": rec.q_motor, "current": rec.v_tau})
        runs[name] = CoupledRun(name, rec.payload_mass, stamps, [a.tobytes() for a in js],
                                [b.tobytes() for b in djs])
    return path, truth, runs
