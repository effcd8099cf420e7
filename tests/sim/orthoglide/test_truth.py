"""True parameter table: complete, physically consistent, overridable from YAML with clear
errors."""

from __future__ import annotations

import numpy as np
import pytest

from orthoglide_ident.errors import ConfigError
from orthoglide_sim.orthoglide.truth import PAYLOAD_NAMES, PROFILES, STANDARD_NAMES, load_parameters


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
                 "  payloads:\n    '1.983': {m_7: 2.0}\n  profile: rig\n"
                 "  profiles:\n    rig: {current_lag: 1.5e-4, screw_ripple: {amplitude: 0.02}}\n"
                 "    realistic: {stribeck: {breakaway: 0.25}}\n")
    tp = load_parameters(f)
    assert tp.g_tau == (2200.0, 2100.5, 2000.0)
    assert tp.values["fv_12"] == 90.0
    assert tp.payload_vector("1.983")[9] == 2.0
    rig = tp.plant_profile()  # the YAML's default profile
    assert rig.name == "rig" and rig.current_lag_s == 1.5e-4 and rig.ripple_amplitude == 0.02
    assert rig.stribeck_breakaway == 0.0 and rig.current_noise_std == 1e-3  # the rest: nominal
    real = tp.plant_profile("realistic")  # overridden key by key, the rest kept
    assert real.stribeck_breakaway == 0.25 and real.current_lag_s == 1.2e-4
    shipped = load_parameters("config/plant.yaml")
    assert shipped.values["fs_13"] == 24.1
    assert (
        shipped.profile == "nominal" and shipped.plant_profile("realistic") == PROFILES["realistic"]
    )
    assert shipped.plant_profile("nominal") == PROFILES["nominal"]


def test_profiles_default_and_realistic():
    tp = load_parameters()
    nominal = tp.plant_profile()
    assert nominal.name == "nominal" and not nominal.unmodelled
    real = tp.plant_profile("realistic")
    assert 1.0e-4 <= real.current_lag_s <= 1.5e-4 and 0.2 <= real.stribeck_breakaway <= 0.4
    assert 0.01 <= real.ripple_amplitude <= 0.02 and real.ripple_lead == 0.01
    assert real.current_noise_std == 2 * nominal.current_noise_std
    assert len(real.unmodelled) == 3
    with pytest.raises(ConfigError, match="unknown plant profile 'rough'"):
        tp.plant_profile("rough")


@pytest.mark.parametrize("text, word", [
    ("plant:\n  parameters:\n    fv_99: 1.0\n", "fv_99"),
    ("plant:\n  parameters:\n    fv_11: fast\n", "fv_11"),
    ("plant:\n  gains: [1, 2, 3]\n", "gains"),
    ("plant:\n  g_tau: [1, 2]\n", "g_tau"),
    ("plant: [unclosed\n", "YAML"),
    ("plant:\n  profiles:\n    realistic: {current_lag: -1.0e-4}\n", "current_lag"),
    ("plant:\n  profiles:\n    realistic: {current_lag: slow}\n", "current_lag"),
    ("plant:\n  profiles:\n    realistic: {stribeck: {breakaway: 0.3, width: 1}}\n", "width"),
    ("plant:\n  profiles:\n    realistic: {screw_ripple: {lead: 0}}\n", "lead"),
    ("plant:\n  profiles:\n    realistic: {gain_ripple: 1}\n", "gain_ripple"),
    ("plant:\n  profile: rough\n", "rough"),
    ("plant:\n  screw_ripple: {enabled: true}\n", "profiles"),
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
