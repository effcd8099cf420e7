"""The simulated UR5 under its 1 kHz controller: tracking, zero-order hold with the true gains,
encoder and current noise as configured, determinism, workspace errors, bags."""
from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest
import yaml

from orthoglide_ident.bags import read_bag
from orthoglide_ident.errors import WorkspaceError
from orthoglide_sim.arm_or_chain.bags import main as bags_main
from orthoglide_sim.arms import simulator as asim
from orthoglide_sim.arms.description import load_arm
from orthoglide_sim.arms.excitation import designed_trajectory
from orthoglide_sim.arms.limits import motion_limits
from orthoglide_sim.arms.plant import MujocoPlant
from orthoglide_sim.arms.record import simulate_arm
from orthoglide_sim.arms.truth import default_truth

SECONDS = 2.0


@pytest.fixture(scope="module")
def truth():
    return default_truth(load_arm("ur5"))


@pytest.fixture(scope="module")
def rec(truth):
    return simulate_arm(SECONDS, payload="2.0", trajectory="exciting2", seed=3, truth=truth)


def test_record_layout(rec):
    N = int(SECONDS * 1000)
    assert rec.stamps_ns.dtype == np.int64 and np.all(np.diff(rec.stamps_ns) == 1_000_000)
    assert rec.q.shape == rec.v_tau.shape == rec.q_true.shape == rec.current.shape == (N, 6)
    assert rec.joint_names == load_arm("ur5").joint_names and rec.payload_mass == 2.0


def test_controller_tracks_the_exciting_trajectory(rec):
    """Triple pole at 100 rad/s: measured 0.02-0.13 mrad rms per joint on the designed motion."""
    print("tracking rms (mrad):", np.round(1e3 * rec.tracking_rms, 3))
    assert np.all(rec.tracking_rms < 0.3e-3)
    assert np.abs(rec.q_true - rec.q_ref).max() < 1.5e-3
    assert rec.saturated_ticks == 0


def test_drive_holds_the_current_over_the_tick_with_the_true_gains(rec, truth):
    """Replaying tick k from the recorded state under g_tau (v_tau + noise) held for the tick
    lands on the recorded state of tick k+1; under the nominal gains it does not."""
    plant = MujocoPlant(truth, rec.payload)
    g = truth.drive_array("g_tau")
    for k in (100, 900, 1700):
        for gains, close in ((g, True), (truth.arm.nominal_gains, False)):
            plant.reset(rec.q_true[k], rec.qd_true[k])
            plant.step(gains * rec.current[k], asim.SUBSTEPS)
            err = np.abs(plant.q - rec.q_true[k + 1]).max()
            assert (err < 1e-9) if close else (err > 1e-7), (k, err)


def test_encoder_reads_whole_counts(rec, truth):
    res = truth.encoder_resolution
    assert np.allclose(res, 2 * np.pi / 2**19)
    counts = rec.q / res
    assert np.abs(counts - np.round(counts)).max() < 1e-6
    assert np.all(np.abs(rec.q - rec.q_true) <= 0.5 * res * (1 + 1e-9))


def test_current_noise_is_half_a_percent_of_the_rms_current(rec):
    """White noise of 0.5 % of each joint's rms current: the configured σ is that of the
    reference's currents (within 10 % of the recorded v_tau's rms), the drawn noise has it
    (2000 samples: ±3.2 % is 2σ of a σ estimate)."""
    noise = rec.current - rec.v_tau
    rms = np.sqrt(np.mean(rec.v_tau**2, axis=0))
    assert np.allclose(rec.current_noise_std, 0.005 * rms, rtol=0.10)
    assert np.allclose(noise.std(axis=0), rec.current_noise_std, rtol=0.08)
    assert np.abs(np.corrcoef(noise.T) - np.eye(6)).max() < 0.1


def test_same_seed_same_record_other_seed_other_noise(truth):
    run = lambda seed, noise=True: simulate_arm(0.3, payload="2.0", trajectory="exciting2",  # noqa: E731
                                                seed=seed, truth=truth, noise=noise)
    a, b, c = run(3), run(3), run(4)
    assert np.array_equal(a.q, b.q) and np.array_equal(a.v_tau, b.v_tau)
    assert not np.array_equal(a.v_tau, c.v_tau)
    quiet = run(3, noise=False)
    assert np.array_equal(quiet.current, quiet.v_tau) and not np.array_equal(quiet.v_tau, a.v_tau)


def test_leaving_the_limits_is_a_workspace_error(truth, tmp_path):
    """The elbow's reference pushed 0.6 rad above its box: the arm follows it out of its stop
    limit (0.25 rad beyond the box) and the simulator stops with the joint named."""
    traj = designed_trajectory(truth.arm, "exciting1")
    q0 = traj.q0.copy()
    q0[2] += 0.6
    path = tmp_path / "out.json"
    path.write_text(json.dumps(replace(traj, q0=q0).to_dict()))
    with pytest.raises(WorkspaceError, match="elbow_joint = .* left its limits"):
        simulate_arm(5.0, trajectory=str(path), truth=truth)


def test_non_finite_state_is_a_workspace_error(truth, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # MuJoCo's own warning handler would write MUJOCO_LOG.TXT here
    plant = MujocoPlant(truth)
    limits = motion_limits(truth.arm)
    q = np.tile(limits.centre, (3, 1))
    pid = asim.arm_pid(np.ones(6), truth.arm.nominal_gains, np.full(6, np.inf), q[0],
                            np.zeros(6), np.zeros(6))
    plant.reset(q[0], np.zeros(6))
    noise = np.full((3, 6), np.nan)
    with pytest.raises(WorkspaceError, match="not finite"):
        asim.run_arm(plant, pid, q, np.zeros((3, 6)), noise, limits)
    assert not list(tmp_path.iterdir())


def test_current_limit_clips_the_reference(truth):
    pid = asim.arm_pid(np.ones(6), truth.arm.nominal_gains, np.full(6, 2.0), np.zeros(6),
                            np.zeros(6), np.zeros(6))
    v = pid.current(np.zeros(6), np.array([1.0, -1.0, 1e-6, 0, 0, 0]), np.zeros(6))
    assert v[0] == 2.0 and v[1] == -2.0 and 0 < v[2] < 2.0


def test_bags_of_the_three_runs(tmp_path):
    assert bags_main(["--robot", "ur5", "--duration", "0.3", "--out", str(tmp_path)]) == 0
    for name, mass in (("unloaded", 0.0), ("loaded_2kg", 2.0), ("loaded_1kg", 1.0)):
        bag = read_bag(tmp_path / name)
        assert bag.tags.payload_mass == mass
        assert bag.joint_states.names == load_arm("ur5").joint_names
        assert len(bag.joint_states.stamps_ns) == 300
        custom = yaml.safe_load((tmp_path / name / "metadata.yaml").read_text())[
            "rosbag2_bagfile_information"]["custom_data"]
        assert custom["orthoglide.sim.robot"] == "ur5"
        if mass:
            payload = default_truth(load_arm("ur5")).payload(f"{mass:.1f}")
            assert custom["orthoglide.payload_frame"] == "tool0"
            assert np.array_equal(
                np.array(custom["orthoglide.payload_com"].split(), float), payload.body.com
            )
            assert len(custom["orthoglide.payload_inertia"].split()) == 6
        else:
            assert "orthoglide.payload_frame" not in custom


def test_bags_bad_input_one_line(tmp_path, capsys):
    assert bags_main(["--robot", "nope", "--duration", "1", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: robot 'nope'") and err.count("\n") == 1
    assert bags_main(["--duration", "-1", "--out", str(tmp_path)]) == 2


@pytest.mark.slow
def test_the_60_s_records_stay_in_the_workspace_unsaturated(tmp_path, capsys):
    """The bags command's three 60 s records (unloaded, 2 kg, 1 kg) run to the end."""
    assert bags_main(["--robot", "ur5", "--duration", "60", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert out.count("0 saturated ticks") == 3
    for name in ("unloaded", "loaded_2kg", "loaded_1kg"):
        assert len(read_bag(tmp_path / name).joint_states.stamps_ns) == 60_000
