"""IDIM-TLS, IDIM-WLS, statistics and essential parameters on synthetic linear models."""
from __future__ import annotations

import numpy as np
import pytest

from orthoglide_ident.errors import ExcitationError, IdentificationError
from orthoglide_ident.identify.observe.equations import Observations
from orthoglide_ident.identify.solve.essential import essential_parameters
from orthoglide_ident.identify.solve.tls import (
    ExcitationLimits,
    TLSProblem,
    check_excitation,
    idim_tls,
)
from orthoglide_ident.identify.solve.wls import idim_wls

G = np.array([2170.0, 2100.0, 2070.0])
JOINTS = ("q11", "q12", "q13")


def _blocks(chi, r=800, masses=(0.0, 1.983), noise=(0.0, 0.0, 0.0), seed=0, w_scale=None):
    """Records of a random linear model: W (3, r, n_b) shared χ, payload column, v = τ/g + n."""
    rng = np.random.default_rng(seed)
    nb = chi.shape[0]
    out = []
    for i, m in enumerate(masses):
        W = rng.standard_normal((3, r, nb)) * (w_scale if w_scale is not None else 1.0)
        w_m = 3.0 * rng.standard_normal((3, r))
        tau = W @ chi + w_m * m
        v = tau / G[:, None] + np.asarray(noise)[:, None] * rng.standard_normal((3, r))
        out.append(Observations(f"rec{i}", "loaded" if m > 0 else "unloaded", m, W, v, w_m))
    return out


CHI = np.array([9.0, 8.5, -3.0, 80.0, 25.0, 1.5])


def test_noise_free_tls_recovers_gains_and_parameters_exactly():
    for weighting in (False, True):
        sol = idim_tls(_blocks(CHI), weighting=weighting)
        assert np.abs(sol.g_tau / G - 1).max() < 1e-9
        assert np.abs(sol.chi - CHI).max() < 1e-9 * np.abs(CHI).max()


def test_several_loaded_records_with_their_own_masses():
    blocks = _blocks(CHI, masses=(0.0, 1.983, 1.136, 0.0))
    sol = idim_tls(blocks)
    assert np.abs(sol.g_tau / G - 1).max() < 1e-9


def test_tls_needs_loaded_and_unloaded_records():
    with pytest.raises(IdentificationError, match="loaded"):
        idim_tls(_blocks(CHI, masses=(0.0, 0.0)))
    with pytest.raises(IdentificationError, match="unloaded"):
        idim_tls(_blocks(CHI, masses=(1.983,)))


def test_sigma_of_eq39_matches_monte_carlo():
    chi = CHI[:4]
    gains, pred = [], []
    for seed in range(150):
        sol = idim_tls(_blocks(chi, r=300, noise=(2e-4, 2e-4, 2e-4), seed=seed), weighting=False)
        gains.append(sol.g_tau)
        pred.append(sol.std[4:7])
    empirical = np.std(gains, axis=0)
    predicted = np.mean(pred, axis=0)
    assert np.all(empirical / predicted > 0.7) and np.all(empirical / predicted < 1.4)
    assert np.abs(np.mean(gains, axis=0) / G - 1).max() < 3 * np.max(empirical / G)


def test_joint_weighting_estimates_the_noise_ratio_and_helps():
    chi = CHI[:4]
    noise = (1e-4, 1e-4, 8e-4)
    err = {True: [], False: []}
    for seed in range(40):
        blocks = _blocks(chi, r=300, noise=noise, seed=seed)
        for w in (True, False):
            sol = TLSProblem(blocks, weighting=w).solve()
            err[w].append(sol.g_tau / G - 1)
            if w:
                ratio = sol.joint_sigma[2] / sol.joint_sigma[0]
                assert 4.0 < ratio < 13.0  # σ_j ∝ g_j σ_v,j
    spread_w = np.sqrt(np.mean(np.square(err[True]), axis=0))
    spread_u = np.sqrt(np.mean(np.square(err[False]), axis=0))
    assert spread_w[:2].max() < 0.8 * spread_u[:2].max()


def test_near_null_regressor_direction_is_detected():
    rng = np.random.default_rng(5)
    blocks = _blocks(CHI, noise=(2e-4,) * 3, seed=1)
    for b in blocks:  # column 2 almost equal to column 1: a near-null direction of W
        b.W[:, :, 2] = b.W[:, :, 1] + 1e-7 * rng.standard_normal(b.W.shape[:2])
        b.v_tau = (b.W @ CHI + b.w_m * b.payload_mass) / G[:, None] + 2e-4 * rng.standard_normal(
            b.v_tau.shape)
    sol = idim_tls(blocks)
    with pytest.raises(ExcitationError):
        check_excitation(sol, ExcitationLimits(), None, JOINTS)


def test_good_excitation_passes_the_checks():
    sol = idim_tls(_blocks(CHI, noise=(1e-5,) * 3))
    check_excitation(sol, ExcitationLimits(), None, JOINTS)
    assert sol.singular_ratio < 0.1 and sol.condition_number < 10


def test_wls_estimates_the_payload_with_given_gains():
    blocks = _blocks(CHI, masses=(0.0, 1.136))
    sol = idim_wls(blocks, G)
    assert sol.payload_masses[0] == pytest.approx(1.136, rel=1e-10)
    assert np.abs(sol.chi - CHI).max() < 1e-9 * 80
    off = idim_wls(blocks, np.full(3, 637 * np.pi))
    assert abs(off.payload_masses[0] / 1.136 - 1) > 0.01
    with pytest.raises(IdentificationError, match="unloaded"):
        idim_wls(blocks[1:], G)


def test_wls_sigma_matches_monte_carlo():
    est, pred = [], []
    for seed in range(100):
        sol = idim_wls(_blocks(CHI[:4], r=300, masses=(0.0, 1.136), noise=(2e-4,) * 3,
                               seed=seed), G)
        est.append(sol.payload_masses[0])
        pred.append(sol.std[-1])
    assert 0.7 < np.std(est) / np.mean(pred) < 1.4


def test_essential_parameters_drop_the_unexcited_ones():
    chi = np.array([9.0, 8.5, 80.0, 25.0, 0.0, 0.0, 0.0])
    scale = np.array([1, 1, 1, 1, 0.01, 0.02, 0.01])
    blocks = _blocks(chi, noise=(2e-4,) * 3, w_scale=scale, seed=2)
    problem = TLSProblem(blocks)
    base = problem.solve()
    res = essential_parameters(lambda a: problem.solve(a, reweight=False), 7, r_sigma=10.0,
                               start=base)
    assert set(res.removed) == {4, 5, 6}
    assert res.ratios[-1] < 10.0
    assert np.abs(res.solution.g_tau / G - 1).max() < 0.01
