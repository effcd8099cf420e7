"""The identification of a closed-chain robot on its independent plant (MuJoCo): the five-bar.

The product's general model (``--robot five_bar``: Pinocchio's regressors projected through
the point loop at the tip, friction on the passive elbows) identifies the drive gains of the
simulated five-bar (orthoglide_sim.chain_*: MuJoCo loading the same URDF with its own true
inertials, the loop an equality constraint, armature on the motors, damping, frictionloss and
offsets on every joint, true gains 2.7 and 3.8 % above nominal, 0.5 % current noise, 2^19-count
encoders) from an unloaded record and one with the 1 kg off-centre payload at the tip, whose
mass, centre of mass and inertia enter the TLS as the known columns; the 0.5 kg payload is then
re-estimated by WLS with the identified gains.
"""
from __future__ import annotations

import json

import numpy as np
import pytest
from live_helpers import as_record, live_result

from orthoglide_ident.cli import main as cli_main
from orthoglide_ident.identify import IdentifyOptions, Record, identify_records
from orthoglide_ident.model.registry import load_robot
from orthoglide_ident.model.robot import Payload
from orthoglide_sim.arm_or_chain.bags import main as bags_main
from orthoglide_sim.chains.description import load_chain
from orthoglide_sim.chains.record import simulate_chain
from orthoglide_sim.chains.truth import default_chain_truth


def gain_errors(result, truth) -> tuple[np.ndarray, np.ndarray]:
    """(relative error, relative σ) of the identified gains against the plant's."""
    g = np.array([x.value for x in result.drive_gains])
    g_true = np.array([truth.drives[j].g_tau for j in result.joint_names])
    return g / g_true - 1, np.array([x.rel_std for x in result.drive_gains])


@pytest.fixture(scope="module")
def five_bar():
    runs = {"unloaded": simulate_chain(20.0, payload=None, trajectory="exciting1", seed=0),
            "1kg": simulate_chain(20.0, payload="1.0", trajectory="exciting2", seed=1),
            "0.5kg": simulate_chain(20.0, payload="0.5", trajectory="exciting1", seed=2)}
    return (
        load_robot("five_bar"),
        {k: as_record(v, k) for k, v in runs.items()},
        runs["unloaded"].truth,
    )


@pytest.fixture(scope="module")
def tls(five_bar):
    model, recs, _ = five_bar
    return identify_records([recs["unloaded"], recs["1kg"]], model=model)


def test_five_bar_gains_within_a_tenth_of_a_percent_and_three_honest_sigma(five_bar, tls):
    """20 s + 20 s: σ 0.009-0.010 % measured (errors 0.004 and -0.014 %; 3 seeds in
    bench/closed_chain.py: |error| <= 1.5 σ). The bar, 0.1 %, is 10 σ (noise cannot fail it), a
    tenth of the issue's 1 % and a thirtieth of the nominal gains' offset: a plant-model mismatch
    of the size the UR5 shows (0.05-0.5 %) would fail it."""
    model, _, truth = five_bar
    err, sigma = gain_errors(tls, truth)
    print("gain errors (%):", np.round(100 * err, 4), "σ (%):", np.round(100 * sigma, 4))
    assert np.abs(err).max() < 0.001, err
    assert np.all(np.abs(err) <= 3 * sigma), err / sigma
    assert np.all(np.abs(model.nominal_gains / truth.drive_array("g_tau") - 1) > 0.02)
    assert tls.robot == "five_bar" and tls.joint_names == ["joint_1", "joint_2"]
    # The excitation's margin: the TLS refuses s_c/s_c-1 > 0.5 (its noise direction too close to
    # the weakest parameter direction, here the passive elbows' offsets). 0.36-0.37 measured
    # over seeds with the ±0.6 rad box; a ±0.5 rad box gave 0.50.
    assert tls.diagnostics.solver.singular_ratio < 0.45


def test_five_bar_second_payload_by_wls_with_the_identified_gains(five_bar, tls):
    """0.5 kg re-estimated to 0.02 % (σ 0.009 %) with the identified gains; the nominal ones,
    both below the true gains, make it 3.2 % light."""
    model, recs, _ = five_bar
    gains = [x.value for x in tls.drive_gains]
    wls = identify_records(
        [recs["unloaded"], recs["0.5kg"]], method="wls", gains=gains, model=model
    )
    assert abs(wls.payload_mass.value / 0.5 - 1) < 0.002
    nominal = identify_records([recs["unloaded"], recs["0.5kg"]], method="wls", model=model)
    assert abs(nominal.payload_mass.value / 0.5 - 1) > 0.02


def test_the_payload_shape_matters(five_bar, tls):
    """The same 1 kg as a point mass at the tip: its known columns miss the 2.5 cm offset of
    its centre of mass and its inertia, and the gains move by 8 % (exact shape: 0.014 %)."""
    model, recs, truth = five_bar
    point = Record(**{**vars(recs["1kg"]), "payload": Payload(1.0, "tip")})
    wrong = identify_records([recs["unloaded"], point], model=model,
                             options=IdentifyOptions.of(check_excitation=False))
    e_exact = np.abs(gain_errors(tls, truth)[0]).max()
    e_point = np.abs(gain_errors(wrong, truth)[0]).max()
    print(f"gain error: exact payload {100 * e_exact:.4f} %, point mass {100 * e_point:.3f} %")
    assert e_point > 10 * e_exact and e_point > 0.005


def test_live_equals_offline_on_the_closed_chain(five_bar):
    """The live identification of the closed chain (the loop solved per tick inside the model,
    batches of 500 ticks, the payload's shape as the recorder's status carries it) folds the
    same equations as offline: the same answer to 1e-6."""
    from live_helpers import rel_diff

    model, recs, _ = five_bar
    opts = IdentifyOptions.of(lag_model="off")
    records = [recs["unloaded"], recs["1kg"]]
    offline = identify_records(records, model=model, options=opts)
    result = live_result(model, records, opts)
    assert result.joint_names == offline.joint_names
    assert max(rel_diff(offline, result)) < 1e-6


@pytest.mark.slow
def test_five_bar_60_s_bags_through_the_cli(tmp_path, capsys):
    """The issue's figure: ``orthoglide-ident identify --robot five_bar`` on the 60 s unloaded
    and 1 kg bags: every gain within 1 % of the plant's and 3 honest σ (measured: 0.0027 and
    -0.0050 %, σ 0.0045 and 0.0059 %); the 0.5 kg bag by WLS with those gains within 0.2 %
    (measured 0.49998 kg)."""
    assert bags_main(["--robot", "five_bar", "--duration", "60", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert out.count("0 saturated ticks") == 3
    tls_json = tmp_path / "tls.json"
    assert cli_main(["identify", "--robot", "five_bar", str(tmp_path / "unloaded"),
                     str(tmp_path / "loaded_1kg"), "--json", str(tls_json)]) == 0
    doc = json.loads(tls_json.read_text())
    truth = default_chain_truth(load_chain("five_bar"))
    assert [g["joint"] for g in doc["drive_gains"]] == ["joint_1", "joint_2"]
    for g in doc["drive_gains"]:
        joint, err = g["joint"], g["value"] / truth.drives[g["joint"]].g_tau - 1
        print(f"{joint}: error {100 * err:.4f} %, σ {100 * g['rel_std']:.4f} %")
        assert abs(err) < 0.01 and abs(err) <= 3 * g["rel_std"], (joint, err, g)
    wls_json = tmp_path / "wls.json"
    assert cli_main(["identify", "--robot", "five_bar", "--method", "wls", "--gains", str(tls_json),
                     str(tmp_path / "unloaded"), str(tmp_path / "loaded_0.5kg"),
                     "--json", str(wls_json)]) == 0
    mass = json.loads(wls_json.read_text())["payload_mass"]
    print("WLS 0.5 kg:", mass)
    assert abs(mass["value"] / 0.5 - 1) < 0.002


def test_a_transmission_on_the_closed_chain_gives_the_motors_gains(five_bar, tls, tmp_path):
    """The five-bar's base motors behind gears of 10 and −12 (robot YAML ``transmission``; the
    second motor turns the other way, so its current has the other sign): identified in
    actuator space (the loop solved on the joint side, the rows through N⁻ᵀ), each motor's gain
    times |n| is the joint-side gain within one σ of it, and its friction times n² (fs: |n|) the
    joint's within two (measured: 0.48 and 0.14 σ on the gains, 4e-5 and 1.4e-5 relative, fv_1
    1.2 σ, with the
    solvers in joint-side units (identify/joint_units.py), which make a serial arm's two
    descriptions agree to 1e-12; on the closed chain a difference of that size is left,
    not yet explained; it meets the plant's gains as the joint-side answer does); the CTC
    feed-forward through N is the joint-side one's."""
    import dataclasses

    import yaml

    from orthoglide_ident.control import CTCParameters, feedforward_currents
    from orthoglide_ident.identify.records.record import motor_side
    from orthoglide_ident.model.registry import ROBOTS_DIR

    model, recs, truth = five_bar
    n = np.array([10.0, -12.0])
    data = yaml.safe_load((ROBOTS_DIR / "five_bar.yaml").read_text())
    data.update(description=str(ROBOTS_DIR / "five_bar.urdf"), nominal_gains=[0.05, 0.05],
                transmission={"actuators": ["ma", "mb"], "reduction": np.diag(n).tolist()})
    (tmp_path / "five_bar_geared.yaml").write_text(yaml.safe_dump(data))
    geared = load_robot(str(tmp_path / "five_bar_geared.yaml"))
    assert geared.joint_names == ("ma", "mb") and geared.transmission.joints == (
        "joint_1",
        "joint_2",
    )
    records = [motor_side(dataclasses.replace(recs[k], names_v=("ma", "mb"),
                                              v_tau=recs[k].v_tau * np.sign(n)), geared)
               for k in ("unloaded", "1kg")]
    res = identify_records(records, model=geared)
    assert res.joint_names == ["ma", "mb"]
    g_m = np.array([x.value for x in res.drive_gains])
    g_j = np.array([x.value for x in tls.drive_gains])
    sigma = np.array([x.rel_std for x in tls.drive_gains])
    assert np.all(np.abs(g_m * np.abs(n) / g_j - 1) < sigma), (g_m * np.abs(n) / g_j - 1) / sigma
    g_true = np.array([truth.drives[j].g_tau for j in ("joint_1", "joint_2")]) / np.abs(n)
    assert np.all(np.abs(g_m / g_true - 1) < 0.001)
    motor = {p.name: p.value for p in res.parameters}
    joint = {p.name: p for p in tls.parameters}
    for a, (name, nn) in enumerate(zip(("ma", "mb"), n)):
        for kind, power in (("fv", 2), ("fs", 1)):
            p = joint[model.standard_names[model.drive_columns(a)[kind]]]
            assert (
                abs(motor[f"{kind}_{name}"] * abs(nn) ** power - p.value)
                < 2 * abs(p.value) * p.rel_std
            )
    # the feed-forward through N (one current per motor) is the joint-side model's
    t = np.arange(50) * 1e-3
    q = np.array([1.8708, 1.2708]) + 0.1 * np.sin(np.outer(t, [3.0, 4.0]))
    qd, qdd = (
        0.1 * np.cos(np.outer(t, [3.0, 4.0])) * [3.0, 4.0],
        -0.1 * np.sin(np.outer(t, [3.0, 4.0])) * [9.0, 16.0],
    )
    v_j = feedforward_currents(q, qd, qdd, CTCParameters.from_result(tls, 0.0, model=model))
    v_m = feedforward_currents(q, qd, qdd, CTCParameters.from_result(res, 0.0, model=geared))
    np.testing.assert_allclose((v_m * g_m) * n, v_j * g_j, rtol=2e-3)  # τ_j = Nᵀ τ_m

