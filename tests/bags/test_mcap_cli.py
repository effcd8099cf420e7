"""Our files through the official MCAP CLI (Rust): ``mcap doctor --strict-message-order`` and
``mcap recover`` of a file cut short (schemas and channels in the chunks: the recovered file keeps
its real start time). Skipped where the CLI is not installed (it is not on PyPI)."""

from __future__ import annotations

import os
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest

from orthoglide_ident import bags
from orthoglide_ident.model.registry import load_robot
from orthoglide_ident.ros import processes as children  # children end with this process

ORTHOGLIDE = load_robot("orthoglide")  # the robot these records are of

T0 = 1_700_000_000_000_000_000


def _mcap_cli() -> str:
    for cand in (shutil.which("mcap"), os.path.join(sys.prefix, "bin", "mcap")):
        if cand and os.access(cand, os.X_OK):
            out = children.run([cand, "--version"], capture_output=True, text=True)
            if out.returncode == 0 and "mcap" in out.stdout:
                return cand
    pytest.skip("the mcap CLI is not installed")


@pytest.fixture(scope="module")
def bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    n = 2000
    stamps = T0 + np.arange(n, dtype=np.int64) * 1_000_000
    rng = np.random.default_rng(5)
    return bags.write_bag(
        tmp_path_factory.mktemp("cli") / "b",
        stamps,
        rng.normal(size=(n, 3)),
        rng.normal(size=(n, 3)),
        "unloaded",
        0.0,
        joint_names=ORTHOGLIDE.joint_names,
    )


def test_doctor_strict_message_order(bag: Path) -> None:
    mcap = _mcap_cli()
    (f,) = bag.glob("*.mcap")
    done = children.run([mcap, "doctor", "--strict-message-order", str(f)],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr


def test_recover_keeps_the_start_time(bag: Path, tmp_path: Path) -> None:
    mcap = _mcap_cli()
    (f,) = bag.glob("*.mcap")
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(f.read_bytes()[: f.stat().st_size * 2 // 3])
    out = tmp_path / "recovered.mcap"
    children.run([mcap, "recover", str(cut), "-o", str(out)], capture_output=True, timeout=60)
    info = children.run([mcap, "info", str(out)], capture_output=True, text=True, timeout=60)
    fields = {ln.split(":")[0]: ln.split(":", 1)[1].strip() for ln in info.stdout.splitlines()
              if ":" in ln and not ln.startswith("\t")}
    assert fields["start"].split("(")[-1].rstrip(")") == f"{T0 // 10**9}.000000000"
    kept = bags.read_bag(cut)  # our reader and mcap recover keep the same complete chunks
    assert int(fields["messages"]) == 2 * len(kept.joint_states.stamps_ns) > 0


def test_doctor_ros2_control_bag(tmp_path: Path) -> None:
    """/joint_states + /dynamic_joint_states, shuffled joints and an extra one, pass the doctor."""
    mcap = _mcap_cli()
    n = 2000
    stamps = T0 + np.arange(n, dtype=np.int64) * 1_000_000
    rng = np.random.default_rng(6)
    names = ("a", "b", "c")
    bag = bags.write_bag(tmp_path / "rc", stamps, rng.normal(size=(n, 3)), rng.normal(size=(n, 3)),
                         "unloaded", 0.0, names, layout="dynamic_joint_states",
                         joint_order=("c", "x", "a", "b"), extra_joints={"x": 0.0})
    (f,) = bag.glob("*.mcap")
    done = children.run([mcap, "doctor", "--strict-message-order", str(f)],
                        capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
