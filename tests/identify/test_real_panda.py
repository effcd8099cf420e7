"""A real robot's record, imported from CSV and identified, against its published model: the
Franka Emika Panda of Gaz et al. 2019 (tests/panda_gaz2019.py; the fixture's README.md).

Tolerances. The reference is itself an estimate: Gaz et al.'s feasible parameters, fitted to many
1 kHz trajectories (their own gravity coefficients differ from them by ~0.1 N·m); ours come from
14 s of one trajectory at ~100 Hz on the logging PC's uneven clock (every 10th sample of the
log), by IDIM-WLS with the default options (resolved at the record's rate, derivatives on each
sample's own stamp). Measured (README): the published model misses the held-out torques by
0.33 N·m rms (3.3 % of the torque), ours by 0.15 N·m (0.45x; at worst 0.84x, panda_joint7; with
the median step taken as the period, before issue 32, 0.52 N·m), and our gravity torques are
within 1-13 % of the published ones on the joints that carry gravity. The bounds (0.75x overall,
1.5x per joint) catch a time base gone wrong (0.52 N·m: 1.56x) and what breaks an import: a
wrong unit (x1000, x57 for degrees), a swapped or mis-signed column, a time column read in the
wrong unit (each > 100 %). Ours fits the first 14 s of the same trajectory the held-out 7 s
continue; the published model was fitted to other trajectories: the comparison favours ours.
"""
from __future__ import annotations

import numpy as np
import panda_gaz2019 as P
import pytest

from orthoglide_ident.cli import main
from orthoglide_ident.model.registry import load_robot

GRAVITY_JOINTS = slice(1, 6)  # panda_joint2..6: gravity torques of 0.8-17 N·m rms held out


@pytest.fixture(scope="module")
def identified(tmp_path_factory):
    assert (P.FIXTURE / "traj1_a.csv.gz").exists(), (
        "the Panda record is not here: python tools/panda_gaz2019_fixture.py "
        "<clone of marcocognetti/FrankaEmikaPandaDynModel>")
    doc = P.run(tmp_path_factory.mktemp("panda"), main)
    robot = load_robot(str(P.URDF))
    return robot, doc, np.array([p["value"] for p in doc["parameters"]])


def test_the_record_imports_as_a_torque_tagged_bag(identified):
    robot, doc, _ = identified
    assert doc["method"] == "wls" and doc["robot"] == "panda_gaz2019"
    assert [g["value"] for g in doc["drive_gains"]] == [1.0] * 7
    assert "(a torque, as tagged: divided by the nominal gains)" in doc["diagnostics"]["bags"][0][
        "sources"]


def test_held_out_torques_against_the_published_model(identified):
    robot, _, chi = identified
    rms = P.held_out_rms(robot, chi)
    total = {k: float(np.sqrt(np.mean(v ** 2))) for k, v in rms.items()}
    # the reference explains the record: the fixture, the URDF and the units are right
    assert total["published"] < 0.05 * total["measured"], total
    # ours, from 14 s at ~100 Hz, predicts the other 7 s at least as well as the published model
    assert total["identified"] < 0.75 * total["published"], total
    assert np.all(rms["identified"] < 1.5 * rms["published"]), rms


def test_gravity_torques_against_the_published_model(identified):
    robot, doc, chi = identified
    names = [p["name"] for p in doc["parameters"]]
    inertial = np.array([n.split("_")[0] not in ("fv", "fs", "tauoff", "ia") for n in names])
    published = robot.base_values(P.published_standard(robot))
    s = P.states(P.FIXTURE / "traj1_b.csv.gz")  # the held-out configurations
    zero = np.zeros_like(s.q)
    W = robot.regressor(s.q, zero, zero)
    g_ours = (W @ (chi * inertial)).reshape(7, -1).T
    g_pub = (W @ (published * inertial)).reshape(7, -1).T
    rms = lambda e: np.sqrt(np.mean(e ** 2, axis=0))  # noqa: E731
    rel = (rms(g_ours - g_pub) / rms(g_pub))[GRAVITY_JOINTS]
    assert np.all(rel < 0.2), rel
