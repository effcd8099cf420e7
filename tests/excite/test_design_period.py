"""``excite design`` with a period too short for the acceleration limits says so (issue 43:
``--period 0.01`` was told to "loosen the margins … or a lighter payload").

The reference is the closed form of the first harmonic: a joint whose acceleration limit is
q̈_max moves at most q̈_max/ω₁ at ω₁ = 2π/T, so below T = 2π q̇_max/q̈_max its velocity limit
is out of reach; the UR5's shoulder (3.15 rad/s, 8 rad/s²): T = 2.47 s."""
from __future__ import annotations

import math

from orthoglide_ident.cli import main


def test_a_period_of_10_ms_is_named_as_the_cause(tmp_path, capsys):
    code = main(["excite", "design", "--robot", "ur5", "--payload-mass", "2", "--period", "0.01",
                 "--out", str(tmp_path / "t.yaml"), "--restarts", "2", "--steps", "0"])
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert code == 2 and not (tmp_path / "t.yaml").exists()
    assert "the period 0.01 s is too short" in err and "lighter payload" not in err
    assert f"--period {2 * math.pi * 3.15 / 8.0:.2g} s or longer" in err
    assert f"±{15.0 / (2 * math.pi / 0.01) ** 2:.2g}" in err  # the wrists' 15 rad/s² at 100 Hz
