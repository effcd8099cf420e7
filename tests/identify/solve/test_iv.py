"""IDIM-IV (identify/solve/iv.py, iv_answer.py) and TLS's bias under per-joint current noise
(issue 43): a 7-axis Panda whose records come from Pinocchio's RNEA (tests/panda_arm.py, not the
product's regressor), the distal drive gains small, 1 % current noise on every joint. The truth
is the generator's gains; the paper's TLS puts joints 5-7 several of its σ from them."""
from __future__ import annotations

import numpy as np
import panda_arm as P
import pytest
from synthetic import TRUE_GAINS, SyntheticModel, synthetic_record

from orthoglide_ident.cli import build_parser
from orthoglide_ident.errors import ConfigError, IdentificationError
from orthoglide_ident.identify import IdentifyOptions, identify_records
from orthoglide_ident.identify.solve import methods
from orthoglide_ident.identify.solve.factors import RecordFactors
from orthoglide_ident.identify.solve.iv import observations_of
from orthoglide_ident.model.registry import load_robot

SECONDS, NOISE = 20.0, 0.01


@pytest.fixture(scope="module")
def panda():
    return load_robot(str(P.URDF)), P.records(SECONDS, NOISE, seed=0)


def _z(res, truth):
    g = np.array([x.value for x in res.drive_gains])
    return (g / truth - 1) / np.array([x.rel_std for x in res.drive_gains])


def test_the_methods_table_lists_iv():
    m = methods.get("iv")
    assert not m.gains_given and "drive_gains" in m.result_fields
    args = build_parser().parse_args(["identify", "b1", "b2", "--method", "iv"])
    assert args.method == "iv"
    args = build_parser().parse_args(["identify", "b1", "b2", "--cross-check", "none"])
    assert args.cross_check == "none"
    with pytest.raises(ConfigError, match="cross_check must be 'iv' or 'none'"):
        IdentifyOptions.of(cross_check="hausman").validate()


def test_iv_recovers_the_gains_where_the_papers_tls_is_biased(panda):
    model, recs = panda
    tls = identify_records(recs, model=model, options=IdentifyOptions.of(
        tls_noisy_columns="all", cross_check="none"))  # the paper's TLS
    assert np.max(np.abs(_z(tls, P.GAINS))) > 4  # the bias: joint 7 at about -5.7 σ
    iv = identify_records(recs, model=model, method="iv")
    assert iv.method == "iv" and iv.complete
    z = _z(iv, P.GAINS)
    assert np.all(np.abs(z) < 3), z
    rel = np.array([x.rel_std for x in iv.drive_gains])
    assert np.all(rel < 0.005)  # a real answer, not a wide error bar


def test_per_joint_tls_removes_the_bias(panda):
    model, recs = panda
    res = identify_records(recs, model=model, options=IdentifyOptions.of(cross_check="none"))
    assert res.diagnostics.solver.tls_noisy_columns == "per-joint"  # the default
    assert np.all(np.abs(_z(res, P.GAINS)) < 3)


def test_the_cross_check_marks_the_biased_tls_gains(panda):
    model, recs = panda
    # the paper's TLS, cross-checked by IV (the default cross-check)
    res = identify_records(recs, model=model, options=IdentifyOptions.of(tls_noisy_columns="all"))
    marked = [g for g in res.drive_gains if not g.determined]
    assert marked and all("IDIM-IV" in g.reason for g in marked)
    assert any(w.startswith("TLS cross-checked by IV") for w in res.warnings)
    z = _z(res, P.GAINS)
    determined = np.array([g.determined for g in res.drive_gains])
    assert np.all(np.abs(z[determined]) < 3), z  # every gain still marked determined is honest
    assert len(res.cross_check) == 7


def test_the_cross_check_is_silent_on_a_clean_record():
    recs = [synthetic_record(20.0, 0.0, seed=1, amplitude=0.1, f_max=4.0),
            synthetic_record(20.0, 1.983, seed=2, amplitude=0.1, f_max=4.0)]
    res = identify_records(recs, model=SyntheticModel())
    assert res.complete and not any("cross-checked" in w for w in res.warnings)
    assert all(c.sigmas < 3 for c in res.cross_check)
    assert np.all(np.abs(_z(res, TRUE_GAINS)) < 3)


def test_iv_says_why_without_the_rows():
    f = RecordFactors("loaded", 1.0, 3, n_joints=3)
    with pytest.raises(IdentificationError, match="decimated rows"):
        observations_of([f])


def test_the_cli_identifies_by_iv_from_bags(panda, tmp_path):
    import json

    from orthoglide_ident.bags.writer import write_bag
    from orthoglide_ident.cli import main

    _, recs = panda
    bags = [str(write_bag(tmp_path / r.condition, r.stamps_q_ns, r.q, r.v_tau, r.condition,
                          r.payload_mass, P.JOINTS)) for r in recs]
    out = tmp_path / "iv.json"
    assert main(["identify", "--robot", str(P.URDF), *bags, "--method", "iv", "--json",
                 str(out), "-q"]) == 0
    doc = json.loads(out.read_text())
    assert doc["method"] == "iv" and all(g["determined"] for g in doc["drive_gains"])
    g = np.array([x["value"] for x in doc["drive_gains"]])
    rel = np.array([x["rel_std"] for x in doc["drive_gains"]])
    assert np.all(np.abs(g / P.GAINS - 1) < 3 * rel)
