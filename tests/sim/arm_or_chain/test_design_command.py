"""The exciting-trajectory design command, serial arm or closed chain by name: it writes the
two designed series as JSON the simulator reads back; an unknown robot is a one-line error."""
from __future__ import annotations

import json

from orthoglide_sim.arm_or_chain import excitation as design
from orthoglide_sim.arms.description import load_arm
from orthoglide_sim.arms.excitation import designed_trajectory


def test_redesign_command_writes_the_json(tmp_path, capsys):
    assert design.main(["--robot", "ur5", "--restarts", "1", "--steps", "2", "--harmonics", "2",
                    "--out-dir", str(tmp_path)]) == 0
    for k in (1, 2):
        doc = json.loads((tmp_path / f"ur5_exciting{k}.json").read_text())
        assert doc["robot"] == "ur5" and len(doc["joint_names"]) == 6 and doc["criterion"] == "cond"
        traj = designed_trajectory(load_arm("ur5"), str(tmp_path / f"ur5_exciting{k}.json"))
        assert traj.a.shape == (6, 2)
    assert design.main(["--robot", "nope"]) == 2
    assert capsys.readouterr().err.strip().startswith("error: robot 'nope'")
