"""The result's parts are typed (issue 44): read by attribute, written to exactly the JSON keys of
docs/design/interfaces.md; no robot default; a method's title comes from the methods table."""
from __future__ import annotations

import dataclasses
import io
import tokenize
from pathlib import Path

import numpy as np
import pytest
from synthetic import TRUE_GAINS, SyntheticModel, synthetic_record

from orthoglide_ident.identify import identify_records
from orthoglide_ident.identify.solve import methods
from orthoglide_ident.identify.validate.cross_validation import ValidationResult
from orthoglide_ident.results import (
    Estimate,
    IdentificationResult,
    LagEstimate,
    RippleEstimate,
    lag_text,
)

ROOT = Path(__file__).resolve().parents[1]


def test_a_result_names_its_robot_there_is_no_default():
    gains = [Estimate("j0", 2.0, 0.01)]
    with pytest.raises(TypeError, match="robot"):
        IdentificationResult("tls", ["j0"], gains, False, [], None, [], 1.0, [1.0], ["b"])
    res = IdentificationResult("tls", ["j0"], gains, False, [], None, [], 1.0, [1.0], ["b"],
                               "five_bar")
    assert res.to_json()["robot"] == "five_bar"


def test_the_text_report_opens_with_the_title_of_the_methods_row(monkeypatch):
    """A row registered under a title of its own: the result is named and titled by the row
    (results.py sits below the table and reads the title as data)."""
    recs = [synthetic_record(20.0, m, seed=s, noise=True, amplitude=0.1, f_max=4.0)
            for m, s in ((0.0, 1), (1.983, 2))]
    row = dataclasses.replace(methods.METHODS["wls"], name="wls_again", title="WLS, once more")
    monkeypatch.setitem(methods.METHODS, "wls_again", row)
    res = identify_records(recs, method="wls_again", gains=list(TRUE_GAINS),
                           model=SyntheticModel(), essential=True)
    assert res.method == res.essential.method == "wls_again"
    assert res.to_text().splitlines()[0] == "WLS, once more"
    assert res.to_json()["method"] == "wls_again"


@pytest.mark.parametrize("path", ["orthoglide_ident/results.py",
                                  "orthoglide_ident/identify/solve/answer.py",
                                  "orthoglide_ident/identify/pipeline.py"])
def test_no_method_is_named_outside_the_table(path):
    src = (ROOT / path).read_text()
    named = [f"{path}:{t.start[0]} {t.string}"
             for t in tokenize.generate_tokens(io.StringIO(src).readline)
             if t.type == tokenize.STRING and t.string.strip("'\"") in methods.METHODS]
    assert not named, named


def test_drive_terms_are_read_by_attribute_and_written_as_the_json_says():
    lag = LagEstimate("q11", 1.02e-4, 3.2e-5)
    assert lag.tau_ms == pytest.approx(0.102) and lag.tau_std_ms == pytest.approx(0.032)
    assert lag.to_json() == {"joint": "q11", "tau_ms": 1e3 * 1.02e-4, "tau_std_ms": 1e3 * 3.2e-5}
    assert lag_text([lag]) == "q11 0.102 ms (σ 0.032)"
    rip = RippleEstimate("q12", 0.01, True, 0.4, 0.02, -1.0)
    assert rip.kind == "friction (sign of velocity)"
    assert list(rip.to_json()) == ["joint", "wavelength_m", "kind", "amplitude_n",
                                   "amplitude_std_n", "phase_rad"]
    with pytest.raises(dataclasses.FrozenInstanceError):
        rip.amplitude_n = 0.0  # type: ignore[misc]


def test_a_validation_row_is_typed_and_its_json_keeps_the_note_only_where_said():
    nan = float("nan")
    v = ValidationResult("val.mcap", np.array([0.1, nan]), np.array([2.0, 1.0]),
                         np.array([0.05, nan]), None, np.zeros(1), np.zeros((2, 1)),
                         np.zeros((2, 1)), ["w"], ["", "hardly moves"])
    row = v.row(("q11", "q12"))
    assert row.bag == "val.mcap" and row.joints[0].residual_rms == 0.1
    assert row.joints[1].residual_rms is None and row.joints[1].note == "hardly moves"
    assert row.to_json() == {
        "bag": "val.mcap",
        "joints": [{"joint": "q11", "residual_rms": 0.1, "measured_rms": 2.0,
                    "relative_error": 0.05, "noise_ratio": None},
                   {"joint": "q12", "residual_rms": None, "measured_rms": 1.0,
                    "relative_error": None, "noise_ratio": None, "note": "hardly moves"}],
        "warnings": ["w"]}


def test_a_records_report_is_a_snapshot_of_its_segment_figures_with_the_json_keys():
    """bag_report's RecordReport: every SegmentReport figure (as it was then: a live recording
    goes on counting), read by attribute; its JSON the figures in their order, then the record's
    name, condition, payload, equations and (only when known) its sources."""
    from orthoglide_ident.identify.diagnostics import bag_report
    from orthoglide_ident.identify.records.segments import SegmentReport
    from orthoglide_ident.ticks import StepStats

    seg = SegmentReport(period_s=0.001, steps=StepStats(10, 1e-3, 1e-3, 1e-3, 1e-3, 0.0),
                        n_paired=10, n_used=8, reordered=["q12"])
    rep = bag_report(seg, "a.mcap", "loaded", 1.983, [3, 4, 5], "q from /joint_states")
    seg.n_used, seg.reordered[0] = 9, "q13"
    assert rep.n_used == 8 and rep.reordered == ("q12",) and rep.equations_per_joint == (3, 4, 5)
    doc = rep.to_json()
    names = [f.name for f in dataclasses.fields(SegmentReport)]
    assert list(doc) == names + ["bag", "condition", "payload_mass", "equations_per_joint",
                                 "sources"]
    assert doc["steps"] == {"n_steps": 10, "median_s": 1e-3, "mean_s": 1e-3, "p05_s": 1e-3,
                            "p95_s": 1e-3, "off_grid": 0.0}
    assert doc["reordered"] == ["q12"] and doc["equations_per_joint"] == [3, 4, 5]
    assert "sources" not in bag_report(seg, "b.mcap", "unloaded", 0.0, [1, 1, 1]).to_json()


def test_the_solvers_figures_are_typed_and_written_with_the_json_keys():
    from orthoglide_ident.results import SolverInfo

    tls = SolverInfo("per-joint", 0.2, (1.0, 2.0, 3.0), joint_sigma=(0.1,), lambda_scale=2.5)
    assert list(tls.to_json()) == ["tls_noisy_columns", "singular_ratio",
                                   "smallest_singular_values", "joint_sigma", "lambda"]
    assert tls.to_json()["smallest_singular_values"] == [1.0, 2.0, 3.0]
    assert SolverInfo(iv_iterations=4, iv_start="tls per-joint", joint_sigma=(0.1,)).to_json() \
        == {"iv_iterations": 4, "iv_start": "tls per-joint", "joint_sigma": [0.1]}


def test_an_identifications_diagnostics_are_read_by_attribute():
    """After a solve the result's diagnostics, its records' reports and the solver's figures are
    typed; the JSON holds them under today's keys, in today's order."""
    from orthoglide_ident.results import Diagnostics, RecordReport, SolverInfo

    recs = [synthetic_record(20.0, m, seed=s, noise=True, amplitude=0.1, f_max=4.0)
            for m, s in ((0.0, 1), (1.983, 2))]
    res = identify_records(recs, model=SyntheticModel(), essential=True)
    d = res.diagnostics
    assert isinstance(d, Diagnostics) and isinstance(d.solver, SolverInfo)
    assert all(isinstance(b, RecordReport) for b in res.record_reports)
    assert d.samples_used == sum(b.n_used for b in d.bags) and d.solver.singular_ratio < 1
    assert [b.bag for b in d.bags] == [r.source for r in recs]
    assert list(res.to_json()["diagnostics"]) == [
        "samples_used", "samples_dropped", "segments", "rows", "solver", "decimation", "bags",
        "timings_s", "options", "uncertainty", "cross_check_iv"]
    assert res.cross_check and all(c.joint == g.name
                                   for c, g in zip(res.cross_check, res.drive_gains))
    u = res.uncertainty
    assert u.blocks > 0
    assert set(u.autocorrelation) == set(u.gain_sigma_inflation) == set(res.joint_names)
    keys = list(res.to_json()["diagnostics"]["uncertainty"])
    assert keys[:9] == ["method", "blocks", "block_s", "lags", "autocorrelation",
                        "autocorrelation_white", "notes", "slow_ratio", "gain_sigma_inflation"]
    assert keys[-1] == "position_spectrum_peaks"
    ess = res.essential.reduction
    assert ess.steps and ess.method == "keep_gains"
    assert list(res.to_json()["essential"]["diagnostics"]) == [
        "method", "stopped_because", "ratios", "tolerance", "steps"]


def test_the_consistency_report_is_apart_from_the_fit_and_its_direct_dynamics_typed():
    """identify/consistency/report.py formats what fit.py computes; a direct-dynamic
    validation is a typed row whose JSON is today's (no horizon when no window ran)."""
    from orthoglide_ident.identify.consistency import fit, report

    for name in ("to_json", "text_lines", "message_fields", "standard_parameters", "summary"):
        assert name not in vars(fit.ConsistencyResult) and name in vars(report.ConsistencyReport)
    dd = report.DirectDynamics("val", "Pinocchio ABA on the URDF", 3, (
        report.DirectDynamicsJoint("q1", "rad", 1e-4, 0.02, 0.005),), 0.2)
    assert dd.to_json() == {"bag": "val", "engine": "Pinocchio ABA on the URDF", "windows": 3,
                            "horizon_s": 0.2, "joints": [{"joint": "q1", "unit": "rad",
                                                          "rms_error": 1e-4, "drift_rms": 0.02,
                                                          "relative": 0.005}]}
    assert dd.text() == ("  direct dynamics on val (Pinocchio ABA on the URDF, 3 windows of 0.2 s "
                         "from the measured state under the recorded currents): position error "
                         "rms q1 0.0001 rad (0.5 % of the drift)")
    assert report.DirectDynamics("val", "no model", 0).to_json() == {
        "bag": "val", "engine": "no model", "windows": 0, "joints": []}


def test_the_consistent_answers_bodies_and_bounds_are_typed():
    """The sample bags with --consistent: every body of the answer read by attribute, each a
    physical body (mass > 0, the least eigenvalue of its pseudo-inertia ≥ 0); the JSON the same
    rows."""
    from orthoglide_ident.identify import IdentifyOptions, identify
    from orthoglide_ident.identify.consistency.report import BodyConsistency, BodyInertial
    from orthoglide_ident.model.registry import load_robot

    res = identify([ROOT / "bags/unloaded", ROOT / "bags/loaded"], model=load_robot("orthoglide"),
                   options=IdentifyOptions.of(consistent=True))
    c = res.consistency
    bodies, inertials = c.bodies(), c.inertials()
    assert all(isinstance(b, BodyConsistency) and b.min_eigenvalue >= 0 for b in bodies)
    assert all(isinstance(b, BodyInertial) and b.mass > 0 and len(b.inertia) == 6
               for b in inertials)
    doc = res.to_json()
    assert doc["consistency"]["bodies"] == [b.to_json() for b in bodies]
    assert doc["standard_parameters"] == [b.to_json() for b in inertials]
    assert doc["consistency"]["violated_bounds"] == [b.name for b in c.bounds()
                                                     if not b.consistent_unconstrained]
