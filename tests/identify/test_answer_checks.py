"""Every answer checked against the question (issue 32): no gain band without nominal gains,
static records refused in one line, strict JSON, --essential with WLS on unloaded records,
duplicate records counted once, negative friction and a WLS payload far from its tag said."""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from orthoglide_ident import bags
from orthoglide_ident.cli import main
from orthoglide_ident.errors import ConfigError, ExcitationError
from orthoglide_ident.identify import IdentifyOptions, identify, identify_records, read_record
from orthoglide_ident.identify.solve.tls import ExcitationLimits, gain_band_warnings
from orthoglide_ident.model.registry import ROBOTS_DIR, load_robot
from orthoglide_ident.results import json_text

REPO = Path(__file__).resolve().parents[2]
SAMPLE = [str(REPO / "bags" / "unloaded"), str(REPO / "bags" / "loaded")]
ORTHOGLIDE = load_robot("orthoglide")  # the sample bags' robot


def _static_bag(path: Path, condition: str = "unloaded", mass: float = 0.0) -> str:
    """The Orthoglide holding still for 20 s: encoder and current noise only."""
    rng = np.random.default_rng(0)
    n = 20000
    t = 1_700_000_000_000_000_000 + np.arange(n, dtype=np.int64) * 1_000_000
    q = np.array([0.01, -0.02, 0.03]) + 1e-7 * rng.standard_normal((n, 3))
    v = np.array([0.1, 0.2, 0.05]) + 1e-3 * rng.standard_normal((n, 3))
    return str(bags.write_bag(path, t, q, v, condition, mass, ORTHOGLIDE.joint_names))


# --- nominal gains optional ---------------------------------------------------------------
def test_a_bare_urdf_gives_no_nominal_gains_and_no_band():
    urdf = load_robot(ROBOTS_DIR / "ur5.urdf")
    yaml = load_robot("ur5")
    assert not urdf.nominal_gains_given and yaml.nominal_gains_given
    opts = IdentifyOptions()
    assert opts.solve.limits(urdf.nominal_gains, False).gain_range is None
    lo, hi = opts.solve.limits(yaml.nominal_gains, True).gain_range
    assert np.allclose(lo * 100, hi)


def test_a_gain_outside_the_nominal_band_is_a_warning_the_users_bounds_an_error():
    names = ("a", "b")
    band = IdentifyOptions().solve.limits([1.0, 1.0], True)
    w = gain_band_warnings(np.array([24.9, 1.1]), band, names)
    assert len(w) == 1 and w[0].startswith("identified drive gain of a 24.9 is outside")
    assert gain_band_warnings(np.array([24.9, 1.1]), ExcitationLimits(gain_range=None), names) == []
    own = IdentifyOptions.of(gain_max=10.0).solve.limits([1.0, 1.0], False)
    with pytest.raises(ExcitationError, match="gain_min, gain_max"):
        gain_band_warnings(np.array([24.9, 1.1]), own, names)


# --- static records, strict JSON, --essential with WLS ---------------------------------------
def test_a_static_record_is_refused_in_one_line(tmp_path):
    still = _static_bag(tmp_path / "still")
    with pytest.raises(ExcitationError, match=r"bag .*still: the robot hardly moves"):
        identify([still, SAMPLE[1]], model=ORTHOGLIDE)
    with pytest.raises(ExcitationError, match=r"validation bag .*still: the robot hardly moves"):
        identify(SAMPLE, validation_bags=[still], model=ORTHOGLIDE)


def test_validate_on_a_static_record_exits_2_and_json_is_strict(tmp_path, capsys):
    still = _static_bag(tmp_path / "still")
    out = tmp_path / "r.json"
    code = main(["identify", "-q", *SAMPLE, "--validate", still, "--json", str(out)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and err[-1].startswith("orthoglide-ident: error: validation bag")
    assert "nan" not in err[-1]


def test_a_joint_that_does_not_move_in_a_validation_record_is_a_note(tmp_path):
    rec = read_record(SAMPLE[0], ORTHOGLIDE)
    q = rec.q.copy()
    q[:, 2] = q[0, 2]  # q13 holds still
    path = bags.write_bag(tmp_path / "half", rec.stamps_q_ns, q, rec.v_tau, "unloaded", 0.0,
                          ORTHOGLIDE.joint_names)
    res = identify(SAMPLE, validation_bags=[str(path)], model=ORTHOGLIDE)
    j = res.validation[0].joints
    assert j[2].residual_rms is None and j[2].note.startswith("hardly moves")
    assert j[0].residual_rms > 0 and j[0].note == ""
    assert "q13 - (hardly moves" in res.to_text()
    json.loads(json_text(res.to_json()))  # strict: no NaN token


def test_json_text_is_strict():
    doc = {"a": math.nan, "b": [1.0, math.inf, np.float64("nan")], "c": np.array([1.0, np.nan])}
    text = json_text(doc)
    assert "NaN" not in text and "Infinity" not in text
    assert json.loads(text) == {"a": None, "b": [1.0, None, None], "c": [1.0, None]}


def test_essential_works_with_wls_on_unloaded_records_only():
    res = identify(SAMPLE[:1], method="wls", essential=True, model=ORTHOGLIDE)
    assert res.essential is not None and res.payload_mass is None
    assert 0 < len(res.essential.parameters) < len(res.parameters)


# --- duplicates, friction sign, WLS payload vs its tag ---------------------------------------
def test_the_same_record_twice_is_counted_once(tmp_path):
    import shutil

    copy = shutil.copytree(SAMPLE[1], tmp_path / "copy")
    once = identify(SAMPLE, model=ORTHOGLIDE)
    thrice = identify([*SAMPLE, SAMPLE[1], str(copy)], model=ORTHOGLIDE)
    assert [g.value for g in thrice.drive_gains] == [g.value for g in once.drive_gains]
    assert thrice.bags == SAMPLE
    said = [w for w in thrice.warnings if "is the same record as" in w]
    assert len(said) == 2 and said[1].startswith(f"{copy} is the same record as {SAMPLE[1]}")


def test_a_reversed_current_makes_negative_friction_and_is_said():
    recs = [read_record(p, ORTHOGLIDE) for p in SAMPLE]
    for r in recs:  # q12's current recorded with the opposite sign (a reversed motor)
        r.v_tau = r.v_tau.copy()
        r.v_tau[:, 1] *= -1
    res = identify_records(recs, method="wls", model=ORTHOGLIDE)
    said = [w for w in res.warnings if "negative friction coefficient" in w]
    assert said and all(w.split()[0].endswith("_12") for w in said)
    clean = identify(SAMPLE, method="wls", model=ORTHOGLIDE)
    assert not [w for w in clean.warnings if "negative friction" in w]


def test_a_wls_payload_far_from_its_tag_is_a_warning():
    res = identify(SAMPLE, method="wls", gains=[200.1, 200.1, 200.1],  # 10x too small
                   model=ORTHOGLIDE)
    said = [w for w in res.warnings if w.startswith("payload mass estimated")]
    assert len(said) == 1 and "tagged 1.983 kg" in said[0] and "gains given" in said[0]
    assert not [w for w in identify(SAMPLE, method="wls", model=ORTHOGLIDE).warnings
                if w.startswith("payload mass estimated")]  # -4 %: 2001 N/A's known bias


# --- errors name the file that is wrong -----------------------------------------------------
def test_a_robot_yaml_typo_names_the_yaml(tmp_path):
    text = (ROBOTS_DIR / "ur5.yaml").read_text().replace("actuated_joints:", "actuated_joint:")
    text = text.replace("description: ur5.urdf", f"description: {ROBOTS_DIR / 'ur5.urdf'}")
    bad = tmp_path / "my_ur5.yaml"
    bad.write_text(text)
    with pytest.raises(ConfigError) as exc:
        load_robot(bad)
    assert str(exc.value).startswith(f"robot file {bad}: unknown keys ['actuated_joint']")
