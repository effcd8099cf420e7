"""The pipeline end to end on records of a synthetic 3-joint model (no bag, no simulator)."""
from __future__ import annotations

import json

import numpy as np
import pytest
from synthetic import TRUE_CHI, TRUE_GAINS, SyntheticModel, synthetic_record

from orthoglide_ident.errors import ConfigError, DataError, ExcitationError, IdentificationError
from orthoglide_ident.identify import IdentifyOptions, Record, identify_records

MODEL = SyntheticModel()
STRONG = dict(amplitude=0.1, f_max=4.0)
CHI_SMOOTH = TRUE_CHI.copy()
CHI_SMOOTH[6:9] = 0.0  # no Coulomb friction: the data match the model exactly


def _gains(res):
    return np.array([g.value for g in res.drive_gains])


def _pair(noise, chi=TRUE_CHI, duration=20.0, **kw):
    kw = {**STRONG, **kw}
    return [synthetic_record(duration, 0.0, seed=1, noise=noise, chi=chi, **kw),
            synthetic_record(duration, 1.983, seed=2, noise=noise, chi=chi, **kw)]


def test_noise_free_records_give_the_true_gains_and_the_zoh_shift_matters():
    recs = _pair(False, CHI_SMOOTH)
    res = identify_records(recs, model=MODEL)
    err = np.abs(_gains(res) / TRUE_GAINS - 1).max()
    assert err < 2e-5
    chi = np.array([p.value for p in res.parameters])
    assert np.abs(chi - CHI_SMOOTH).max() < 2e-3
    no_shift = identify_records(recs, model=MODEL, options=IdentifyOptions.of(zoh_shift=False,
                                                                              check_excitation=False))
    assert np.abs(_gains(no_shift) / TRUE_GAINS - 1).max() > 5 * err


def test_realistic_noise_gains_within_half_a_percent():
    # 1 mA current noise (the simulator's), 1 µm encoder: %σ of the gains ~0.1-0.15 %
    res = identify_records(_pair(True, duration=30.0, current_noise_a=1e-3), model=MODEL)
    assert np.abs(_gains(res) / TRUE_GAINS - 1).max() < 0.005
    assert all(0 < g.rel_std < 0.01 for g in res.drive_gains)
    assert res.payload_mass.known and res.payload_mass.value == 1.983


def test_gentle_trajectories_are_refused_with_a_reason():
    recs = _pair(True, amplitude=0.01, f_max=0.5)
    with pytest.raises(ExcitationError, match="excit"):
        identify_records(recs, model=MODEL)


def test_short_records_are_said_short_not_below_the_dead_band():
    # 0.8 s each, well excited: 44 decimated samples in all where max(50, 2 n_b) = 50 are needed
    recs = _pair(True, duration=0.8)
    with pytest.raises(ExcitationError) as exc:
        identify_records(recs, model=MODEL)
    assert str(exc.value) == ("the records are too short: 44 equations per joint (decimated "
                              "samples, 1 in 10) where 50 are needed (max(50, 2 n_b), n_b = 13); "
                              "record longer trajectories")
    # long enough but gentle: the dead band is the cause, and the reason says so (a record with
    # no joint above it is refused as one that hardly moves, naming the record)
    with pytest.raises(ExcitationError, match=r"hardly moves in this record \(at most 0 of \d+ "
                                              r"decimated samples .* above the velocity dead band"):
        identify_records(_pair(True, amplitude=0.001, f_max=0.5), model=MODEL)


def test_bad_inputs_get_one_line_reasons():
    recs = _pair(False)
    with pytest.raises(IdentificationError, match="loaded"):
        identify_records([recs[0]], model=MODEL)
    with pytest.raises(IdentificationError, match="tagged with a payload of 1.983 kg"):
        identify_records(recs, payload_mass=1.136, model=MODEL)
    bad = recs[1]
    names = Record(bad.source, bad.stamps_q_ns, ("x", "y", "z"), bad.q, bad.stamps_v_ns,
                   bad.names_v, bad.v_tau, bad.condition, bad.payload_mass)
    with pytest.raises(DataError, match="joint names"):
        identify_records([recs[0], names], model=MODEL)
    nan = Record(**{**vars(bad), "v_tau": bad.v_tau.copy()})
    nan.v_tau[5000, 2] = np.nan
    with pytest.raises(DataError, match="NaN"):
        identify_records([recs[0], nan], model=MODEL)
    untagged = Record(**{**vars(bad), "condition": None})
    with pytest.raises(IdentificationError, match="tag"):
        identify_records([recs[0], untagged], model=MODEL)
    with pytest.raises(IdentificationError, match="no bag"):
        identify_records([], model=MODEL)


def test_gaps_are_segmented_and_reported():
    recs = _pair(True, duration=30.0)
    r = recs[1]
    keep = np.ones(r.q.shape[0], bool)
    keep[10_000:10_040] = False
    keep[20_000] = False
    gappy = Record(r.source, r.stamps_q_ns[keep], r.names_q, r.q[keep], r.stamps_v_ns,
                   r.names_v, r.v_tau, r.condition, r.payload_mass)
    res = identify_records([recs[0], gappy], model=MODEL)
    d = res.record_reports[1]
    assert d.n_missing_ticks == 41 and d.n_gaps == 2 and d.n_segments == 3
    assert np.abs(_gains(res) / TRUE_GAINS - 1).max() < 0.01


def test_wls_reidentifies_the_second_payload():
    recs = [synthetic_record(30, 0.0, seed=1, **STRONG),
            synthetic_record(30, 1.136, seed=3, **STRONG)]
    good = identify_records(recs, method="wls", gains=TRUE_GAINS, model=MODEL)
    assert not good.payload_mass.known and good.payload_mass.tagged == 1.136
    assert abs(good.payload_mass.value / 1.136 - 1) < 0.01
    manuf = identify_records(recs, method="wls", model=MODEL)
    assert abs(manuf.payload_mass.value / 1.136 - 1) > 2 * abs(good.payload_mass.value / 1.136 - 1)
    assert manuf.drive_gains_given and manuf.drive_gains[0].value == pytest.approx(637 * np.pi)


def test_json_text_essential_and_validation():
    recs = _pair(True)
    val = [synthetic_record(20, 1.983, seed=7, **STRONG)]
    res = identify_records(recs, model=MODEL, essential=True, validation=val)
    doc = json.loads(json.dumps(res.to_json()))
    for key in ("method", "drive_gains", "parameters", "payload_mass", "condition_number",
                "residual_rms", "bags"):
        assert key in doc
    assert doc["method"] == "tls" and len(doc["drive_gains"]) == 3
    assert set(doc["drive_gains"][0]) >= {"joint", "value", "rel_std"}
    assert set(doc["parameters"][0]) >= {"name", "value", "rel_std", "expression"}
    assert doc["payload_mass"]["value"] == 1.983
    assert "essential" in doc and doc["essential"]["parameters"]
    v = doc["validation"][0]
    assert all(j["relative_error"] < 0.1 for j in v["joints"])
    text = res.to_text()
    assert "essential" in text and "g_tau q11" in text and "cross-validation" in text
    fields = res.message_fields()
    assert len(fields["names"]) == len(fields["values"]) == len(fields["rel_std"])


def test_options_from_yaml(tmp_path):
    p = tmp_path / "ident.yaml"
    p.write_text("/**:\n  ros__parameters:\n    r_sigma: 20.0\n    decimation: 5\n"
                 "    method: tls\n")
    o = IdentifyOptions.from_yaml(p)
    assert o.solve.r_sigma == 20.0 and o.observe.decimation == 5
    p.write_text("r_sigmaa: 3\n")
    with pytest.raises(ConfigError, match="unknown option"):
        IdentifyOptions.from_yaml(p)
    p.write_text("decimation: many\n")
    with pytest.raises(ConfigError, match="decimation"):
        IdentifyOptions.from_yaml(p)


def test_the_result_says_the_robots_locked_joints_with_drive_terms_modelled():
    """A drive term in the equations (a screw's ripple at a given lead) and a robot with a
    locked joint: the result names it, as without the term (the robot is passed itself beside
    its column layout, issue 44, where a drive-terms wrapper used to hide it)."""
    from orthoglide_ident.model.locked_joints import LISTED, LockedJoint

    class Locked(SyntheticModel):
        locked_joints = (LockedJoint("finger", 0.03, "prismatic", LISTED),)

    res = identify_records(_pair(False), model=Locked(),
                           options=IdentifyOptions.of(screw_lead_m=0.010))
    assert res.locked_joints == [Locked.locked_joints[0]]
    assert res.to_json()["locked_joints"] == [Locked.locked_joints[0].to_json()]
