"""current_sampling: the tag, the import flag, the option and the robot file say how a record's
current relates to its stamps (held over the step, or sampled at the stamp from a faster loop);
``auto`` reads a negative identified lag as sampled; a point-sampled log of a 1 kHz loop is
identified without bias only as sampled (observe/sampling.py)."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from orthoglide_ident.bags import BagTags, read_bag
from orthoglide_ident.bags.csv_import import ColumnMap, import_csv
from orthoglide_ident.errors import BagError, ConfigError
from orthoglide_ident.identify import IdentifyOptions
from orthoglide_ident.identify.observe.sampling import (
    lag_says_sampled,
    record_sampling,
    sampled_shift_s,
)
from orthoglide_ident.identify.observe.time_base import states_on_stamps
from orthoglide_ident.identify.pipeline import sampling_rerun
from orthoglide_ident.model.robot_file import read_description
from orthoglide_ident.results import LagEstimate


def test_the_tag_round_trips_and_a_wrong_value_is_refused():
    tags = BagTags.checked("unloaded", 0.0, current_sampling="sampled")
    d = tags.to_dict()
    assert d["orthoglide.current_sampling"] == "sampled"
    assert BagTags.from_dict(d, "x").current_sampling == "sampled"
    assert "orthoglide.current_sampling" not in BagTags.checked("unloaded", 0.0).to_dict()
    with pytest.raises(BagError, match="current_sampling"):
        BagTags.from_dict({**d, "orthoglide.current_sampling": "avg"}, "x.mcap")


def test_import_flag_tags_the_bag(tmp_path):
    csv = tmp_path / "log.csv"
    t = np.arange(200) * 0.012
    csv.write_text("t,j1.q,j1.effort\n" + "".join(f"{x:.3f},{np.sin(x):.6f},{np.cos(x):.6f}\n"
                                                   for x in t))
    cmap = ColumnMap().with_values(effort_unit="A", current_sampling="sampled")
    res = import_csv([csv], tmp_path / "bag", cmap)
    assert "current sampled" in res.tag
    assert read_bag(tmp_path / "bag").tags.current_sampling == "sampled"
    plain = import_csv([csv], tmp_path / "bag2", ColumnMap().with_values(effort_unit="A"))
    assert read_bag(plain.bag).tags.current_sampling is None  # auto: untagged
    with pytest.raises(ConfigError, match="current_sampling"):
        ColumnMap().with_values(current_sampling="mean")


def test_option_and_robot_file_key(tmp_path):
    assert IdentifyOptions.from_mapping({"current_sampling": "sampled"}).input.current_sampling == \
        "sampled"
    assert IdentifyOptions().input.current_sampling == "auto"
    with pytest.raises(ConfigError, match="current_sampling"):
        IdentifyOptions.from_mapping({"current_sampling": "point"})
    (tmp_path / "r.urdf").write_text("<robot name='r'/>")
    desc = read_description({"description": "r.urdf", "current_sampling": "sampled"}, tmp_path)
    assert desc.current_sampling == "sampled"
    with pytest.raises(ConfigError, match="current_sampling"):
        read_description({"description": "r.urdf", "current_sampling": "auto"}, tmp_path)


def test_a_robot_file_key_reaches_the_model(tmp_path):
    """A robot YAML with current_sampling: its model says it (also through a transmission)."""
    from orthoglide_ident.identify.observe.sampling import robot_file_sampling
    from orthoglide_ident.model.registry import ROBOTS_DIR, load_robot

    text = (ROBOTS_DIR / "ur5.yaml").read_text()
    (tmp_path / "ur5.urdf").write_text((ROBOTS_DIR / "ur5.urdf").read_text())
    (tmp_path / "ur5.yaml").write_text(text + "\ncurrent_sampling: sampled\n")
    assert robot_file_sampling(load_robot(str(tmp_path / "ur5.yaml"))) == "sampled"
    assert robot_file_sampling(load_robot("ur5")) is None


def test_who_says_the_sampling():
    assert record_sampling("sampled", "held", "held")[0] == "sampled"  # the tag first
    assert record_sampling(None, "sampled", "held")[0] == "sampled"  # then the option
    assert record_sampling(None, "auto", "sampled")[0] == "sampled"  # then the robot file
    assert record_sampling(None, "auto", None)[0] == "held"  # auto's first reading


def _lags(taus_ms, std_ms=0.02):
    return [LagEstimate(f"j{i}", 1e-3 * t, 1e-3 * std_ms) for i, t in enumerate(taus_ms)]


def test_auto_reads_a_negative_lag_as_sampled():
    neg = _lags([-0.47, -0.45, -0.49, -0.46])
    assert "negative on 4 of 4" in lag_says_sampled(neg)
    assert lag_says_sampled(_lags([0.05, 0.02, -0.01, 0.03])) is None  # noise around 0
    assert lag_says_sampled(_lags([-0.47, 0.05, 0.02, 0.01])) is None  # one joint only
    from types import SimpleNamespace

    res = SimpleNamespace(current_lag=neg)
    why = "current_sampling: auto, nothing said: held until the lag says otherwise"
    res.record_reports = [SimpleNamespace(current_sampling_why=why)]
    assert sampling_rerun(res, IdentifyOptions()) is not None
    assert sampling_rerun(res, IdentifyOptions.of(current_sampling="held")) is None  # as told
    res.record_reports = [SimpleNamespace(current_sampling_why="the bag's tag")]
    assert sampling_rerun(res, IdentifyOptions()) is None  # a tagged record is as tagged


def test_sampled_states_sit_at_the_stamp_plus_the_loops_half_tick():
    """Closed form: q = sin(2π f t) on a 10/12/14 ms clock; the states of a sampled record are
    those at t_k (+ 1 / (2 f_loop) with the loop's rate), a held record's at the step middles."""
    st = np.cumsum(np.r_[0, np.resize([10, 12, 14], 999)]).astype(np.int64) * 1_000_000
    t = st * 1e-9
    f = 0.5
    q = np.sin(2 * np.pi * f * t)[:, None]
    opts = IdentifyOptions.of(current_sampling="sampled", zoh_shift=False, current_loop_hz=1000.0)
    shift = sampled_shift_s(opts)
    assert shift == pytest.approx(5e-4)
    assert sampled_shift_s(IdentifyOptions()) == 0.0  # held: the half step of the log instead
    sl = slice(100, -100)
    for zoh, want in ((False, t + shift), (True, 0.5 * (t[:-1] + t[1:]))):
        qh, qd, _ = states_on_stamps(q, st, 15.0, zoh_shift=zoh, shift_s=shift)
        assert np.abs(qh[sl, 0] - np.sin(2 * np.pi * f * want[sl])).max() < 1e-5
        assert np.abs(qd[sl, 0] - 2 * np.pi * f * np.cos(2 * np.pi * f * want[sl])).max() < 1e-4


@pytest.mark.slow
def test_a_point_sampled_250_hz_log_is_unbiased_only_as_sampled():
    """UR5 under its 1 kHz PID, logged every 3/4/5 ticks, the loop's current band-limited below
    the log's Nyquist frequency (bench/logger_sampling.py's '~250 Hz pt, smooth'): held puts
    the states 2 ms late and wrist_2 comes out biased beyond 3 σ; sampled (the loop's rate
    known) puts every gain within 3 σ of the plant's."""
    from orthoglide_ident.identify import Record, identify_records
    from orthoglide_ident.identify.observe.filtering import zero_phase_butterworth
    from orthoglide_ident.model.registry import load_robot
    from orthoglide_sim.arms.log import KEEP_3_4_5, clock_uniform, point_sampled, simulate_arm_log

    model = load_robot("ur5")
    recs = []
    for p, tr, s in ((None, "exciting1", 0), ("2.0", "exciting2", 1)):
        r = simulate_arm_log(60.0, clock_uniform(60.0, 1000.0), payload=p, trajectory=tr,
                             seed=s, print_resolution=0.0)
        r = dataclasses.replace(r, v_tau=zero_phase_butterworth(r.v_tau, 1e-3, 87.5, 4))
        recs.append(point_sampled(r, KEEP_3_4_5, 0.0))

    def records():
        out = []
        for i, r in enumerate(recs):
            tag = r.payload.tag() if r.payload is not None else None
            from orthoglide_ident.model.robot import Payload
            pl = None if tag is None else Payload(r.payload_mass, tag["payload_frame"],
                                                  tuple(tag["payload_com"]),
                                                  tuple(tag["payload_inertia"]))
            out.append(Record.from_arrays(f"r{i}", r.stamps_ns, r.q, r.v_tau,
                                          "loaded" if pl else "unloaded", r.payload_mass,
                                          r.joint_names, pl))
        return out

    truth = recs[0].truth.drive_array("g_tau")

    def sigmas(opts):
        res = identify_records(records(), model=model, options=opts)
        return np.array([abs(g.value / t - 1) / g.rel_std for g, t in zip(res.drive_gains, truth)
                         if getattr(g, "determined", True)]), res

    held, _ = sigmas(IdentifyOptions.of(current_sampling="held"))
    sampled, _ = sigmas(IdentifyOptions.of(current_sampling="sampled", current_loop_hz=1000.0))
    assert held.max() > 3.0
    assert sampled.size == 6 and sampled.max() < 3.0
    # the loop's rate unknown: its half tick fitted by the residual (0.5 ms found)
    fitted, res = sigmas(IdentifyOptions.of(current_sampling="sampled"))
    assert fitted.size == 6 and fitted.max() < 3.0
    assert {b.current_shift_ms for b in res.record_reports} == {0.5}
    # auto, nothing said, a 4 ms step: the reading whose residual is smaller, said in one line
    _, auto = sigmas(IdentifyOptions.of(current_loop_hz=1000.0))
    assert {b.current_sampling for b in auto.record_reports} == {"sampled"}
    assert any(w.startswith("current_sampling: auto on") and "read sampled" in w
               for w in auto.warnings)


@pytest.mark.slow
def test_auto_reads_a_log_held_at_its_own_rate_as_held():
    """A controller at the log rate on a 10/12 ms clock (bench/real_records.py): auto keeps
    held (sampled leaves a larger residual or is refused), the answer today's."""
    import sys
    from pathlib import Path

    from orthoglide_ident.identify import identify_records
    from orthoglide_ident.model.registry import load_robot
    from orthoglide_sim.arms.log import clock_10_12, simulate_arm_log
    sys.path.insert(0, str(Path(__file__).parents[3] / "bench"))
    from real_records import to_record

    model = load_robot("ur5")
    recs = [to_record(simulate_arm_log(60.0, clock_10_12(60.0), payload=p, trajectory=tr,
                                       seed=s), f"r{s}")
            for p, tr, s in ((None, "exciting1", 0), ("2.0", "exciting2", 1))]
    auto = identify_records(recs, model=model)
    held = identify_records(recs, model=model, options=IdentifyOptions.of(current_sampling="held"))
    assert {b.current_sampling for b in auto.record_reports} == {"held"}
    assert [g.value for g in auto.drive_gains] == [g.value for g in held.drive_gains]
    assert any("read held" in w for w in auto.warnings)


def test_live_blocks_of_a_sampled_current_give_the_offline_rows():
    """The live stream (ticks pushed in blocks) reads the option as offline does: the states at
    t_k + 1 / (2 current_loop_hz), not at the half tick; its rows equal the offline ones."""
    from synthetic import SyntheticModel, synthetic_record

    from orthoglide_ident.identify.columns.layout import plain_layout
    from orthoglide_ident.identify.observe.stream import SegmentStream
    from orthoglide_ident.identify.observe.time_base import states_at_half_tick

    opts = IdentifyOptions.of(current_sampling="sampled", current_loop_hz=4000.0).at_rate(1e3)
    rec = synthetic_record(4.0, 0.0, seed=3, amplitude=0.1, f_max=4.0)
    model, T = SyntheticModel(), 1e-3
    ob = opts.observe
    trim = int(round(ob.edge_trim_s / T))
    states = states_at_half_tick(rec.q, rec.v_tau, T, ob.filter_cutoff_hz, ob.filter_order,
                                 trim, False, ob.filter_currents, rec.stamps_q_ns,
                                 shift_s=1.25e-4)
    stamps = rec.stamps_q_ns[trim:trim + states[0].shape[0]]
    t0 = int(rec.stamps_q_ns[0])
    whole = SegmentStream(model, plain_layout(model), opts, T, t0)
    ref = [whole.push_states(stamps, *states), whole.finish()]
    held = states_at_half_tick(rec.q, rec.v_tau, T, ob.filter_cutoff_hz, ob.filter_order,
                               trim, True, ob.filter_currents)
    assert held[0].shape[0] == states[0].shape[0] - 1  # the held reading's rows differ
    blocks = SegmentStream(model, plain_layout(model), opts, T, t0)
    got = [blocks.push(rec.stamps_q_ns[a:a + 700], rec.q[a:a + 700], rec.v_tau[a:a + 700])
           for a in range(0, rec.q.shape[0], 700)] + [blocks.finish()]
    X0 = np.concatenate([r.X for r in ref], axis=2)
    X1 = np.concatenate([r.X for r in got], axis=2)
    assert X0.shape == X1.shape and X0.shape[2] > 0
    scale = np.abs(X0).max(axis=2, keepdims=True) + 1e-300
    assert np.abs((X1 - X0) / scale).max() < 1e-9
    t = np.concatenate([r.t for r in got])
    assert np.allclose(t, np.concatenate([r.t for r in ref]))
    k = (t - 1.25e-4) * 1e3  # ms since the first stamp, less the loop's half tick: whole
    assert np.allclose(k, np.round(k), atol=1e-6)


@pytest.mark.slow
def test_auto_reads_a_1khz_log_of_a_4khz_loop_as_sampled_by_its_negative_lag():
    """A 4 kHz loop (its current band-limited at 350 Hz) logged every 4th tick: read held, the
    lag is negative on every joint (the log's half tick less the loop's, 0.375 ms, the wrong
    way); auto reads it again as sampled, says why, and the lag comes out positive."""
    from orthoglide_ident.identify import Record, identify_records
    from orthoglide_ident.identify.observe.filtering import zero_phase_butterworth
    from orthoglide_ident.model.registry import load_robot
    from orthoglide_ident.model.robot import Payload
    from orthoglide_sim.arms.log import clock_uniform, point_sampled, simulate_arm_log

    recs = []
    for p, tr, s in ((None, "exciting1", 0), ("2.0", "exciting2", 1)):
        r = simulate_arm_log(25.0, clock_uniform(25.0, 4000.0), payload=p, trajectory=tr, seed=s,
                             print_resolution=0.0)
        r = dataclasses.replace(r, v_tau=zero_phase_butterworth(r.v_tau, 2.5e-4, 350.0, 4))
        r = point_sampled(r, 4, 0.0)
        tag = None if r.payload is None else r.payload.tag()
        pl = None if tag is None else Payload(r.payload_mass, tag["payload_frame"],
                                              tuple(tag["payload_com"]),
                                              tuple(tag["payload_inertia"]))
        recs.append(Record.from_arrays(f"r{s}", r.stamps_ns, r.q, r.v_tau,
                                       "loaded" if pl else "unloaded", r.payload_mass,
                                       r.joint_names, pl))
    model = load_robot("ur5")
    held = identify_records(recs, model=model, options=IdentifyOptions.of(current_sampling="held"))
    assert all(x.tau_ms < -0.2 for x in held.current_lag)  # measured -0.27 ... -0.44
    auto = identify_records(recs, model=model)
    assert {b.current_sampling for b in auto.record_reports} == {"sampled"}
    assert auto.warnings[0].startswith("the identified current-loop lag is negative")
    assert all(x.tau_ms > -3 * x.tau_std_ms for x in auto.current_lag)


def test_the_reading_kept_is_the_one_whose_residual_is_least():
    """best_reading's rule on stand-in solves: auto keeps held on a tie, takes sampled at its
    best half tick below 0.98 x held's residual, and falls back to what solves."""
    from types import SimpleNamespace

    from orthoglide_ident.errors import ExcitationError
    from orthoglide_ident.identify.observe.sampling import best_reading, loop_half_ticks

    assert loop_half_ticks(4e-3, 0.0) == (1.25e-4, 2.5e-4, 5e-4, 1e-3)
    assert loop_half_ticks(1.5e-3, 0.0) == (1.25e-4, 2.5e-4, 5e-4)
    assert loop_half_ticks(12e-3, 1000.0) == (5e-4,)

    def case(residuals, refused=()):
        def solve_rows(blocks, reports):
            if blocks[0] in refused:
                raise ExcitationError(f"{blocks[0]} refused")
            res = SimpleNamespace(residual_rms=[residuals[blocks[0]]] * 2)
            return (None, None, None, SimpleNamespace(result=res))
        rep = SimpleNamespace(bag="b", period_s=4e-3, current_sampling="held", k="held")
        alts = [[(d, k, SimpleNamespace(**dict(vars(rep), current_sampling="sampled", k=k)))
                 for d, k in ((0.0, "s0"), (5e-4, "s5"))]]
        out, reports, line = best_reading(solve_rows, ["held"], [rep], alts)
        return reports[0].k, line

    assert case({"held": 1.0, "s0": 0.99, "s5": 0.985})[0] == "held"  # a tie stays held
    pick, line = case({"held": 1.0, "s0": 0.9, "s5": 0.5})
    assert pick == "s5" and "0.5 ms after the stamp" in line and "0.5 x held's" in line
    assert case({"held": 1.0, "s0": 0.9, "s5": 0.5}, refused={"held"})[0] == "s5"
    assert case({"held": 1.0, "s0": 0.9, "s5": 0.5}, refused={"s0", "s5"})[0] == "held"
    with pytest.raises(ExcitationError, match="held refused"):
        case({}, refused={"held", "s0", "s5"})


def test_the_robot_file_says_the_sampling_with_the_lag_modelled(tmp_path):
    """With lag_model auto (the default) the observation still reads the robot file's
    current_sampling: the robot is passed itself beside its column layout (issue 44), where a
    drive-terms wrapper used to hide its description (the record was read held)."""
    from orthoglide_ident.identify import Record
    from orthoglide_ident.identify.columns.layout import column_layout
    from orthoglide_ident.identify.observe.rows import observe
    from orthoglide_ident.model.registry import ROBOTS_DIR, load_robot

    text = (ROBOTS_DIR / "ur5.yaml").read_text()
    (tmp_path / "ur5.urdf").write_text((ROBOTS_DIR / "ur5.urdf").read_text())
    (tmp_path / "ur5.yaml").write_text(text + "\ncurrent_sampling: sampled\n")
    robot = load_robot(str(tmp_path / "ur5.yaml"))
    st = np.arange(3000, dtype=np.int64) * 1_000_000  # 3 s at 1 kHz
    t = st * 1e-9
    q = 0.3 * np.sin(2 * np.pi * 0.5 * t[:, None] + np.arange(robot.n_joints))
    rec = Record.from_arrays("r", st, q, 0.1 * np.cos(2 * np.pi * 0.5 * t[:, None] + 0 * q),
                             "unloaded", 0.0, robot.joint_names)
    layout = column_layout(robot, 0.0, lag=True)
    assert layout.lag_column is not None  # the columns of lag_model auto
    _, rep, _ = observe(rec, robot, IdentifyOptions(), 0.0, layout=layout)
    assert rep.current_sampling == "sampled", rep.current_sampling_why
