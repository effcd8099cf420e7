"""orthoglide_ident.control: IDIM feed-forward, the per-tick CTC law and its parameters."""
from __future__ import annotations

import numpy as np
import pytest

from orthoglide_ident import control as ctl
from orthoglide_ident.control import CTC, CTCParameters, LinearGains, feedforward
from orthoglide_ident.errors import ConfigError
from orthoglide_ident.model.base import base_model
from orthoglide_ident.results import Estimate, IdentificationResult, PayloadMass


def true_params(m7: float = 1.983) -> CTCParameters:
    """Base parameters of the simulator's true standard parameters, true drive gains."""
    from orthoglide_sim.true_parameters import load_parameters

    tp = load_parameters()
    bm = base_model()
    return CTCParameters.from_values(bm.names, bm.base_values(tp.standard_vector()), tp.g_tau, m7)


def fake_result(params: CTCParameters) -> IdentificationResult:
    names = base_model().names
    return IdentificationResult(
        method="tls", joint_names=["q11", "q12", "q13"],
        drive_gains=[Estimate(j, float(g), 0.001) for j, g in zip(["q11", "q12", "q13"], params.drive_gains)],
        drive_gains_given=False,
        parameters=[Estimate(n, float(v), 0.01) for n, v in zip(names, params.chi_b)],
        payload_mass=PayloadMass(params.payload_mass, 0.0005, True), payloads=[], condition_number=100.0,
        residual_rms=[1.0, 1.0, 1.0], bags=["a", "b"])


def test_linear_part_is_the_simulators():
    from orthoglide_sim import simulator as sm

    g = LinearGains.from_bandwidth()
    assert (g.kp, g.kd, g.ki) == pytest.approx((sm.KP, sm.KD, sm.KI), rel=1e-15)
    assert ctl.G_TAU_MANUFACTURER == pytest.approx(sm.G_TAU_MANUFACTURER, rel=1e-15)
    assert ctl.TICK == sm.TICK


def test_feedforward_equals_plant_torque_on_exact_data(monkeypatch):
    """Plant forward dynamics (independent Lagrange formulation, sign() friction like the model)
    under random forces, then the feed-forward at the resulting (q, qd, qdd) gives the forces back."""
    from orthoglide_sim import plant as pl
    from orthoglide_sim.true_parameters import load_parameters

    rng = np.random.default_rng(1)
    n = 12  # the shape test_sim_plant_vs_model compiles forward_dynamics for
    q, qd = 0.04 + rng.uniform(-0.08, 0.08, (n, 3)), rng.uniform(-1.0, 1.0, (n, 3))  # the safe box
    tp = load_parameters()
    tau = np.random.default_rng(3).uniform(-300.0, 300.0, (len(q), 3))
    qdd = pl.forward_dynamics(q, qd, tau, (tp.standard_vector(), tp.payload_vector("1.983")), coulomb="sign")
    monkeypatch.setattr(ctl, "FF_CHUNK", 3)  # several chunks
    tau_ff = feedforward(q, qd, np.asarray(qdd), true_params(1.983))
    assert np.abs(tau_ff - tau).max() / np.abs(tau).max() < 1e-8


def test_feedforward_matches_observation_and_ignores_absent_parameters():
    bm = base_model()
    rng = np.random.default_rng(0)
    from orthoglide_ident.model.base import random_states

    q, qd, qdd = random_states(7, seed=5)
    p = true_params(1.0)
    W, w_m7 = bm.observation(q, qd, qdd)
    expected = (W @ p.chi_b + w_m7 * 1.0).reshape(3, 7).T
    assert np.allclose(feedforward(q, qd, qdd, p), expected, rtol=1e-12, atol=1e-9)
    keep = sorted(rng.choice(bm.n_b, 20, replace=False))  # an essential-like subset
    sub = CTCParameters.from_values([bm.names[i] for i in keep], p.chi_b[keep], p.drive_gains, 1.0)
    chi = np.zeros(bm.n_b)
    chi[keep] = p.chi_b[keep]
    assert np.allclose(sub.chi_b, chi)
    assert np.allclose(feedforward(q, qd, qdd, sub), (W @ chi + w_m7).reshape(3, 7).T)


def test_command_is_feedforward_over_gain_when_on_the_reference():
    """Constant-velocity reference (so the backward difference is exact): zero error, zero integral,
    v_est = qd_d, hence v_tau = tau_ff / g_tau on every tick, across block boundaries."""
    q0, v = np.array([0.01, 0.03, 0.05]), np.array([0.2, -0.1, 0.3])

    def reference(t):
        t = np.asarray(t, float)[:, None]
        return q0 + v * t, np.broadcast_to(v, (len(t), 3)).copy(), np.zeros((len(t), 3))

    p = true_params()
    ctc = CTC(p, reference, block=4, ff_lead=0.0)
    ks = np.arange(11)
    q_d, qd_d, qdd_d = reference(ks * ctl.TICK)
    tau_ff = feedforward(q_d, qd_d, qdd_d, p)
    for k in ks:
        np.testing.assert_allclose(ctc.command(int(k), q_d[k]), tau_ff[k] / p.drive_gains, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(ctc.integral, 0.0, atol=1e-15)


def test_feedback_is_the_pid_ff_law():
    p = true_params()

    def reference(t):
        n = len(np.atleast_1d(t))
        return np.full((n, 3), 0.04), np.zeros((n, 3)), np.zeros((n, 3))

    ctc = CTC(p, reference, feedforward_on=False)
    g = LinearGains.from_bandwidth()
    ctc.command(0, np.full(3, 0.04))
    q1 = np.array([0.04 - 1e-5, 0.04, 0.04 + 2e-6])
    e = 0.04 - q1
    expected = g.kp * e + g.ki * e * ctl.TICK + g.kd * (0.0 - (q1 - 0.04) / ctl.TICK)
    np.testing.assert_allclose(ctc.force(1, q1), expected, rtol=1e-12)


def test_parameters_from_result_and_message_agree():
    p = true_params()
    res = fake_result(p)
    a = CTCParameters.from_result(res)
    b = CTCParameters.from_message_fields(res.message_fields())
    for x in (a, b):
        np.testing.assert_array_equal(x.chi_b, p.chi_b)
        np.testing.assert_array_equal(x.drive_gains, p.drive_gains)
        assert x.payload_mass == p.payload_mass
    c = CTCParameters.from_result(res, payload_mass=1.136, drive_gains=[2001.0] * 3)
    assert c.payload_mass == 1.136 and list(c.drive_gains) == [2001.0] * 3
    d = a.with_gains([1.0, 2.0, 3.0])
    np.testing.assert_array_equal(d.chi_b, a.chi_b)
    with pytest.raises(ConfigError, match="essential"):
        CTCParameters.from_result(res, essential=True)


@pytest.mark.parametrize("change, match", [
    ({"names": ["m_11R", "not_a_parameter"], "values": [1.0, 2.0]}, "unknown base parameter"),
    ({"names": ["m_11R"], "values": [1.0, 2.0]}, "1 parameter names but 2 values"),
    ({"names": [], "values": []}, "no dynamic parameters"),
    ({"names": ["m_11R", "m_11R"], "values": [1.0, 2.0]}, "repeated"),
    ({"names": ["m_11R"], "values": [float("nan")]}, "non-finite"),
    ({"drive_gains": [2001.0, 2001.0]}, "drive_gains"),
    ({"drive_gains": [2001.0, -1.0, 2001.0]}, "drive_gains"),
    ({"payload_mass": -1.0}, "payload mass"),
    ({"values": ["heavy"]}, "not numbers"),
])
def test_bad_parameters_raise_config_error(change, match):
    fields = {"names": ["m_11R"], "values": [1.0], "drive_gains": [2001.0] * 3, "payload_mass": 1.983}
    fields.update(change)
    with pytest.raises(ConfigError, match=match):
        CTCParameters.from_message_fields(fields)


def test_missing_field_raises_config_error():
    with pytest.raises(ConfigError, match="lack field"):
        CTCParameters.from_message_fields({"names": ["m_11R"], "values": [1.0]})
    with pytest.raises(ConfigError):
        LinearGains.from_bandwidth(-1.0)
