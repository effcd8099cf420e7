"""excite run's plan without ROS: what it refuses before anything moves (another robot, other
joints, NaN, out of limits), the points it sends, the approach's speed, the payload tag."""
from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
from trajectories import UR5_CENTRE, small_trajectory  # noqa: E402

from orthoglide_ident.errors import ConfigError  # noqa: E402
from orthoglide_ident.excite import plan as plan  # noqa: E402
from orthoglide_ident.model.registry import load_robot  # noqa: E402


@pytest.fixture(scope="module")
def ur5():
    return load_robot("ur5")


def test_a_small_trajectory_passes(ur5):
    plan.check_run(small_trajectory(), "unloaded", ur5, "t.yaml")


def test_another_robots_trajectory_is_refused(ur5):
    five = small_trajectory("five_bar", ("joint_1", "joint_2"), (2.1, 1.04))
    with pytest.raises(
        ConfigError, match=r"t.yaml: the trajectory is for robot 'five_bar', not 'ur5'"
    ):
        plan.check_run(five, "unloaded", ur5, "t.yaml")
    renamed = replace(small_trajectory(), joints=("a", "b", "c", "d", "e", "f"))
    with pytest.raises(ConfigError, match="moves joints a, b"):
        plan.check_run(renamed, "unloaded", ur5, "t.yaml")


def test_nan_and_out_of_limit_runs_are_refused_with_the_joint_and_time(ur5):
    t = small_trajectory()
    bad = dict(t.runs)
    bad["unloaded"] = replace(
        t.runs["unloaded"], q0=np.where(np.arange(6) == 2, np.nan, UR5_CENTRE)
    )
    with pytest.raises(ConfigError, match="not finite"):
        plan.check_run(replace(t, runs=bad), "unloaded", ur5, "t.yaml")
    bad["unloaded"] = replace(t.runs["unloaded"], q0=UR5_CENTRE + np.array([0, 0, 2.0, 0, 0, 0]))
    with pytest.raises(
        ConfigError, match=r"takes elbow_joint above its upper limit at t = .* vs 3.1416 rad"
    ):
        plan.check_run(replace(t, runs=bad), "unloaded", ur5, "t.yaml")
    fast = small_trajectory(amplitude=3.0, period_s=1.0)
    with pytest.raises(ConfigError, match="faster than its velocity limit"):
        plan.check_run(fast, "unloaded", ur5, "t.yaml")


def test_points_cover_the_run_and_the_approach_is_slow(ur5):
    t = small_trajectory(periods=2)
    pts = plan.excitation_points(t, "loaded", 100.0)
    assert len(pts.times) == 401 and pts.duration == pytest.approx(4.0)
    np.testing.assert_allclose(pts.qd[[0, -1]], 0, atol=1e-9)  # at rest at both ends
    speed = plan.approach_speed(ur5)
    np.testing.assert_allclose(speed, 0.1 * np.array([3.15, 3.15, 3.15, 3.2, 3.2, 3.2]))
    ap = plan.approach_points(UR5_CENTRE + 1.0, pts.q[0], speed, pts.joint_names, 1000.0)
    assert np.all(np.abs(ap.qd).max(axis=0) <= speed * (1 + 1e-6))
    np.testing.assert_allclose(ap.q[-1], pts.q[0]) and np.testing.assert_allclose(ap.qd[[0, -1]], 0)


def test_payload_tag_from_the_file_or_the_flag():
    t = small_trajectory(mass=2.0)
    assert plan.payload_tag(t, "unloaded").mass == 0
    assert plan.payload_tag(t, "loaded") == plan.PayloadTag("loaded", 2.0, "tool0")
    assert plan.payload_tag(t, "loaded", 1.5).mass == 1.5
    no_mass = replace(t, runs={**t.runs, "loaded": replace(t.runs["loaded"], payload=None)})
    with pytest.raises(ConfigError, match="give --payload-mass"):
        plan.payload_tag(no_mass, "loaded", where="t.yaml")
    with pytest.raises(ConfigError, match="for --condition loaded"):
        plan.payload_tag(t, "unloaded", 2.0)


def test_the_command_refuses_a_nan_or_out_of_limit_file_in_one_line(tmp_path, ros_env):
    """Before anything moves (no robot needed): exit 2, one line naming the file."""
    import subprocess

    import yaml
    from trajectories import write_small

    cli = Path(sys.prefix) / "bin" / "orthoglide-ident"
    good = write_small(tmp_path / "good.yaml")
    doc = yaml.safe_load(good.read_text())
    doc["runs"]["unloaded"]["q0"][2] = float("nan")
    (tmp_path / "nan.yaml").write_text(yaml.safe_dump(doc))
    doc = yaml.safe_load(good.read_text())
    doc["runs"]["unloaded"]["q0"][2] = 3.5  # the elbow beyond its ±π
    (tmp_path / "far.yaml").write_text(yaml.safe_dump(doc))
    for name, reason in (
        ("nan.yaml", "non-finite"),
        ("far.yaml", "elbow_joint above its upper limit"),
    ):
        out = subprocess.run(
            [str(cli), "excite", "run", str(tmp_path / name), "--condition", "unloaded"],
            capture_output=True,
            text=True,
            timeout=120,
            env=ros_env,
        )
        assert out.returncode == 2 and reason in out.stderr and name in out.stderr, out.stderr
        assert len(out.stderr.strip().splitlines()) == 1
