"""The exciting-trajectory file: rest at both ends, round trip, one-line reasons."""
from __future__ import annotations

import numpy as np
import pytest

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.excite.trajectory import (
    ExcitationRun,
    ExcitationTrajectory,
    load_trajectory,
    rest_projection,
    save_trajectory,
)


def _trajectory(seed: int = 0) -> ExcitationTrajectory:
    rng = np.random.default_rng(seed)
    runs = {}
    for name in ("unloaded", "loaded"):
        a, b = rest_projection(rng.normal(size=(2, 4)), rng.normal(size=(2, 4)))
        payload = {"mass": 1.5, "frame": "tool0"} if name == "loaded" else None
        runs[name] = ExcitationRun(name, rng.normal(size=2), 0.1 * a, 0.1 * b, payload)
    return ExcitationTrajectory("two_link", ("j1", "j2"), 4.0, 3, runs, {"design": {"seed": seed}})


def test_runs_start_and_end_at_rest_and_repeat():
    traj = _trajectory()
    for name in ("unloaded", "loaded"):
        assert traj.rest_error(name) < 1e-12
        q, qd, qdd = traj.evaluate(name, np.array([0.0, traj.period_s, traj.duration]))
        assert np.allclose(q, traj.start_pose(name)) and np.abs(qd).max() < 1e-12
        assert np.abs(qdd).max() < 1e-12


def test_derivatives_match_finite_differences():
    traj = _trajectory(1)
    t = np.linspace(0.3, 3.7, 50)
    h = 1e-6
    q_p, qd_p, _ = traj.evaluate("unloaded", t + h)
    q_m, qd_m, _ = traj.evaluate("unloaded", t - h)
    _, qd, qdd = traj.evaluate("unloaded", t)
    assert np.allclose((q_p - q_m) / (2 * h), qd, atol=1e-7)
    assert np.allclose((qd_p - qd_m) / (2 * h), qdd, atol=1e-6)


def test_holds_the_start_pose_outside_the_run():
    traj = _trajectory(2)
    q, qd, qdd = traj.evaluate("loaded", np.array([-1.0, traj.duration + 1.0]))
    assert np.allclose(q, traj.start_pose("loaded")) and not qd.any() and not qdd.any()


def test_a_run_as_its_periodic_series():
    """``series(run)``: the run inside [0, duration], periodic beyond it (what a plant tracks),
    its derivatives those of its positions (finite differences); JSON round trip."""
    from orthoglide_ident.excite import FourierSeries

    traj = _trajectory(4)
    s = traj.series("loaded")
    assert isinstance(s, FourierSeries) and s.period == pytest.approx(traj.period_s)
    t = np.linspace(0.0, traj.duration, 97)
    for x, y in zip(s.evaluate(t), traj.evaluate("loaded", t)):
        assert np.array_equal(x, y)
    later = s.evaluate(t + 7 * traj.period_s)
    assert all(np.allclose(x, y, atol=1e-12) for x, y in zip(later, s.evaluate(t)))
    h = 1e-6
    (q_p, qd_p, _), (q_m, qd_m, _) = s.evaluate(t + h), s.evaluate(t - h)
    _, qd, qdd = s.evaluate(t)
    assert np.allclose((q_p - q_m) / (2 * h), qd, atol=1e-7)
    assert np.allclose((qd_p - qd_m) / (2 * h), qdd, atol=1e-6)
    back = FourierSeries.from_dict(s.to_dict())
    assert all(np.array_equal(x, y) for x, y in zip(back.evaluate(t), s.evaluate(t)))


def test_round_trip(tmp_path):
    traj = _trajectory(3)
    path = tmp_path / "traj.yaml"
    save_trajectory(traj, path)
    back = load_trajectory(path)
    t = np.linspace(0, traj.duration, 101)
    for name in ("unloaded", "loaded"):
        assert np.array_equal(back.evaluate(name, t)[0], traj.evaluate(name, t)[0])
    assert back.run("loaded").payload == {"mass": 1.5, "frame": "tool0"}
    assert back.extra == {"design": {"seed": 3}} and back.joints == ("j1", "j2")


@pytest.mark.parametrize("edit, reason", [
    (lambda d: d.pop("format"), "not an exciting-trajectory file"),
    (lambda d: d["runs"]["unloaded"].pop("a"), "lacks 'a'"),
    (lambda d: d["runs"]["unloaded"].update(q0=[0.0]), "q0 needs 2 values"),
    (lambda d: d["runs"].update(other=d["runs"]["loaded"]), "unknown runs ['other']"),
    (lambda d: d.update(period_s=0), "period_s must be > 0"),
])
def test_bad_files_get_one_line_reasons(tmp_path, edit, reason):
    import yaml

    doc = _trajectory().to_dict()
    edit(doc)
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(doc))
    with pytest.raises(ConfigError, match=".*") as exc:
        load_trajectory(path)
    assert reason in str(exc.value) and str(path) in str(exc.value) and "\n" not in str(exc.value)
