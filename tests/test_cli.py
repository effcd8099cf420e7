"""orthoglide-ident: success paths on model-consistent bags, bad input as one-line reasons."""
from __future__ import annotations

import json

import numpy as np
import pytest
from synthetic import synthetic_record

from orthoglide_ident import bags
from orthoglide_ident.cli import main, parse_gains
from orthoglide_ident.errors import ConfigError
from orthoglide_ident.model.registry import load_robot

ORTHOGLIDE = load_robot("orthoglide")  # the robot these records are of


def _one_line_error(capsys, code, match=None):
    out, err = capsys.readouterr()
    assert code == 2
    lines = err.strip().splitlines()
    assert lines and lines[-1].startswith("orthoglide-ident: error: ")
    assert "Traceback" not in err
    if match:
        assert match in lines[-1]
    return lines[-1]


@pytest.fixture(scope="module")
def model_bags(tmp_path_factory):
    """Noise-free bags of the Orthoglide base model with the simulator's true parameters."""
    from orthoglide_ident.model.orthoglide.base import base_model
    from orthoglide_sim.orthoglide import truth as true_parameters

    bm = base_model()
    tp = true_parameters.default_parameters()
    chi = bm.base_values(tp.standard_vector())
    g = np.array(tp.g_tau)
    d = tmp_path_factory.mktemp("bags")
    out = {}
    for name, m, seed in (("unloaded", 0.0, 1), ("loaded", 1.983, 2), ("check", 1.983, 3)):
        r = synthetic_record(15, m, seed=seed, noise=False, model=bm, chi=chi, g_tau=g,
                             amplitude=0.13, f_max=3.5)
        out[name] = str(bags.write_bag(d / name, r.stamps_q_ns, r.q, r.v_tau, r.condition, m,
                                       joint_names=ORTHOGLIDE.joint_names))
    out["g"] = g
    return out


def test_identify_prints_a_table_and_writes_json(model_bags, tmp_path, capsys):
    js = tmp_path / "r.json"
    code = main(["identify", model_bags["unloaded"], model_bags["loaded"], "--json", str(js),
                 "--validate", model_bags["check"]])
    out, err = capsys.readouterr()
    assert code == 0, err
    assert "g_tau q11" in out and "m_6R" in out
    doc = json.loads(js.read_text())
    g = np.array([x["value"] for x in doc["drive_gains"]])
    assert np.abs(g / model_bags["g"] - 1).max() < 1e-3
    assert doc["payload_mass"]["value"] == 1.983 and doc["bags"] == [model_bags["unloaded"],
                                                                    model_bags["loaded"]]
    assert "reading" in err  # progress on stderr
    # WLS with the gains just identified, from the JSON file
    code = main(["identify", model_bags["unloaded"], model_bags["loaded"], "--method", "wls",
                 "--gains", str(js), "-q"])
    out, err = capsys.readouterr()
    assert code == 0, err
    assert "estimated" in out


def test_report_writes_plots_and_summary(model_bags, tmp_path, capsys):
    code = main(["report", model_bags["unloaded"], model_bags["loaded"], "--out",
                 str(tmp_path / "rep"), "-q"])
    capsys.readouterr()
    assert code == 0
    for f in ("torques.png", "parameters.png", "summary.md", "result.json"):
        assert (tmp_path / "rep" / f).stat().st_size > 0


def test_bad_inputs_exit_2_with_one_line(model_bags, tmp_path, capsys):
    u, lo = model_bags["unloaded"], model_bags["loaded"]
    _one_line_error(capsys, main(["identify", str(tmp_path / "nope")]))
    _one_line_error(capsys, main(["identify", u, "-q"]), "loaded")
    _one_line_error(capsys, main(["identify", u, lo, "--payload-mass", "1.136", "-q"]),
                    "tagged with a payload of 1.983 kg")
    _one_line_error(capsys, main(["identify", u, lo, "--payload-mass", "-1", "-q"]), "positive")
    _one_line_error(capsys, main(["identify", u, lo, "--method", "wls", "--gains", "1,2", "-q"]))
    _one_line_error(capsys, main(["identify", u, lo, "--gains", "2000,2000,2000", "-q"]), "wls")
    _one_line_error(capsys, main(["identify", u, lo, "--r-sigma", "0.5", "-q"]), "r-sigma")
    cfg = tmp_path / "bad.yaml"
    cfg.write_text("decimation: [1\n")
    _one_line_error(capsys, main(["identify", u, lo, "--config", str(cfg), "-q"]), "YAML")
    notbag = tmp_path / "x.mcap"
    notbag.write_text("hello")
    _one_line_error(capsys, main(["identify", str(notbag), lo, "-q"]))
    _one_line_error(capsys, main(["info", str(tmp_path / "nope")]))


def test_nan_and_unexciting_bags(tmp_path, capsys):
    r = synthetic_record(5, 0.0, seed=1)
    v = r.v_tau.copy()
    v[100, 0] = np.nan
    nan = bags.write_bag(tmp_path / "nan", r.stamps_q_ns, r.q, v, "unloaded", 0.0,
                         joint_names=ORTHOGLIDE.joint_names)
    r2 = synthetic_record(5, 1.983, seed=2, amplitude=0.002, f_max=0.3)
    still = bags.write_bag(tmp_path / "still", r2.stamps_q_ns, r2.q, r2.v_tau, "loaded", 1.983,
                           joint_names=ORTHOGLIDE.joint_names)
    _one_line_error(capsys, main(["identify", str(nan), str(still), "-q"]), "NaN")


def test_info_model_and_help(model_bags, tmp_path, capsys):
    assert main(["info", model_bags["loaded"]]) == 0
    out, _ = capsys.readouterr()
    assert "joint_states" in out
    js = tmp_path / "model.json"
    assert main(["model", "--base-parameters", "--json", str(js)]) == 0
    out, _ = capsys.readouterr()
    assert "m_6R" in out and json.loads(js.read_text())["parameters"]
    for cmd in ("identify", "report", "info", "model"):
        with pytest.raises(SystemExit) as exc:
            main([cmd, "--help"])
        assert exc.value.code == 0
    out, _ = capsys.readouterr()
    assert "N/A" in out and "kg" in out


def test_parse_gains(tmp_path):
    assert parse_gains("2170,2100,2070", joints=ORTHOGLIDE.joint_names) == [2170.0, 2100.0, 2070.0]
    f = tmp_path / "g.json"
    f.write_text(json.dumps({"drive_gains": [{"joint": "q11", "value": 1.0},
                                             {"joint": "q12", "value": 2.0},
                                             {"joint": "q13", "value": 3.0}]}))
    assert parse_gains(str(f), joints=ORTHOGLIDE.joint_names) == [1.0, 2.0, 3.0]
    f.write_text(json.dumps({"q11": 1, "q12": 2, "q13": 3}))
    assert parse_gains(str(f), joints=ORTHOGLIDE.joint_names) == [1.0, 2.0, 3.0]
    for bad in ("1,2", "a,b,c", "1,-2,3", str(tmp_path / "missing.json")):
        with pytest.raises(ConfigError):
            parse_gains(bad, joints=ORTHOGLIDE.joint_names)
