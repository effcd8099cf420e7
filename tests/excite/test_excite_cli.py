"""``orthoglide-ident excite design|check`` end to end (short designs: 2 shapes, a few steps)."""
from __future__ import annotations

import numpy as np
import pytest
from excite_robots import two_link_urdf

from orthoglide_ident.cli import main
from orthoglide_ident.excite.trajectory import load_trajectory

QUICK = ["--restarts", "2", "--steps", "4", "--periods", "4"]


@pytest.fixture(scope="module")
def designed(tmp_path_factory):
    d = tmp_path_factory.mktemp("excite")
    out, csv = d / "traj.yaml", d / "runs.csv"
    code = main(["excite", "design", "--robot", "ur5", "--payload-mass", "2", "--out", str(out),
                 "--samples", str(csv), "--seed", "3", "--current-noise", "0.01"] + QUICK)
    assert code == 0
    return out, csv


def test_design_writes_the_file_its_limits_margins_and_prediction(designed, capsys):
    out, csv = designed
    traj = load_trajectory(out)
    assert traj.robot == "ur5" and traj.duration == pytest.approx(20.0)
    assert set(traj.extra) == {"design", "limits", "margins", "prediction"}
    pred = traj.extra["prediction"]
    assert pred["current_noise_a"]["elbow_joint"] == 0.01
    # a bare mass at the flange does not load wrist_3 (test_excite_payload_share.py)
    assert pred["for_target"].endswith("gives every determined gain ≤ 0.2 %")
    assert traj.extra["limits"]["joints"]["wrist_1_joint"]["effort"] == 28.0
    assert traj.extra["margins"]["required"]["effort"] == 0.2
    assert all(v["ok"] for v in traj.extra["margins"]["worst"].values())


def test_samples_csv_has_the_documented_header_and_1khz_rows(designed):
    out, csv = designed
    traj = load_trajectory(out)
    with open(csv) as fh:
        header = fh.readline().strip().split(",")
        first = fh.readline().strip().split(",")
    assert header[:5] == ["run", "t", "shoulder_pan_joint.q", "shoulder_pan_joint.qd",
                          "shoulder_pan_joint.qdd"] and len(header) == 2 + 3 * 6
    assert first[0] == "unloaded" and float(first[1]) == 0.0
    assert float(first[2]) == pytest.approx(traj.start_pose("unloaded")[0])
    rows = sum(1 for _ in open(csv)) - 1
    assert rows == 2 * (20_000 + 1)


def test_check_passes_and_a_tighter_joint_limits_file_fails_it(designed, tmp_path, capsys):
    out, _ = designed
    assert main(["excite", "check", str(out), "--robot", "ur5"]) == 0
    assert "every constraint keeps its margin" in capsys.readouterr().out
    lim = tmp_path / "limits.yaml"
    lim.write_text(
        "joint_limits:\n  wrist_2_joint: {has_velocity_limits: true, max_velocity: 0.2}\n"
    )
    assert main(["excite", "check", str(out), "--robot", "ur5", "--joint-limits", str(lim)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "breaks its limits: velocity" in err


def test_the_same_seed_designs_the_same_trajectory(designed, tmp_path):
    out, _ = designed
    again = tmp_path / "again.yaml"
    assert main(["excite", "design", "--robot", "ur5", "--payload-mass", "2", "--out", str(again),
                 "--seed", "3", "--current-noise", "0.01"] + QUICK) == 0
    a, b = load_trajectory(out), load_trajectory(again)
    for run in ("unloaded", "loaded"):
        np.testing.assert_array_equal(a.run(run).a, b.run(run).a)
        np.testing.assert_array_equal(a.run(run).b, b.run(run).b)


def one_line_error(capsys, argv) -> str:
    assert main(argv) == 2
    lines = capsys.readouterr().err.strip().splitlines()  # progress lines, then the reason
    errors = [x for x in lines if x.startswith("orthoglide-ident: error: ")]
    assert len(errors) == 1 and lines[-1] == errors[0] and "Traceback" not in "".join(lines)
    return errors[0]


def test_bad_inputs_get_one_line_reasons(designed, tmp_path, capsys):
    out, _ = designed
    err = one_line_error(capsys, ["excite", "check", str(out), "--robot", "five_bar"])
    assert "is a trajectory for robot ur5" in err
    err = one_line_error(capsys, ["excite", "design", "--robot", "ur5", "--payload-mass", "40",
                                  "--out", str(tmp_path / "x.yaml")] + QUICK)
    assert "40 kg payload needs" in err and "lighter payload" in err
    urdf = two_link_urdf(tmp_path, limits=False)
    err = one_line_error(capsys, ["excite", "design", "--robot", str(urdf), "--payload-mass", "1",
                                  "--out", str(tmp_path / "x.yaml")])
    assert "joint j1 has no position limit" in err
    meshy = tmp_path / "m"
    meshy.mkdir()
    urdf = two_link_urdf(meshy, mesh="package://arm_description/meshes/cube.stl")
    lim = tmp_path / "acc.yaml"
    lim.write_text("joint_limits:\n  j1: {has_acceleration_limits: true, max_acceleration: 5}\n"
                   "  j2: {has_acceleration_limits: true, max_acceleration: 5}\n")
    err = one_line_error(capsys, ["excite", "design", "--robot", str(urdf), "--payload-mass", "1",
                                  "--joint-limits", str(lim), "--out", str(tmp_path / "x.yaml")])
    assert "cannot be found" in err and "--collision" in err
    err = one_line_error(capsys, ["excite", "check", str(tmp_path / "nope.yaml"), "--robot", "ur5"])
    assert "nope.yaml" in err


def test_a_plain_urdf_designs_with_derived_accelerations_and_a_time_limit(tmp_path, capsys):
    """No acceleration limit anywhere: derived (said in one line); the expected duration is
    said first; --time-limit stops a search far too long for it with the best so far; no step
    progress off a terminal."""
    urdf = two_link_urdf(tmp_path)
    out = tmp_path / "t.yaml"
    args = ["excite", "design", "--robot", str(urdf), "--payload-mass", "0.5", "--out", str(out),
            "--periods", "2", "--restarts", "3", "--steps", "10000000", "--time-limit", "1",
            "--collision", "skip"]
    assert main(args) == 0
    err = capsys.readouterr().err
    derived = [s for s in err.splitlines() if "acceleration limits derived" in s]
    assert len(derived) == 1 and "0.5 × effort limit" in derived[0]
    assert err.index("expected duration ~") < err.index("time limit 1 s: the best of")
    assert "step " not in err
    assert load_trajectory(out).extra["margins"]["worst"]["velocity"]["ok"]
    assert main(args + ["--require-acceleration-limits"]) == 2
    assert "joint j1 has no acceleration limit" in capsys.readouterr().err


def test_a_period_too_short_says_what_it_cannot_excite_not_a_lighter_payload(tmp_path, capsys):
    """issue 43: --period 0.01 answered 'loosen the margins … lighter payload' (0.01 s is refused
    now, naming the period: test_design_period.py); at 0.03 s what cannot be excited is named."""
    urdf = two_link_urdf(tmp_path)
    out = tmp_path / "t.yaml"
    assert main(["excite", "design", "--robot", str(urdf), "--payload-mass", "0.5", "--out",
                 str(out), "--period", "0.03", "--periods", "2", "--restarts", "2", "--steps",
                 "0", "--collision", "skip"]) == 0
    text = capsys.readouterr().out
    assert "not excited: " in text and "a longer period" in text
    assert "lighter payload" not in text
    assert load_trajectory(out).extra["prediction"]["not_excited"]
