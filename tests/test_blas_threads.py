"""One BLAS thread in every entry point users run (issue 35), a user's own setting kept.

Each entry point is imported in a fresh interpreter whose environment has no BLAS thread
variable; the OpenBLAS that numpy loaded is then asked how many threads it runs (its own
``*_get_num_threads``, found in the process's memory map), so the test fails if numpy loads
before the package sets the variable, whatever the machine's core count."""
from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from orthoglide_ident import BLAS_THREAD_VARIABLES

ROOT = Path(__file__).resolve().parents[1]
LAUNCHERS = ROOT / "resource" / "launchers"

PROBE = """
import ctypes, re, sys
__import__(sys.argv[1])
import numpy
libs = set(re.findall(r"(/\\S*openblas\\S*\\.so\\S*)", open("/proc/self/maps").read()))
counts = []
for path in libs:
    lib = ctypes.CDLL(path)
    for name in ("scipy_openblas_get_num_threads64_", "openblas_get_num_threads64_",
                 "openblas_get_num_threads"):
        if hasattr(lib, name):
            counts.append(getattr(lib, name)())
            break
print(max(counts) if counts else "none")
"""


def _modules() -> list[str]:
    """The console script's module and every `ros2 run` launcher's."""
    mods = ["orthoglide_ident.cli"]
    for launcher in sorted(LAUNCHERS.iterdir()):
        m = re.search(r"from ([\w.]+) import main", launcher.read_text())
        assert m, f"{launcher} does not say which module it runs"
        mods.append(m.group(1))
    return mods


def _threads(module: str, **env: str) -> str:
    clean = {k: v for k, v in os.environ.items() if k not in BLAS_THREAD_VARIABLES}
    out = subprocess.run([sys.executable, "-c", PROBE, module], env={**clean, **env},
                         capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert out.returncode == 0, out.stderr[-2000:]
    return out.stdout.strip().splitlines()[-1]


def test_every_entry_point_is_covered():
    assert {"orthoglide_ident.nodes.ctc", "orthoglide_sim.nodes.driver"} <= set(_modules())


@pytest.mark.parametrize("module", _modules())
def test_one_blas_thread_unless_the_user_says(module):
    threads = _threads(module)
    if threads == "none":
        pytest.skip("numpy is not linked to OpenBLAS here")
    assert threads == "1"


def test_a_users_setting_is_the_override():
    if os.cpu_count() < 2:
        pytest.skip("one core: OpenBLAS runs one thread whatever is asked")
    assert _threads("orthoglide_ident.cli", OMP_NUM_THREADS="2") == "2"
