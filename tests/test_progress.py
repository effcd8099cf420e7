"""Progress on long work (orthoglide_ident/progress.py): a line with the time left on a terminal,
nothing when piped or quiet; ``excite design`` says its expected duration before searching."""
from __future__ import annotations

import io
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from orthoglide_ident import progress
from orthoglide_ident.bags.csv_import import ColumnMap, read_csv
from orthoglide_ident.progress import ProgressLine, duration_text

ARM = Path(__file__).resolve().parent / "fixtures" / "xacro_vendor" / "acme_arm_a3_by_hand.urdf"


class Tty(io.StringIO):
    def isatty(self) -> bool:
        return True


class Clock:
    def __init__(self) -> None:
        self.t = 100.0

    def __call__(self) -> float:
        return self.t


@pytest.fixture(autouse=True)
def _not_quiet():
    progress.set_quiet(False)
    yield
    progress.set_quiet(False)


def test_the_line_says_how_far_and_the_time_left():
    out, clock = Tty(), Clock()
    line = ProgressLine("designing", 10, "evaluations", stream=out, clock=clock)
    clock.t += 4.0  # 4 s for 2 of 10: 16 s left
    line.update(2)
    assert out.getvalue() == "\rdesigning: 20 % (2/10 evaluations), 16 s left"
    clock.t += 0.05  # redrawn at most every REDRAW_S
    line.update(3)
    assert out.getvalue().count("\r") == 1
    clock.t += 1.0  # the total revised as the work learns it: 5.05 s for 3 of 30
    line.update(3, 30)
    assert out.getvalue().endswith("\rdesigning: 10 % (3/30 evaluations), 45 s left")
    line.close()
    assert out.getvalue().endswith("\r" + " " * 45 + "\r")


@pytest.mark.parametrize("quiet, stream", [(False, io.StringIO()), (True, Tty())])
def test_nothing_when_piped_or_quiet(quiet, stream):
    progress.set_quiet(quiet)
    with ProgressLine("x", 10, stream=stream, clock=Clock()) as line:
        line.update(5)
    assert stream.getvalue() == ""


def test_duration_text():
    assert [duration_text(s) for s in (4.4, 200, 7300)] == ["4 s", "3 min 20 s", "2 h 01 min"]


def test_import_reading_shows_its_progress_on_a_terminal(tmp_path, monkeypatch):
    t = np.arange(0.0, 10.0, 0.001)
    csv = tmp_path / "log.csv"
    csv.write_text("t,j1.q,j1.effort\n" + "\n".join(f"{x:.3f},{np.sin(x):.6f},0.1" for x in t))
    tty = Tty()
    monkeypatch.setattr(sys, "stderr", tty)
    rec = read_csv(csv, ColumnMap(effort_unit="A"))
    assert len(rec.stamps_ns) == len(t)
    assert re.match(r"\rreading log\.csv: \d+ % \([\d.]+/0\.\d+ MB\), \d+ s left",
                    tty.getvalue())
    assert tty.getvalue().endswith("\r")  # erased when done


def test_design_says_its_expected_duration_first(tmp_path):
    (tmp_path / "lim.yaml").write_text("joint_limits:\n" + "".join(
        f"  {j}: {{has_acceleration_limits: true, max_acceleration: 5.0}}\n"
        for j in ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint",
                  "finger_left_joint")))
    p = subprocess.run([sys.executable, "-m", "orthoglide_ident.cli", "excite", "design",
                        "--robot", str(ARM), "--joint-limits", "lim.yaml", "--payload-mass",
                        "0.5", "--out", "t.yaml", "--collision", "skip", "--restarts", "2",
                        "--steps", "8", "--periods", "1", "--harmonics", "2"],
                       cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    lines = p.stderr.splitlines()
    assert lines[1].startswith("orthoglide-ident: expected duration ~")
    assert "(2 random shapes, 8 steps" in lines[1]
    assert "\r" not in p.stderr and "step 8/8" not in p.stderr  # piped: no progress, no steps
