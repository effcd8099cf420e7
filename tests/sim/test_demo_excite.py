"""The whole workflow through the action on the simulated UR5 (make demo-excite, 2 periods of
5 s per run): trajectory file -> excite run unloaded -> mount -> excite run loaded -> identify ->
feed-forward. Every gain within 0.5 % of the plant's (the issue's bar), no fault, no current
limit hit, and the identified model's feed-forward lowers the tracking error.

σ: every gain within 3 σ but shoulder_pan_joint's, which carries a bias of 0.1-0.3 % (1.1-3.7 σ
measured: README "Running an exciting trajectory"): the samples at rest the recording holds before
and after the goal (~0.3 s; 0.5 s adds 0.08 % without ROS) and the weaker excitation of that joint
in these rest-to-rest runs; bounded at 5 σ here."""
from __future__ import annotations

import re

import pytest

pytest.importorskip("control_msgs.action")

ROW = re.compile(r"^\s+(\w+_joint)\s+([\d.]+)\s+([\d.]+)\s+([\d.]+)%\s+([+-][\d.]+)%$", re.M)


@pytest.mark.slow
def test_excite_run_identify_and_feed_forward_on_the_simulated_ur5(tmp_path, capsys):
    from orthoglide_sim.demo_excite import run

    assert run(tmp_path / "excite", periods=2) == 0
    out = capsys.readouterr().out
    assert "unloaded run complete" in out and "loaded run complete" in out
    assert "stand-in fault: none, 0 current-limited" in out, out[-2000:]
    rows = ROW.findall(out)
    assert len(rows) == 6, out[-2000:]
    for joint, _, _, sigma, error in rows:
        assert abs(float(error)) < 0.5, (joint, error)
        bound = 5.0 if joint == "shoulder_pan_joint" else 3.0
        assert abs(float(error)) < bound * float(sigma), (joint, error, sigma)
    pid, ff = map(float, re.search(r"PID alone ([\d.]+) mrad, with the feed-forward ([\d.]+) mrad", out).groups())
    assert ff < 0.7 * pid
