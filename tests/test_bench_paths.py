"""The bench scripts leave the choice of tree to PYTHONPATH (issue 44): importing bench/
busy_machine.py and what it imports puts no checkout ahead of PYTHONPATH on sys.path, so that
``PYTHONPATH=OTHER_TREE python bench/busy_machine.py`` measures OTHER_TREE's package."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PROBE = """
import json, sys
sys.path.insert(0, sys.argv[1])  # what running bench/NAME.py does: its folder first
import busy_machine, identify_speed  # noqa: F401  (identify_speed: busy_machine's helper)
print(json.dumps(sys.path))
"""


def test_busy_machine_puts_no_tree_ahead_of_pythonpath(tmp_path):
    other = tmp_path / "other_tree"
    other.mkdir()
    env = {**os.environ, "PYTHONPATH": str(other), "OPENBLAS_NUM_THREADS": "1"}
    done = subprocess.run([sys.executable, "-P", "-c", PROBE, str(ROOT / "bench")], env=env,
                          cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]
    path = json.loads(done.stdout.strip().splitlines()[-1])
    ahead = path[:path.index(str(other))]
    assert str(ROOT) not in ahead, f"{ROOT} put ahead of PYTHONPATH: {ahead}"
