"""``orthoglide-ident --robot``: the CLI for a robot other than the Orthoglide, as a user runs
it."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from orthoglide_sim.arm_or_chain.bags import write_record
from orthoglide_sim.arms.description import load_arm
from orthoglide_sim.arms.record import simulate_arm
from orthoglide_sim.arms.truth import OFFSET_COM, OFFSET_PAYLOAD, load_truth, with_offset_payload


def cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "orthoglide_ident.cli", *args],
                          capture_output=True, text=True, timeout=600)


@pytest.fixture(scope="module")
def ur5_bags(tmp_path_factory):
    d = tmp_path_factory.mktemp("ur5")
    runs = (("unloaded", None, "exciting1", 0), ("loaded_2kg", "2.0", "exciting2", 1))
    out, truth = [], None
    for name, payload, traj, seed in runs:
        rec = simulate_arm(20.0, "ur5", payload=payload, trajectory=traj, seed=seed)
        out.append(str(write_record(d / name, rec)))
        truth = rec.truth
    return out, truth


def test_identify_a_ur5_from_its_ros2_control_bags(ur5_bags, tmp_path):
    bags, truth = ur5_bags
    js = tmp_path / "r.json"
    p = cli("identify", "--robot", "ur5", *bags, "--json", str(js), "-q")
    assert p.returncode == 0, p.stderr
    assert "drive gains (N·m/A)" in p.stdout and "g_tau shoulder_pan_joint" in p.stdout
    assert "current from /joint_states effort (JointState)" in p.stdout
    doc = json.loads(js.read_text())
    assert doc["robot"] == "ur5" and doc["units"]["drive_gains"] == "N·m/A"
    g = np.array([x["value"] for x in doc["drive_gains"]])
    g_true = np.array([truth.drives[x["joint"]].g_tau for x in doc["drive_gains"]])
    assert np.abs(g / g_true - 1).max() < 0.005
    ratio = [x["ratio_to_nominal"] for x in doc["drive_gains"]]
    assert np.allclose(ratio, g / np.array([13.0, 13.0, 13.0, 9.3, 9.3, 9.3]))


def test_a_payload_tagged_with_its_mass_only(tmp_path):
    """Sect. 4.3 at the CLI: the bag says only the mass; the CoM is identified and reported
    (text and JSON 'payload'); --payload-known point takes it for a point mass at the flange,
    which cannot scale wrist_3's gain (a partial answer: not determined)."""
    truth = with_offset_payload(load_truth(load_arm("ur5")))
    bags = [str(write_record(tmp_path / name, simulate_arm(
        20.0, payload=payload, trajectory=traj, seed=seed, truth=truth), mass_only=True))
        for name, payload, traj, seed in (("unloaded", None, "exciting1", 0),
                                          ("loaded", OFFSET_PAYLOAD, "exciting2", 1))]
    info = cli("info", bags[1])
    assert "loaded, payload 2 kg (mass known, CoM and inertia not)" in info.stdout
    js = tmp_path / "r.json"
    p = cli("identify", "--robot", "ur5", *bags, "--json", str(js), "-q")
    assert p.returncode == 0, p.stderr
    assert "payload at tool0 (its mass known, CoM and inertia identified, Sect. 4.3)" in p.stdout
    doc = json.loads(js.read_text())
    assert np.abs(np.array(doc["payload"]["com"]) - OFFSET_COM).max() < 2e-3
    assert all(s > 0 for s in doc["payload"]["com_std"])
    g = np.array([x["value"] for x in doc["drive_gains"]])
    assert np.abs(g / truth.drive_array("g_tau") - 1).max() < 0.005
    point = cli("identify", "--robot", "ur5", *bags, "--payload-known", "point", "-q")
    assert point.returncode == 0, point.stderr  # a partial answer: no torque on the wrist_3 axis
    assert "g_tau wrist_3_joint       not determined: the payload adds almost no torque" \
        in point.stdout, point.stdout
    urdf = tmp_path / "identified.urdf"  # a partial answer has no consistent set: said, no file
    out = cli("identify", "--robot", "ur5", *bags, "--payload-known", "point", "--urdf-out",
              str(urdf), "-q")
    assert out.returncode == 2 and "Traceback" not in out.stderr, out.stderr
    assert "--urdf-out not written: a partial answer" in out.stderr and not urdf.exists()
    bad = cli("identify", "--robot", "ur5", *bags, "--payload-known", "com", "-q")
    assert bad.returncode == 2 and "payload_known com needs the payload's centre of mass" \
        in bad.stderr


def test_model_base_parameters_of_a_robot_file():
    p = cli("model", "--robot", "ur5", "--base-parameters")
    assert p.returncode == 0, p.stderr
    assert p.stdout.startswith("58 base parameters of robot ur5")
    p = cli("model", "--robot", "five_bar", "--base-parameters")
    assert p.returncode == 0 and "base parameters of robot five_bar" in p.stdout


def test_the_orthoglide_bags_are_not_a_ur5(tmp_path):
    p = cli("identify", "--robot", "ur5", "bags/unloaded", "bags/loaded", "-q")
    assert p.returncode == 2 and "Traceback" not in p.stderr
    assert p.stderr.count("\n") == 1 and "joint 'shoulder_pan_joint' is not in" in p.stderr


@pytest.mark.parametrize("text, reason", [
    ("<robot name='x'><link name='a'/>", "robot file"),
    ("name: x\nmodel: pinocchio\ndescription: nowhere.urdf\n", "nowhere.urdf"),
])
def test_bad_robot_files_are_one_line_reasons(tmp_path, text, reason):
    f = tmp_path / ("bad.urdf" if text.startswith("<") else "bad.yaml")
    f.write_text(text)
    p = cli("model", "--robot", str(f))
    assert p.returncode == 2 and "Traceback" not in p.stderr
    assert p.stderr.count("\n") == 1, p.stderr
