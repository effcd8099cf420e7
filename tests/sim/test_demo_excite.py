"""The whole workflow through the action on the simulated UR5 (make demo-excite, 2 periods of
5 s per run): trajectory file -> excite run unloaded -> mount -> excite run loaded -> identify ->
feed-forward. Gains within 0.5 % and 3 σ of the plant's, no fault, no current limit hit, and the
identified model's feed-forward lowers the tracking error."""
from __future__ import annotations

import re

import pytest

pytest.importorskip("control_msgs.action")


@pytest.mark.slow
def test_excite_run_identify_and_feed_forward_on_the_simulated_ur5(tmp_path, capsys):
    from orthoglide_sim.demo_excite import run

    assert run(tmp_path / "excite", periods=2) == 0
    out = capsys.readouterr().out
    m = re.search(r"gains within ([\d.]+) % and ([\d.]+) σ of the plant's; stand-in fault: none, 0 current-limited", out)
    assert m, out[-2000:]
    assert float(m.group(1)) < 0.5 and float(m.group(2)) < 3.0
    pid, ff = map(float, re.search(r"PID alone ([\d.]+) mrad, with the feed-forward ([\d.]+) mrad", out).groups())
    assert ff < 0.7 * pid
    assert "unloaded run complete" in out and "loaded run complete" in out
