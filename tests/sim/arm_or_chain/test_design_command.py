"""The exciting-trajectory design command, serial arm or closed chain by name: the product's
designer inside the arm's box; it writes the two designed runs as JSON series the simulator reads
back; an unknown robot is a one-line error."""
from __future__ import annotations

import json

import numpy as np

from orthoglide_sim.arm_or_chain import excitation as design
from orthoglide_sim.arms.description import load_arm
from orthoglide_sim.arms.excitation import designed_trajectory
from orthoglide_sim.arms.limits import motion_limits


def test_redesign_command_writes_the_json(tmp_path, capsys):
    assert design.main(["--robot", "ur5", "--restarts", "1", "--steps", "2", "--harmonics", "2",
                        "--search", "walk", "--out-dir", str(tmp_path)]) == 0
    arm = load_arm("ur5")
    box = motion_limits(arm)
    for k in (1, 2):
        doc = json.loads((tmp_path / f"ur5_exciting{k}.json").read_text())
        assert doc["robot"] == "ur5" and len(doc["joint_names"]) == 6
        assert doc["criterion"] == "orthoglide_ident.excite.design"
        traj = designed_trajectory(arm, str(tmp_path / f"ur5_exciting{k}.json"))
        assert traj.a.shape == (6, 2)
        q, qd, qdd = traj.evaluate(np.linspace(0.0, traj.period, 2001))
        assert np.all(np.abs(q - box.centre) <= box.half)  # inside the simulator's box
        assert np.all(np.abs(qd) <= box.velocity) and np.all(np.abs(qdd) <= box.acceleration)
    assert design.main(["--robot", "nope"]) == 2
    assert capsys.readouterr().err.strip().startswith("error: robot 'nope'")
    missing = tmp_path / "no" / "such"
    assert design.main(["--robot", "ur5", "--restarts", "1", "--steps", "0", "--harmonics", "2",
                        "--search", "walk", "--out-dir", str(missing)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"error: cannot write {missing}")
