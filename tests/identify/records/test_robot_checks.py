"""Records checked against the robot (issue 43): positions beyond the limits refused with the
likely cause, velocities and currents far beyond them said, the same data under another clock
counted once, and refusals in the robot's own words (no Orthoglide parameter in a UR5's).

The records are the simulated UR5 (MuJoCo plant, orthoglide_sim.arms), 6 s each; the limits
are the UR5 URDF's own (±2π rad, elbow ±π; 3.15-3.2 rad/s; 150 / 28 N·m)."""
from __future__ import annotations

import dataclasses
import re

import numpy as np
import pytest
from live_helpers import as_record

from orthoglide_ident.cli import main
from orthoglide_ident.errors import DataError, ExcitationError, IdentificationError
from orthoglide_ident.identify import identify_records
from orthoglide_ident.model.registry import load_robot
from orthoglide_sim.arms.record import simulate_arm

UR5 = load_robot("ur5")


@pytest.fixture(scope="module")
def runs():
    return (simulate_arm(6.0, payload=None, trajectory="exciting1", seed=0),
            simulate_arm(6.0, payload="2.0", trajectory="exciting2", seed=1))


@pytest.fixture()
def recs(runs):
    return as_record(runs[0], "ur5/unloaded"), as_record(runs[1], "ur5/loaded_2kg")


def _with(rec, source, **arrays):
    return dataclasses.replace(rec, source=source, **arrays)


@pytest.mark.parametrize("method", ["tls", "wls"])
def test_positions_in_degrees_are_refused_as_degrees(recs, method):
    unloaded, loaded = recs
    deg = _with(unloaded, "ur5_deg/unloaded", q=np.degrees(unloaded.q))
    with pytest.raises(DataError) as err:
        identify_records([deg, loaded], model=UR5, method=method)
    msg = str(err.value)
    assert msg.startswith("ur5_deg/unloaded:") and "degrees" in msg and "--angle-unit deg" in msg
    assert "\n" not in msg


def test_an_offset_beyond_the_limits_is_called_an_offset(recs):
    unloaded, loaded = recs
    q = unloaded.q.copy()
    q[:, 2] += 2 * np.pi  # the elbow (±π) logged a turn off: the motion fits, not where it is
    with pytest.raises(DataError, match=r"^ur5_turn/unloaded: joint elbow_joint .* offset"):
        identify_records([_with(unloaded, "ur5_turn/unloaded", q=q), loaded], model=UR5,
                         method="wls")


def test_a_motion_wider_than_the_range_is_another_robot(recs):
    unloaded, loaded = recs
    q = unloaded.q.copy()
    q[:, 2] *= 800.0  # 1.25 rad made 1000: wider than the elbow's 2π, in radians or degrees
    with pytest.raises(DataError, match="another robot"):
        identify_records([_with(unloaded, "ur5_x8/unloaded", q=q), loaded], model=UR5)


def test_currents_in_milliamps_are_said_naming_the_joint(recs):
    unloaded, loaded = recs
    ma = _with(loaded, "ur5_mA/loaded", v_tau=loaded.v_tau * 1000.0)  # 65 N·m -> 65 kN·m
    res = identify_records([unloaded, ma], model=UR5, method="wls", gains=UR5.nominal_gains)
    said = [w for w in res.warnings if w.startswith("ur5_mA/loaded: joint")]
    assert {w.split()[2] for w in said} >= {"shoulder_lift_joint's", "elbow_joint's"}
    assert all("effort limit" in w for w in said)
    assert not [w for w in res.warnings if w.startswith("ur5/unloaded: joint")]


def test_a_clock_in_the_wrong_unit_is_said_as_a_velocity_beyond_the_limits(recs):
    from orthoglide_ident.identify.records.robot_checks import motion_warnings

    unloaded, _ = recs
    fast = _with(unloaded, "ur5_fast/unloaded", stamps_q_ns=unloaded.stamps_q_ns // 20,
                 stamps_v_ns=unloaded.stamps_v_ns // 20)  # 6 s logged as 0.3 s
    said = motion_warnings(fast, UR5)
    assert said and all("velocity limit" in w for w in said)
    assert not motion_warnings(unloaded, UR5)


def test_the_same_record_under_a_shifted_clock_is_counted_once(recs):
    unloaded, loaded = recs
    shift = int(1.7e18)  # t + 1.7e9 s: the same log exported again with epoch stamps
    again = _with(unloaded, "ur5/unloaded_epoch", stamps_q_ns=unloaded.stamps_q_ns + shift,
                  stamps_v_ns=unloaded.stamps_v_ns + shift)
    once = identify_records([unloaded, loaded], model=UR5, method="wls")
    twice = identify_records([unloaded, again, loaded], model=UR5, method="wls")
    said = [w for w in twice.warnings if "is the same record as" in w]
    assert said and said[0].startswith("ur5/unloaded_epoch is the same record as ur5/unloaded")
    assert "+1.7e+09 s" in said[0]
    assert twice.bags == once.bags
    assert twice.payload_mass.rel_std == pytest.approx(once.payload_mass.rel_std, rel=1e-9)


@pytest.mark.parametrize("method", ["tls", "wls"])
def test_a_ur5_refusal_speaks_of_the_ur5_not_of_the_orthoglide(recs, method):
    _, loaded = recs
    other = _with(loaded, "ur5/loaded_again", q=loaded.q[::-1].copy())
    with pytest.raises(IdentificationError) as err:
        identify_records([loaded, other], model=UR5, method=method)
    msg = str(err.value)
    assert "unloaded" in msg and "m_6R" not in msg and "platform" not in msg


def test_the_cli_refuses_a_degree_bag_in_one_line_naming_it(runs, tmp_path, capsys):
    from orthoglide_ident.bags.writer import write_bag

    bags = []
    for run, name, deg in ((runs[0], "unloaded_deg", True), (runs[1], "loaded", False)):
        q = np.degrees(run.q) if deg else run.q
        bags.append(str(write_bag(tmp_path / name, run.stamps_ns, q, run.v_tau,
                                  "loaded" if run.payload_mass else "unloaded", run.payload_mass,
                                  joint_names=run.joint_names, layout="joint_states")))
    assert main(["identify", "--robot", "ur5", "--method", "wls", "-q", *bags]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "unloaded_deg" in err[0] and "degrees" in err[0]


@pytest.mark.parametrize("method", ["tls", "wls"])
def test_records_of_another_gain_scale_are_said(recs, method):
    """The loaded record's currents 1.3 times the unloaded one's for the same dynamics (another
    gain or unit). Before: TLS "no drive gain is determined … record longer", WLS an answer
    with a 3.3 kg payload for the 2 kg mounted and nothing about the records."""
    unloaded, loaded = recs
    other = _with(loaded, "ur5/loaded_other_gain", v_tau=loaded.v_tau * 1.3)
    said = ""
    try:
        res = identify_records([unloaded, other], model=UR5, method=method)
        said = " ".join(res.warnings)
    except (ExcitationError, IdentificationError) as exc:
        said = str(exc)
    assert "the records disagree on their drive chain" in said
    factors = [float(x) for x in re.findall(r"×([0-9.]+)", said)]
    assert len(factors) == 6 and all(abs(f / 1.3 - 1) < 0.05 for f in factors), factors


def test_a_payload_tagged_wrong_is_not_taken_for_a_drive_chain(recs):
    unloaded, loaded = recs
    wrong = _with(loaded, "ur5/loaded_tagged_1kg", payload_mass=1.0,
                  payload=dataclasses.replace(loaded.payload, mass=1.0))
    res = identify_records([unloaded, wrong], model=UR5, method="wls")
    assert not [w for w in res.warnings if "drive chain" in w]


def _chattering(rec, joint: int, source: str):
    """``rec`` with joint ``joint``'s current switching ± half its clip level every sample and
    clipped there (a controller at its current limit, as the simulated UR10's shoulder was)."""
    v = rec.v_tau.copy()
    lim = 1.2 * np.abs(v[:, joint]).max()
    v[:, joint] = np.clip(v[:, joint] + 0.5 * lim * (-1.0) ** np.arange(len(v)), -lim, lim)
    return _with(rec, source, v_tau=v)


def test_a_current_chattering_at_its_limit_is_said_and_no_gain_determined(recs):
    """Issue 43's rule: a chattering current dithers the friction the model does not have, of its
    joint and through the coupling of the others (UR10: gains 3-7 σ off, marked determined).
    Before: no word, every gain determined."""
    from orthoglide_ident.identify.records.robot_checks import motion_warnings

    unloaded, loaded = recs
    chat = _chattering(loaded, 2, "ur5_chatter/loaded")
    said = [w for w in motion_warnings(chat, UR5) if w.startswith("ur5_chatter/loaded: joint")]
    assert len(said) == 1 and said[0].startswith("ur5_chatter/loaded: joint elbow_joint's")
    assert "chattering at its current limit" in said[0]
    with pytest.raises(ExcitationError) as err:
        identify_records([unloaded, chat], model=UR5)
    msg = str(err.value)
    assert msg.startswith("no drive gain is determined") and said[0] in msg and "\n" not in msg


def test_a_smooth_current_or_a_sinusoid_is_not_called_chattering(recs):
    from orthoglide_ident.identify.records.robot_checks import current_at_limit

    unloaded, loaded = recs
    assert not current_at_limit(unloaded) and not current_at_limit(loaded)
    t = np.arange(6000) * 1e-3  # a constant-amplitude sinusoid: 0.9 % within 1e-4 of its peak
    sine = np.repeat(np.sin(2 * np.pi * 0.5 * t)[:, None], 6, axis=1)
    assert not current_at_limit(_with(unloaded, "sine", v_tau=sine))
    clipped = np.clip(1.25 * sine, -1.0, 1.0)  # held at ±1 on 41 % of the samples, no chatter
    said = current_at_limit(_with(unloaded, "clipped", v_tau=clipped))
    assert set(said) == set(unloaded.names_v) and "sits at ±1" in said["elbow_joint"]
    assert not current_at_limit(_with(unloaded, "clipped", v_tau=clipped), chatter_only=True)


def test_the_live_identification_says_the_same_of_a_chattering_current(recs):
    from live_helpers import live_result

    from orthoglide_ident.identify import IdentifyOptions

    unloaded, loaded = recs
    chat = _chattering(loaded, 2, "ur5_chatter/loaded")
    with pytest.raises(ExcitationError) as err:
        live_result(UR5, [unloaded, chat], IdentifyOptions())
    assert "ur5_chatter/loaded: joint elbow_joint's current jumps" in str(err.value)


def test_wls_with_given_gains_says_a_chattering_current_and_keeps_the_gains(recs):
    unloaded, loaded = recs
    chat = _chattering(loaded, 2, "ur5_chatter/loaded")
    res = identify_records([unloaded, chat], model=UR5, method="wls", gains=UR5.nominal_gains)
    assert any(w.startswith("ur5_chatter/loaded: joint elbow_joint's current jumps")
               for w in res.warnings)
    assert all(g.determined for g in res.drive_gains)  # an input, not identified
