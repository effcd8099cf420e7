"""The screw friction ripple at a known lead (its columns in the layout, columns/layout.py;
``screw_lead_m``)."""
from __future__ import annotations

import numpy as np
import pytest
from synthetic import TRUE_CHI, TRUE_GAINS, SyntheticModel, synthetic_record, trajectory

from orthoglide_ident.identify import IdentifyOptions, identify_records
from orthoglide_ident.identify.columns.layout import column_layout

LEAD = 0.010  # m
# N, per joint: cos and sin coefficients of sign(q̇_j) (c cos + s sin)(2π q_j / λ); amplitude
# 0.3-0.6 N, ~1.5 % of the synthetic fs (25-35 N) as on the simulated realistic drive
RIPPLE = np.array([0.30, -0.25, 0.10, 0.45, -0.35, -0.20])


class _RippleTruth(SyntheticModel):
    """The synthetic drive with a friction ripple at LEAD: its regressor [W | ripple] (the
    layout's columns), for the records' truth."""

    def regressor(self, q, qd, qdd):
        return column_layout(self, LEAD).regressor(self, q, qd, qdd)


def test_ripple_columns_sit_in_their_own_joint_rows_beside_W():
    base = SyntheticModel()
    layout = column_layout(base, LEAD)
    q, qd, qdd = trajectory(np.linspace(0.0, 2.0, 500), seed=3)
    X = layout.observation_block(base, q, qd, qdd)
    n = len(base.names)
    assert X.shape == (n + 7, 3, 500) and len(layout.names) == n + 6
    W = base.regressor(q, qd, qdd).reshape(3, 500, n).transpose(2, 0, 1)
    np.testing.assert_array_equal(X[:n], W)
    np.testing.assert_array_equal(X[-1], base.payload_mass_column(q, qd, qdd).reshape(3, 500))
    phi = 2 * np.pi * q / LEAD
    for j in range(3):
        np.testing.assert_allclose(X[n + 2 * j, j], np.sign(qd[:, j]) * np.cos(phi[:, j]))
        np.testing.assert_allclose(X[n + 2 * j + 1, j], np.sign(qd[:, j]) * np.sin(phi[:, j]))
        others = [k for k in range(3) if k != j]
        assert not X[n + 2 * j:n + 2 * j + 2, others].any()
    assert layout.ripple_slice == slice(n, n + 6) and layout.lag_column is None
    assert column_layout(base, 0.0).names == base.names  # no lead: the robot's own columns


def _ripple_records(noise: bool):
    model = _RippleTruth()
    chi = np.concatenate([TRUE_CHI, RIPPLE])
    return [synthetic_record(20.0, m, seed=s, noise=noise, model=model, chi=chi)
            for m, s in ((0.0, 1), (1.983, 2))]


def test_a_ripple_at_the_given_lead_is_identified_with_the_gains():
    """Data with a friction ripple at the 10 mm lead: with ``screw_lead_m`` its amplitude and
    phase come out with the gains (the parameters stay the model's, for the controller); without
    any ripple model the gains move by several times as much."""
    recs = _ripple_records(noise=False)
    res = identify_records(recs, model=SyntheticModel(), options=IdentifyOptions.of(
        screw_lead_m=LEAD))
    g = np.array([x.value for x in res.drive_gains])
    err = np.abs(g / TRUE_GAINS - 1)
    assert err.max() < 2e-4, err  # 3.6e-5 measured (the filters' round-off of a sign step)
    assert [p.name for p in res.parameters] == SyntheticModel().names
    amp = np.hypot(RIPPLE[0::2], RIPPLE[1::2])
    assert [r.joint for r in res.ripple] == ["q11", "q12", "q13"]
    for r, a, c, s in zip(res.ripple, amp, RIPPLE[0::2], RIPPLE[1::2]):
        assert r.wavelength_m == LEAD and r.kind.startswith("friction")
        assert abs(r.amplitude_n / a - 1) < 0.005  # 0.03 % measured
        assert abs(np.angle(np.exp(1j * (r.phase_rad - np.arctan2(-s, c))))) < 0.005
    assert not any("ripple" in w for w in res.warnings)  # asked for: said in the log, not warned
    wrong = identify_records(recs, model=SyntheticModel(), options=IdentifyOptions.of(
        screw_lead_m=0.012))
    said = [w for w in wrong.warnings if "varies with its position with a 9." in w
            or "varies with its position with a 10." in w]  # the 10 mm ripple, still there
    assert len(said) == 3 and all("screw_lead_m is 12.0 mm: check" in w for w in said), said
    off = identify_records(recs, model=SyntheticModel(), options=IdentifyOptions.of(
        ripple_model="off"))
    err_off = np.abs(np.array([x.value for x in off.drive_gains]) / TRUE_GAINS - 1)
    assert err_off.max() > 5e-3, err_off  # 1.9 % measured


def test_the_ripple_columns_cost_no_accuracy_on_a_drive_without_ripple():
    """Noisy data (2 mA) without a ripple: the gains and their σ with the columns are those
    without them (measured over 4 seeds: shifts ≤ 0.013 σ, σ within 0.4 %), and the amplitudes
    found are noise (a 2-D amplitude over its σ: beyond 3.5 with probability 0.2 %)."""
    recs = [synthetic_record(20.0, m, seed=s, amplitude=0.1, f_max=4.0)
            for m, s in ((0.0, 3), (1.983, 4))]
    plain = identify_records(recs, model=SyntheticModel(), options=IdentifyOptions.of(
        ripple_model="off"))
    lead = identify_records(recs, model=SyntheticModel(), options=IdentifyOptions.of(
        screw_lead_m=LEAD))
    g0, g1 = ([x.value for x in r.drive_gains] for r in (plain, lead))
    s0, s1 = ([x.rel_std for x in r.drive_gains] for r in (plain, lead))
    np.testing.assert_allclose(g1, g0, rtol=0.1 * min(s0))
    np.testing.assert_allclose(s1, s0, rtol=0.02)
    for r in lead.ripple:
        assert r.amplitude_n < 3.5 * r.amplitude_std_n, r


@pytest.mark.parametrize("lead", [10.0, -0.01, 1e-5])
def test_a_lead_that_is_not_in_metres_is_refused(lead):
    from orthoglide_ident.errors import ConfigError

    with pytest.raises(ConfigError, match="screw_lead_m is the screws' lead in metres"):
        IdentifyOptions.of(screw_lead_m=lead).validate()


def test_cross_validation_predicts_with_the_ripple():
    """A record kept out of the identification is predicted with the identified ripple too:
    residual ≤ 0.012 N measured with the lead, 0.29-0.31 N (the ripple itself) without."""
    model = _RippleTruth()
    val = synthetic_record(10.0, 1.983, seed=9, noise=False, model=model,
                           chi=np.concatenate([TRUE_CHI, RIPPLE]))
    rms = {}
    for opts in (IdentifyOptions.of(screw_lead_m=LEAD), IdentifyOptions.of(ripple_model="off")):
        res = identify_records(_ripple_records(noise=False), model=SyntheticModel(),
                               options=opts, validation=[val])
        rms[opts.solve.screw_lead_m] = [j.residual_rms for j in res.validation[0].joints]
    assert max(rms[LEAD]) < 0.05 and min(rms[0.0]) > 0.2, rms
