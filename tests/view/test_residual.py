"""The live force residual: measured g_τ v_τ against the identified model, from the positions
alone."""

from __future__ import annotations

import numpy as np
import pytest
from coupled_view import G_MOTORS, MOTORS, N_WRIST, coupled_model, coupled_record
from synthetic import synthetic_record, trajectory

from orthoglide_ident.errors import ConfigError, OrthoglideError
from orthoglide_ident.identify.observe.filtering import filter_horizon
from orthoglide_ident.model.registry import load_robot
from orthoglide_ident.view.residual import ForceResidual

SECONDS = 4.0
AMPLITUDE = 0.04  # m: the Orthoglide's safe box


@pytest.fixture(scope="module")
def orthoglide():
    from orthoglide_sim.orthoglide import truth as true_parameters
    bm = load_robot(None)
    tp = true_parameters.default_parameters()
    return bm, bm.base_values(tp.standard_vector()), np.array(tp.g_tau)


def _record(orthoglide, payload=1.983):
    bm, chi, g = orthoglide
    return synthetic_record(
        SECONDS, payload, model=bm, chi=chi, g_tau=g, noise=False, amplitude=AMPLITUDE
    )


def _feed(res: ForceResidual, rec, batch: int, order=("q", "v"), names=None):
    names = names or ("q11", "q12", "q13")
    out = []
    for a in range(0, len(rec.stamps_q_ns), batch):
        sl = slice(a, a + batch)
        for topic in order:
            res.add(topic, rec.stamps_q_ns[sl], names, rec.q[sl] if topic == "q" else rec.v_tau[sl])
        out += res.take()
    return out


def _residual(orthoglide, m7_model=1.983, batch=37, rec=None):
    bm, chi, g = orthoglide
    rec = rec or _record(orthoglide)
    res = ForceResidual(bm)
    # any order
    res.set_parameters(["q13", "q11", "q12"], list(g[[2, 0, 1]]), list(bm.names), list(chi))
    res.set_payload(m7_model)
    return rec, _feed(res, rec, batch)


def _far_from_reversals(rec, blocks, v_min=0.03):
    """Blocks whose joints all move faster than v_min: the model's sign() friction, like the
    identification's, jumps at a velocity reversal that the filtered states smear over a few
    ticks."""
    _, qd, _ = trajectory(
        (np.array([b.stamp_ns for b in blocks]) - rec.stamps_q_ns[0]) * 1e-9, 0, AMPLITUDE
    )
    return np.abs(qd) > v_min


def test_model_force_matches_the_measured_force_of_a_model_consistent_record(orthoglide):
    rec, blocks = _residual(orthoglide)
    ticks = len(rec.stamps_q_ns)
    H = filter_horizon(1e-3, 100.0, 4)
    # every block with its filter context, none twice
    assert len(blocks) == (ticks - 2 * H - 1) // 20
    assert all(b.ticks == 20 for b in blocks)
    meas = np.array([b.measured for b in blocks])
    resid = meas - np.array([b.model for b in blocks])
    far = _far_from_reversals(rec, blocks)
    rms = np.sqrt(np.mean(meas ** 2, axis=0))
    assert np.all(rms > 20.0)  # N: the forces are real
    # the derivative filter's error only: < 0.2 % of the force away from reversals
    for j in range(3):
        assert np.sqrt(np.mean(resid[far[:, j], j] ** 2)) < 2e-3 * rms[j]


def test_a_payload_left_out_of_the_model_shows_as_its_force(orthoglide):
    """Model without the 1.983 kg on the platform: the residual is the payload's force W_kl m_7."""
    bm, _, _ = orthoglide
    rec, with_payload = _residual(orthoglide)
    _, without = _residual(orthoglide, m7_model=0.0, rec=rec)
    diff = np.array([b.model for b in with_payload]) - np.array([b.model for b in without])
    t = (np.array([b.stamp_ns for b in with_payload]) - rec.stamps_q_ns[0]) * 1e-9
    q, qd, qdd = trajectory(t, 0, AMPLITUDE)
    # at the block's middle tick
    expected = 1.983 * bm.payload_mass_column(q, qd, qdd).reshape(3, -1).T
    assert np.abs(diff).max() > 5.0  # N: gravity on q13 and the payload's inertia
    # a 20 ms mean of a smooth force
    assert np.abs(diff - expected).max() < 0.01 * np.abs(expected).max()


def test_blocks_do_not_depend_on_how_the_ticks_arrive(orthoglide):
    bm, chi, g = orthoglide
    rec, a = _residual(orthoglide, batch=1000)
    res = ForceResidual(bm)
    res.set_parameters(["q11", "q12", "q13"], list(g), list(bm.names), list(chi))
    res.set_payload(1.983)
    b = _feed(res, rec, 7, order=("v", "q"))  # currents first, small batches
    assert [x.stamp_ns for x in a] == [x.stamp_ns for x in b]
    np.testing.assert_allclose([x.model for x in a], [x.model for x in b], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(
        [x.measured for x in a], [x.measured for x in b], rtol=1e-9, atol=1e-9
    )


def test_a_gap_restarts_the_filter_and_no_block_spans_it(orthoglide):
    bm, chi, g = orthoglide
    rec = _record(orthoglide)
    keep = np.ones(len(rec.stamps_q_ns), bool)
    keep[2000:2005] = False  # 5 lost ticks
    for f in ("stamps_q_ns", "q", "stamps_v_ns", "v_tau"):
        setattr(rec, f, getattr(rec, f)[keep])
    _, blocks = _residual(orthoglide, rec=rec)
    gap = rec.stamps_q_ns[2000]  # first tick after the gap
    H = filter_horizon(1e-3, 100.0, 4)
    for b in blocks:  # no block, nor its filter context, reaches across the gap
        assert not (gap - (H + 11) * 1_000_000 < b.stamp_ns < gap + (H + 10) * 1_000_000)
    assert min(b.stamp_ns for b in blocks) < gap < max(b.stamp_ns for b in blocks)


def test_without_parameters_nothing_comes_out_and_the_buffer_stays_small(orthoglide):
    bm, _, _ = orthoglide
    res = ForceResidual(bm)
    rec = _record(orthoglide)
    assert _feed(res, rec, 100) == []
    assert len(res.t) < 2 * filter_horizon(1e-3, 100.0, 4) + 200  # ticks kept: the filter's context


def test_wrong_names_are_refused_with_a_reason(orthoglide):
    bm, chi, g = orthoglide
    res = ForceResidual(bm)
    with pytest.raises(ConfigError, match="not those of robot"):
        res.set_parameters(["q11", "q12", "q13"], list(g), ["m_6R", "nonsense"], [1.0, 2.0])
    with pytest.raises(ConfigError, match="lack the drive gains of q13"):
        res.set_parameters(["q11", "q12"], list(g[:2]), list(bm.names), list(chi))
    with pytest.raises(ConfigError, match="lack joints q13"):
        res.add("q", np.arange(3), ("q11", "q12", "x"), np.zeros((3, 3)))


def test_states_the_model_refuses_cost_their_blocks_only(orthoglide):
    """Positions far outside the workspace (a glitch) for 5 ticks: the blocks whose filter window
    holds them are lost with a reason, the residual goes on after them."""
    bm, chi, g = orthoglide
    rec = _record(orthoglide)
    rec.q[2000:2005] = 5.0  # m: no assembly of the Orthoglide reaches it
    res = ForceResidual(bm)
    res.set_parameters(list(bm.joint_names), list(g), list(bm.names), list(chi))
    blocks, errors = [], 0
    for a in range(0, len(rec.stamps_q_ns), 100):
        sl = slice(a, a + 100)
        res.add("q", rec.stamps_q_ns[sl], bm.joint_names, rec.q[sl])
        res.add("v", rec.stamps_v_ns[sl], bm.joint_names, rec.v_tau[sl])
        try:
            blocks += res.take()
        except OrthoglideError:
            errors += 1
    glitch = rec.stamps_q_ns[2000]
    after = [b for b in blocks if b.stamp_ns > glitch + 200 * 1_000_000]
    assert after and np.all(np.isfinite([b.model for b in after]))
    assert len(res.t) < 2 * filter_horizon(1e-3, 100.0, 4) + 200
    assert errors or not any(abs(b.stamp_ns - glitch) < 150 * 1_000_000 for b in blocks)


# --- a robot with a transmission (issue 33): the residual per motor, the joints' beside it -------
@pytest.fixture(scope="module")
def coupled(tmp_path_factory):
    return coupled_model(tmp_path_factory.mktemp("coupled_view"))


def test_a_transmission_gives_the_residual_per_motor_and_per_joint(coupled):
    """Positions under the joints' names, currents under the motors': mapped to the motors on
    arrival (q_m = N q_j + offset), the model force is each motor's row and matches the measured
    g_a v_a; the joints' residual is Nᵀ of the motors'."""
    model, chi = coupled
    stamps, q_j, v = coupled_record(model, chi)
    joints = model.transmission.joints
    res = ForceResidual(model)
    res.set_parameters(list(MOTORS), list(G_MOTORS), list(model.names), list(chi))
    with pytest.raises(ConfigError, match="currents lack joints m1, m2, m3, m4, m5, m6"):
        res.add("v", stamps[:3], joints, v[:3])  # the currents are the motors', not the joints'
    blocks = []
    for a in range(0, len(stamps), 250):
        sl = slice(a, a + 250)
        res.add("q", stamps[sl], joints, q_j[sl])
        res.add("v", stamps[sl], MOTORS, v[sl])
        blocks += res.take()
    assert len(blocks) > 100
    meas = np.array([b.measured for b in blocks])
    resid = meas - np.array([b.model for b in blocks])
    rms = np.sqrt(np.mean(meas ** 2, axis=0))
    assert np.all(rms > 0.01)  # N·m at the motor shafts: the forces are real
    # the derivative filter's error only (no sign() friction here; five-point differences of
    # sinusoids below 0.4 Hz: ~(ωT)⁴ ≈ 1e-12, measured 2e-11 of each motor's force)
    assert np.all(np.sqrt(np.mean(resid**2, axis=0)) < 1e-6 * rms), (
        np.sqrt(np.mean(resid**2, axis=0)) / rms
    )
    joint = np.array([b.joint_residual for b in blocks])
    np.testing.assert_allclose(joint, resid @ N_WRIST, rtol=1e-12, atol=1e-15)
    # without the transmission's offsets and coupling (positions taken as the motors'), it fails
    wrong = ForceResidual(model)
    wrong.set_parameters(list(MOTORS), list(G_MOTORS), list(model.names), list(chi))
    wrong.channels["q"] = (joints, None)
    bad = []
    for a in range(0, len(stamps), 250):
        sl = slice(a, a + 250)
        wrong.add("q", stamps[sl], joints, q_j[sl])
        wrong.add("v", stamps[sl], MOTORS, v[sl])
        bad += wrong.take()
    bad_resid = np.array([b.measured - b.model for b in bad])
    assert np.all(np.sqrt(np.mean(bad_resid ** 2, axis=0)) > 0.05 * rms)  # measured 9 % .. 102 %
