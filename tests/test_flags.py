"""One grammar across commands (orthoglide_ident/flags.py): vector flags as X,Y,Z or 'X Y Z' in
``import`` and ``excite design`` alike, ``excite check`` on the limits its trajectory records,
output flags that create their folders or refuse before any work."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.flags import parse_vector

ARM = Path(__file__).resolve().parent / "fixtures" / "xacro_vendor" / "acme_arm_a3_by_hand.urdf"
# a URDF has no acceleration limit: given once, to the design; the check reads the trajectory's
LIMITS = "joint_limits:\n" + "".join(
    f"  {j}: {{has_acceleration_limits: true, max_acceleration: {a}}}\n"
    for j, a in (("shoulder_pan_joint", 5.0), ("shoulder_lift_joint", 5.0),
                 ("elbow_joint", 5.0), ("finger_left_joint", 0.5)))
QUICK_DESIGN = ("--collision", "skip", "--restarts", "1", "--steps", "1", "--periods", "1",
                "--harmonics", "2")


def cli(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "orthoglide_ident.cli", *args], cwd=cwd,
                          capture_output=True, text=True, timeout=300)


@pytest.mark.parametrize("text", ["0.02,0,0.05", "0.02 0 0.05", " 0.02, 0 ,0.05 ", [0.02, 0, 0.05]])
def test_a_vector_in_either_form(text):
    assert parse_vector(text, 3, "--payload-com") == (0.02, 0.0, 0.05)


@pytest.mark.parametrize("text", ["0.02,0", "a,b,c", "0,0,nan", ""])
def test_a_bad_vector_is_named(text):
    with pytest.raises(ConfigError, match=r"--payload-com: expected 3 numbers"):
        parse_vector(text, 3, "--payload-com")


def _csv(path: Path) -> Path:
    t = np.arange(0.0, 0.5, 0.001)
    rows = [f"{x:.3f},{np.sin(x):.6f},{np.cos(x):.6f},0.1,0.2" for x in t]
    path.write_text("t,j1.q,j2.q,j1.effort,j2.effort\n" + "\n".join(rows) + "\n")
    return path


@pytest.mark.parametrize("com", ["0.02,0,0.05", "0.02 0 0.05"])
def test_import_takes_the_payload_com_in_either_form(tmp_path, com):
    out = tmp_path / "new" / "folder" / "bag"
    p = cli("import", str(_csv(tmp_path / "log.csv")), "--out", str(out), "--effort-unit", "A",
            "--condition", "loaded", "--payload-mass", "1", "--payload-com", com,
            "--payload-inertia", "0.001,0,0,0.001,0,0.001")
    assert p.returncode == 0, p.stderr
    info = cli("info", str(out))
    assert "CoM 0.02 0 0.05 m" in info.stdout


def test_design_then_check_on_the_recorded_limits(tmp_path):
    (tmp_path / "lim.yaml").write_text(LIMITS)
    traj = tmp_path / "new" / "folder" / "t.yaml"  # its folders created
    d = cli("excite", "design", "--robot", str(ARM), "--joint-limits", "lim.yaml",
            "--payload-mass", "0.5", "--payload-com", "0 0 0.05", "--out", str(traj),
            *QUICK_DESIGN, cwd=tmp_path)
    assert d.returncode == 0, d.stderr
    c = cli("excite", "check", str(traj), "--robot", str(ARM), "--collision", "skip")
    assert c.returncode == 0, c.stderr
    assert f"limits: those recorded in {traj}" in c.stderr
    assert "every constraint keeps its margin" in c.stdout
    # other limits given: those are checked (a URDF alone has no acceleration limit)
    other = cli("excite", "check", str(traj), "--robot", str(ARM), "--collision", "skip",
                "--joint-limits", str(ARM.parent / "no_such_limits.yaml"))
    assert other.returncode == 2 and "no_such_limits.yaml" in other.stderr


def test_a_bad_output_path_is_refused_before_the_work(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("")
    p = cli("excite", "design", "--robot", str(ARM), "--payload-mass", "0.5",
            "--out", str(blocker / "t.yaml"), *QUICK_DESIGN)
    assert p.returncode == 2
    assert p.stderr.startswith(f"orthoglide-ident: error: --out {blocker / 't.yaml'}: cannot "
                               "create the folder")
    assert "designing" not in p.stderr  # refused before the search (and the limits)
    m = cli("model", "--robot", str(ARM), "--json", str(tmp_path / "a" / "b" / "m.json"))
    assert m.returncode == 0 and (tmp_path / "a" / "b" / "m.json").is_file()
