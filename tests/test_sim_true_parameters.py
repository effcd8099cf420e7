"""True parameter table: complete, physically consistent, overridable from YAML with clear errors."""
from __future__ import annotations

import numpy as np
import pytest

from orthoglide_ident.errors import ConfigError
from orthoglide_sim.true_parameters import PAYLOAD_NAMES, STANDARD_NAMES, load_parameters


def test_every_parameter_present_nonzero_and_consistent():
    tp = load_parameters()
    chi = tp.standard_vector()
    assert chi.shape == (208,) and len(tp.names) == 208
    assert np.all(chi != 0.0)
    assert STANDARD_NAMES[:3] == ("xx_11", "xy_11", "xz_11") and STANDARD_NAMES[10] == "ia_11"
    assert STANDARD_NAMES[-1] == "m_6"
    v = tp.values
    for suffix in [f"{j}{i}" for i in (1, 2, 3) for j in range(1, 6)] + ["6"]:
        I = np.array([[v[f"xx_{suffix}"], v[f"xy_{suffix}"], v[f"xz_{suffix}"]],
                      [v[f"xy_{suffix}"], v[f"yy_{suffix}"], v[f"yz_{suffix}"]],
                      [v[f"xz_{suffix}"], v[f"yz_{suffix}"], v[f"zz_{suffix}"]]])
        m = v[f"m_{suffix}"]
        c = np.array([v[f"mx_{suffix}"], v[f"my_{suffix}"], v[f"mz_{suffix}"]]) / m
        I_G = I - m * (c @ c * np.eye(3) - np.outer(c, c))
        assert m > 0 and np.all(np.linalg.eigvalsh(I_G) > 0), suffix
    assert 8.0 < v["m_11"] + v["ia_11"] + v["m_21"] + v["m_31"] / 2 < 10.5  # ~ m_11R of Table 3
    assert v["m_6"] < 1.0
    assert tp.g_tau != (2001.0,) * 3 and all(abs(g - 637 * np.pi) > 20 for g in tp.g_tau)
    assert tp.payload_vector("1.983")[9] == pytest.approx(1.983)
    assert tp.payload_vector("1.136")[9] == pytest.approx(1.136)
    assert tp.payload_vector(0.5)[9] == pytest.approx(0.5)
    assert np.all(tp.payload_vector("none") == 0) and len(PAYLOAD_NAMES) == 10


def test_yaml_override(tmp_path):
    f = tmp_path / "plant.yaml"
    f.write_text("plant:\n  g_tau: [2200, 2100.5, 2000]\n  parameters:\n    fv_12: 90.0\n"
                 "  payloads:\n    '1.983': {m_7: 2.0}\n  screw_ripple: {enabled: true}\n")
    tp = load_parameters(f)
    assert tp.g_tau == (2200.0, 2100.5, 2000.0)
    assert tp.values["fv_12"] == 90.0
    assert tp.payload_vector("1.983")[9] == 2.0
    assert tp.screw_ripple["enabled"] is True
    assert load_parameters("config/plant.yaml").values["fs_13"] == 24.1


@pytest.mark.parametrize("text, word", [
    ("plant:\n  parameters:\n    fv_99: 1.0\n", "fv_99"),
    ("plant:\n  parameters:\n    fv_11: fast\n", "fv_11"),
    ("plant:\n  gains: [1, 2, 3]\n", "gains"),
    ("plant:\n  g_tau: [1, 2]\n", "g_tau"),
    ("plant: [unclosed\n", "YAML"),
])
def test_bad_yaml_gets_a_clear_error(tmp_path, text, word):
    f = tmp_path / "bad.yaml"
    f.write_text(text)
    with pytest.raises(ConfigError) as exc:
        load_parameters(f)
    msg = str(exc.value)
    assert word in msg and "\n" not in msg


def test_missing_file():
    with pytest.raises(ConfigError, match="cannot read"):
        load_parameters("/nonexistent/plant.yaml")
