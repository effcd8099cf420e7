"""Behind a transmission (the UR5 with the issue-33 coupled wrist, 10 s + 10 s inverse-model
records): the JSON's ``residual_rms_per_joint`` is joint-side (Nᵀ ε) with the motors'
``residual_rms_per_actuator`` beside it (DESIGN §10), and a reduction row typed wrong
([0,0,0,0,0,32] for [0,0,0,0,32,32]) is said as such, not as a need for a longer record."""
from __future__ import annotations

import numpy as np
import pytest
from coupled_records import MOTORS, N, coupled_records, robot_file

from orthoglide_ident.identify import IdentifyOptions, identify_records
from orthoglide_ident.identify.records.record import motor_side
from orthoglide_ident.model.registry import load_robot

UR5_JOINTS = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint",
              "wrist_2_joint", "wrist_3_joint"]


@pytest.fixture(scope="module")
def records():
    return coupled_records(10.0)


def _identify(records, tmp_path, reduction, stem, options=None):
    model = load_robot(robot_file(tmp_path, reduction, stem))
    return identify_records([motor_side(r, model) for r in records], model=model, options=options)


def test_the_residual_per_joint_is_joint_side(records, tmp_path):
    doc = _identify(records, tmp_path, N, "right").to_json()
    motor = np.array(doc["residual_rms_per_actuator"])
    joint = np.array(doc["residual_rms_per_joint"])
    assert doc["joint_names"] == list(MOTORS) and doc["residual_joint_names"] == UR5_JOINTS
    # the motors' residuals are their independent white current noise (filtered alike), so
    # each joint's is the quadrature sum through τ_j = Nᵀ τ_m: sqrt(Σ_a N_aj² ε_a²)
    expected = np.sqrt((N ** 2).T @ motor ** 2)
    assert np.allclose(joint, expected, rtol=0.1), joint / expected
    assert np.all(joint > 25 * motor)  # gears of 32 ... 48: joint side is not motor side


def test_a_reduction_row_typed_wrong_is_said(records, tmp_path):
    wrong = N.copy()
    wrong[5, 4] = 0.0  # motor 6 turns with q6 only, not q5 + q6
    # the paper's TLS answers m5 and leaves its misfit to be said; the per-joint default leaves
    # m5 and m6 out (not determined, with their reasons): no wrong gain either way
    paper = IdentifyOptions.of(tls_noisy_columns="all", cross_check="none")
    res = _identify(records, tmp_path, wrong, "wrong", paper)
    said = [w for w in res.warnings if w.startswith("the residual of m5 is") and "times" in w]
    assert said and "transmission" in said[0]
    assert not any("record longer" in g.reason for g in res.drive_gains if not g.determined)
    assert not any("record longer" in w for w in res.warnings)
    default = _identify(records, tmp_path, wrong, "wrong_default")
    assert not any(g.determined for g in default.drive_gains if g.name in ("m5", "m6"))


def test_the_right_reduction_says_nothing_of_it(records, tmp_path):
    res = _identify(records, tmp_path, N, "right_again")
    assert not [w for w in res.warnings if "transmission's reduction" in w]


@pytest.mark.parametrize("method", ["tls", "wls"])
def test_a_motor_side_record_beside_a_joint_side_one_is_said(records, tmp_path, method):
    """The loaded record's hardware published its motors' encoders under the joints' names
    (untagged): read as joint-side, mapped through N a second time. Before: TLS "the loaded
    records do not excite the payload mass" or "no drive gain is determined", WLS an answer
    with a payload of -0.61 kg."""
    import dataclasses

    from orthoglide_ident.errors import DataError

    unloaded, loaded = records
    motors = dataclasses.replace(loaded, source="loaded_motor_encoders", q=loaded.q @ N.T)
    model = load_robot(robot_file(tmp_path, N, f"chain_{method}"))
    with pytest.raises(DataError) as err:
        identify_records([motor_side(r, model) for r in (unloaded, motors)], model=model,
                         method=method)
    msg = str(err.value)
    assert msg.startswith("loaded_motor_encoders:") and "motor-side" in msg
    assert "drive chain" in msg and "position_side" in msg and "degrees" not in msg
