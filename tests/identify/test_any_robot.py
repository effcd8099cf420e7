"""The identification takes every size and name from the robot model: a 6-joint revolute robot.

The synthetic model (tests/synthetic.py) with 6 revolute joints goes through the offline pipeline
and the live identification unchanged: nothing in identify/ may assume the Orthoglide's 3 joints,
their names or their units.
"""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from live_helpers import feed, rel_diff, rel_sigma_diff
from synthetic import SyntheticModel, synthetic_record, true_gains

from orthoglide_ident.errors import DataError
from orthoglide_ident.identify import IdentifyOptions, LiveIdentification, Record, identify_records

ARM = SyntheticModel(n_joints=6, kind="revolute")
STRONG = dict(amplitude=0.1, f_max=4.0)
PAPER_DRIVE = IdentifyOptions.of(lag_model="off")


@pytest.fixture(scope="module")
def arm_records() -> list[Record]:
    return [synthetic_record(20.0, 0.0, seed=1, model=ARM, current_noise_a=1e-3, **STRONG),
            synthetic_record(20.0, 2.0, seed=2, model=ARM, current_noise_a=1e-3, **STRONG)]


@pytest.fixture(scope="module")
def arm_result(arm_records):
    return identify_records(arm_records, model=ARM, options=PAPER_DRIVE)


def test_six_joints_identified_with_their_names_and_units(arm_result):
    res = arm_result
    g = np.array([x.value for x in res.drive_gains])
    assert res.joint_names == list(ARM.joint_names) and len(g) == 6
    # 1 mA on ~0.5-1 A: σ of the gains ~0.05-0.1 %; 0.5 % is several σ
    assert np.abs(g / true_gains(6) - 1).max() < 0.005
    assert all(0 < x.rel_std < 0.005 for x in res.drive_gains)
    assert len(res.residual_rms) == 6 and res.robot == "synthetic"
    doc = res.to_json()
    assert doc["units"]["drive_gains"] == "N·m/A" and doc["units"]["residual_rms"] == "N·m"
    assert "drive gains (N·m/A)" in res.to_text()


def test_live_equals_offline_on_six_joints(arm_records, arm_result):
    live = LiveIdentification(PAPER_DRIVE, model=ARM)
    for i, rec in enumerate(arm_records):
        assert feed(live, rec, (1, 37, 250), 3, seed=i) == []
    res = live.result()
    assert max(rel_diff(arm_result, res)) < 1e-6
    assert max(rel_sigma_diff(arm_result, res)) < 1e-6
    est = live.estimate()
    assert est.joint_names == ARM.joint_names and len(est.gains) == 6
    assert est.message_fields()["gain_units"] == ["N·m/A"] * 6


def _reordered(rec: Record, order: list[int], extra: bool) -> Record:
    """The record as a ros2_control broadcaster may publish it: hardware order, a gripper."""
    names = [rec.names_q[k] for k in order]
    q, v = rec.q[:, order], rec.v_tau[:, order]
    if extra:
        names.append("gripper_finger_joint")
        q = np.column_stack([q, np.full(len(q), 0.01)])
        v = np.column_stack([v, np.zeros(len(v))])
    return dataclasses.replace(rec, names_q=tuple(names), q=q, names_v=tuple(names), v_tau=v)


def test_joints_matched_by_name_any_order_extra_joints_ignored(arm_records, arm_result):
    order = [3, 0, 5, 1, 4, 2]
    recs = [_reordered(r, order, extra=True) for r in arm_records]
    res = identify_records(recs, model=ARM, options=PAPER_DRIVE)
    assert max(rel_diff(arm_result, res)) < 1e-12
    live = LiveIdentification(PAPER_DRIVE, model=ARM)
    for rec in recs:
        assert feed(live, rec, (100,)) == []
    assert max(rel_diff(arm_result, live.result())) < 1e-6


def test_a_missing_joint_is_a_one_line_reason(arm_records):
    bad = _reordered(arm_records[1], [0, 1, 2, 3, 4], extra=False)  # joint_6 not recorded
    with pytest.raises(DataError, match=r"lack \['joint_6'\]") as exc:
        identify_records([arm_records[0], bad], model=ARM, options=PAPER_DRIVE)
    assert "\n" not in str(exc.value)
    live = LiveIdentification(PAPER_DRIVE, model=ARM)
    warnings = feed(live, bad, (100,))
    assert any("joint_6" in w and "dropped" in w for w in warnings)


def test_currents_stamped_by_another_publisher_pair_within_half_a_tick(arm_records, arm_result):
    """The current from a controller that stamps with its own now() (0.3 ms late ± 0.15 ms):
    paired by nearest stamp, offline and live, the same identification as shared stamps."""
    rng = np.random.default_rng(5)
    recs = [dataclasses.replace(r, stamps_v_ns=r.stamps_v_ns + 300_000
                                + rng.integers(-150_000, 150_000, len(r.stamps_v_ns)))
            for r in arm_records]
    res = identify_records(recs, model=ARM, options=PAPER_DRIVE)
    assert max(rel_diff(arm_result, res)) < 1e-12
    live = LiveIdentification(PAPER_DRIVE, model=ARM)
    for i, rec in enumerate(recs):
        assert feed(live, rec, (1, 37, 250), 3, seed=i) == []
    assert max(rel_diff(arm_result, live.result())) < 1e-6
