"""Honest σ (identify/uncertainty.py): as eqs. (38)-(39) on white errors, covering correlated ones,
the same live as offline; the residual diagnostics; the gain-keeping essential reduction."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from orthoglide_ident.identify import identify_records, read_record
from orthoglide_ident.identify.observe.equations import Observations
from orthoglide_ident.identify.solve import uncertainty
from orthoglide_ident.identify.solve.essential import essential_parameters
from orthoglide_ident.identify.solve.factors import RecordFactors, qr_r
from orthoglide_ident.identify.solve.tls import TLSProblem
from orthoglide_ident.identify.solve.uncertainty import (
    LAGS,
    ResidualMoments,
    diagnose,
    fir_white_autocorrelation,
)
from orthoglide_ident.identify.solve.wls import idim_wls
from orthoglide_ident.model.registry import load_robot

ORTHOGLIDE = load_robot("orthoglide")  # the robot these records are of

G = np.array([2170.0, 2100.0, 2070.0])
CHI = np.array([9.0, 8.5, -3.0, 80.0])
DT = 0.01  # s between decimated rows
BAGS = Path(__file__).resolve().parents[3] / "bags"


def _ar1(rng, shape, phi):
    """Unit-variance AR(1) noise along the last axis."""
    e = rng.standard_normal(shape) * np.sqrt(1.0 - phi * phi)
    out = np.empty(shape)
    out[..., 0] = rng.standard_normal(shape[:-1])
    for k in range(1, shape[-1]):
        out[..., k] = phi * out[..., k - 1] + e[..., k]
    return out


def _blocks(seed, r=1500, noise=2e-4, phi=0.0, masses=(0.0, 1.983), smooth=False, ripple=0.0):
    """Records of a linear model with instants t (rows DT apart); equation errors AR(1) ``phi``;
    ``smooth``: regressors that vary slowly (like a trajectory); ``ripple``: an error
    ripple·sign(qd)·sin(2π q / 10 mm) with q(t) a slow back-and-forth motion."""
    rng = np.random.default_rng(seed)
    out = []
    t = np.arange(r) * DT
    q = np.stack([0.04 + 0.06 * np.sin(2 * np.pi * 0.23 * t + k) for k in range(3)], axis=1)
    qd = np.gradient(q, DT, axis=0)
    for i, m in enumerate(masses):
        if smooth:
            W = _ar1(rng, (3, CHI.shape[0], r), 0.97).transpose(0, 2, 1)
            w_m = 3.0 * _ar1(rng, (3, r), 0.97)
        else:
            W = rng.standard_normal((3, r, CHI.shape[0]))
            w_m = 3.0 * rng.standard_normal((3, r))
        tau = W @ CHI + w_m * m
        err = noise * (_ar1(rng, (3, r), phi) if phi else rng.standard_normal((3, r)))
        err += ripple * (np.sign(qd) * np.sin(2 * np.pi * q / 0.01)).T / G[:, None]
        v = tau / G[:, None] + err
        out.append(Observations(f"rec{i}", "loaded" if m > 0 else "unloaded", m, W, v, w_m,
                                t=t.copy(), q=q, qd=qd, row_period_s=DT))
    return out


def _gain_sigmas(sol):
    n = sol.chi.shape[0]
    return sol.std[n:n + 3], np.sqrt(np.diag(sol.cov_paper))[n:n + 3]


def test_white_errors_honest_sigma_is_the_papers():
    ratios = []
    for seed in range(4):
        sol = TLSProblem(_blocks(seed)).solve()
        honest, paper = _gain_sigmas(sol)
        ratios.append(honest / paper)
        assert sol.uncertainty.n_blocks == 30  # 15 s records, 1 s blocks
        assert np.all(np.abs(sol.uncertainty.autocorrelation[:, 1:]) < 0.1)
    # honest = max(eq. 39, sandwiches): equal to eq. (39) up to round-off when it is the largest
    assert np.all(np.array(ratios) >= 1.0 - 1e-12) and np.mean(ratios) < 1.25


def test_correlated_errors_paper_sigma_too_small_honest_covers():
    """AR(1) equation errors (φ = 0.9) on slowly varying regressors: eq. (39) is ~3x too small."""
    est, honest, paper = [], [], []
    for seed in range(60):
        sol = TLSProblem(_blocks(seed, r=1000, phi=0.9, smooth=True)).solve(reweight=False)
        h, p = _gain_sigmas(sol)
        est.append(sol.g_tau)
        honest.append(h)
        paper.append(p)
    spread = np.std(est, axis=0)
    assert np.all(spread / np.mean(paper, axis=0) > 2.0)
    cover = spread / np.mean(honest, axis=0)
    assert np.all(cover > 0.7) and np.all(cover < 1.3), cover
    z = np.abs(np.array(est) - G) / np.array(honest)
    assert np.mean(z <= 2) >= 0.9 and z.max() <= 4.0
    d, warnings = diagnose(sol.uncertainty, 10, 4, ("q11", "q12", "q13"), gain_index=slice(4, 7))
    assert d.autocorrelation["q11"][0] > 0.8  # AR(1) 0.9
    assert sum("far from white" in w for w in warnings) == 3
    assert any("σ of the drive gains is up to" in w for w in warnings)


def test_wls_payload_sigma_covers_correlated_errors():
    est, honest, paper = [], [], []
    for seed in range(60):
        sol = idim_wls(_blocks(seed, r=1000, phi=0.9, smooth=True, masses=(0.0, 1.136)), G,
                       weighting=False)
        est.append(sol.payload_masses[0])
        honest.append(sol.std[-1])
        paper.append(np.sqrt(sol.cov_paper[-1, -1]))
    assert np.std(est) / np.mean(paper) > 2.0
    assert 0.7 < np.std(est) / np.mean(honest) < 1.3


def _serial_rows(rng, r, n_c=12, n_j=3):
    """Rows of a serial arm's shape (n_c, n_j, r): joint j without the columns of the bodies
    before it nor the other joints' drive column (the last n_j before v_tau)."""
    X = rng.standard_normal((n_c, n_j, r))
    for j in range(n_j):
        X[:3 * j, j] = 0.0
        X[[n_c - 1 - n_j + k for k in range(n_j) if k != j], j] = 0.0
    return X


def test_moments_on_the_non_zero_columns_are_those_of_every_column(monkeypatch):
    """Blocks and lagged products computed on each joint's non-zero columns only (a serial
    arm's rows) are the products of every column, in pieces, across a gap and with rows
    left out."""
    rng = np.random.default_rng(5)
    r, n_c = 700, 12
    X = _serial_rows(rng, r, n_c)
    t = np.arange(r) * DT
    t[400:] += 0.5
    keep = rng.random((3, r)) > 0.1
    assert uncertainty._nonzero_columns(X.transpose(1, 2, 0), None) is not None  # compact here
    folded = {}
    for name in ("compact", "full"):
        if name == "full":
            monkeypatch.setattr(uncertainty, "_nonzero_columns", lambda Z, tail: None)
        mom = ResidualMoments(n_c, 3, DT)
        for a, b in ((0, 3), (3, 399), (399, 402), (402, 700)):
            mom.fold(X[:, :, a:b], keep[:, a:b], t[a:b])
        folded[name] = mom
    c, f = folded["compact"], folded["full"]
    for k in f.blocks:
        np.testing.assert_allclose(c.blocks[k], f.blocks[k], rtol=0, atol=1e-12)
    np.testing.assert_allclose(c.lagged, f.lagged, rtol=0, atol=1e-12)
    assert np.array_equal(c.pairs, f.pairs)


def test_the_r_factor_on_the_non_zero_columns():
    """qr_r: the Gram of every column, upper triangular; with most columns non-zero it is
    numpy's R itself."""
    rng = np.random.default_rng(6)
    X = _serial_rows(rng, 200)[:, 2].T  # joint 2's rows: 4 of 12 columns non-zero
    R = qr_r(X)
    assert R.shape == (4, 12)
    np.testing.assert_allclose(R.T @ R, X.T @ X, rtol=0, atol=1e-10)
    assert np.all(np.tril(R, -1) == 0.0)
    dense = rng.standard_normal((200, 12))
    assert np.array_equal(qr_r(dense), np.linalg.qr(dense, mode="r"))

def test_moments_fold_in_pieces_as_at_once():
    """Blocks, lagged products and the position spectrum do not depend on how rows arrive;
    rows of another segment (a gap in t) are not paired."""
    rng = np.random.default_rng(3)
    r, n_c = 700, 6
    X = rng.standard_normal((n_c, 3, r))
    t = np.arange(r) * DT
    t[400:] += 0.5  # a gap
    keep = rng.random((3, r)) > 0.1
    q, qd = rng.random((r, 3)) * 0.1, rng.standard_normal((r, 3))
    whole = ResidualMoments(n_c, 3, DT)
    whole.fold(X, keep, t, q, qd)
    parts = ResidualMoments(n_c, 3, DT)
    for a, b in ((0, 1), (1, 7), (7, 399), (399, 402), (402, 700)):
        parts.fold(X[:, :, a:b], keep[:, a:b], t[a:b], q[a:b], qd[a:b])
    assert whole.blocks.keys() == parts.blocks.keys()
    for k in whole.blocks:
        assert np.allclose(whole.blocks[k], parts.blocks[k])
    assert np.allclose(whole.lagged, parts.lagged) and np.array_equal(whole.pairs, parts.pairs)
    assert np.allclose(whole.spectrum, parts.spectrum)
    # lag-1 pairs: consecutive kept rows of one segment only
    Z = X.transpose(1, 2, 0) * keep[:, :, None]
    same = np.ones(r - 1, bool)
    same[399] = False
    expect = np.einsum("ri,rk->ik", Z[0, :-1][same], Z[0, 1:][same])
    assert np.allclose(whole.lagged[0, 0], expect)
    assert whole.pairs[0, 1] == np.sum(keep[0, :-1] & keep[0, 1:] & same)


def test_long_records_merge_blocks():
    m = ResidualMoments(4, 3, DT)
    t = np.arange(20000) * DT  # 200 s
    m.fold(np.ones((4, 3, t.shape[0])), None, t)
    assert m.n_blocks <= 64 and m.block_s == 4.0
    assert np.allclose(sum(m.blocks.values())[0], 20000.0)


def test_screw_ripple_shows_in_the_position_spectrum():
    blocks = _blocks(1, r=3000, noise=1e-4, ripple=0.5)
    sol = TLSProblem(blocks).solve()
    d, warnings = diagnose(sol.uncertainty, 10, sol.chi.shape[0], ("q11", "q12", "q13"),
                           gain_index=slice(4, 7))
    peaks = d.position_spectrum_peaks
    assert len(peaks) == 3
    for p in peaks:
        assert abs(p.wavelength_m - 0.01) < 0.0005 and p.kind.startswith("friction")
        assert 0.3 < p.amplitude_n < 0.7
    assert sum(" mm period" in w and "friction ripple" in w for w in warnings) == 3
    clean = TLSProblem(_blocks(1, r=3000, noise=1e-4)).solve()
    d, warnings = diagnose(clean.uncertainty, 10, clean.chi.shape[0], ("q11", "q12", "q13"),
                           gain_index=slice(4, 7))
    assert d.position_spectrum_peaks == () and not any("period" in w for w in warnings)


def test_fir_white_autocorrelation():
    ac = fir_white_autocorrelation(10)
    assert ac.shape == (LAGS,) and 0.25 < ac[0] < 0.45 and ac[1] < 0
    assert np.all(fir_white_autocorrelation(1) == 0)


@pytest.fixture(scope="module")
def bag_result():
    recs = [read_record(BAGS / "unloaded", model=ORTHOGLIDE), read_record(BAGS / "loaded",
                                                                          model=ORTHOGLIDE)]
    return recs, identify_records(recs, essential=True, model=ORTHOGLIDE)


def test_result_reports_both_sigmas(bag_result):
    _, res = bag_result
    for g in res.drive_gains:
        assert g.rel_std >= g.rel_std_paper > 0
    for p in res.parameters:
        assert p.rel_std >= p.rel_std_paper * (1 - 1e-12)
    js = res.to_json()
    assert {"rel_std", "rel_std_paper"} <= set(js["drive_gains"][0])
    assert "rel_std_paper" in js["parameters"][0] and "uncertainty" in js["diagnostics"]
    u = js["diagnostics"]["uncertainty"]
    assert u["blocks"] == 20 and set(u["autocorrelation"]) == {"q11", "q12", "q13"}
    msg = res.message_fields()
    assert msg["drive_gains_rel_std"] == [g.rel_std for g in res.drive_gains]
    text = res.to_text()
    assert "%σ eq39" in text and "residual autocorrelation" in text


def test_essential_keeps_the_gains_and_says_what_each_cancellation_cost(bag_result):
    recs, res = bag_result
    g = np.array([x.value for x in res.drive_gains])
    tol = np.maximum([x.rel_std for x in res.drive_gains], 0.003)
    ess = res.essential
    ge = np.array([x.value for x in ess.drive_gains])
    assert np.all(np.abs(ge / g - 1) <= tol + 1e-12)
    steps = ess.reduction.steps
    cancelled = [s.name for s in steps if s.accepted]
    assert cancelled == res.removed and len(cancelled) > 10
    assert all(len(s.shift) == 3 and np.isfinite(s.residual_change) for s in steps)
    kept = [s for s in steps if not s.accepted]
    assert kept and all(s.reason.startswith("kept:") for s in kept)
    assert "what each cancellation cost" in res.to_text()
    # the paper's rule, still available, moves the gains further on the same data
    from orthoglide_ident.identify import IdentifyOptions

    paper = identify_records(
        recs, essential=True, options=IdentifyOptions.of(essential_method="paper"), model=ORTHOGLIDE
    ).essential
    gp = np.array([x.value for x in paper.drive_gains])
    assert paper.reduction.method == "paper"
    assert np.abs(gp / g - 1).max() > np.abs(ge / g - 1).max()


def test_essential_procedures_on_a_synthetic_model():
    chi = np.array([9.0, 8.5, 80.0, 25.0, 0.0, 0.0, 0.0])
    rng = np.random.default_rng(2)
    obs = []
    for i, m in enumerate((0.0, 1.983)):
        W = rng.standard_normal((3, 800, 7)) * np.array([1, 1, 1, 1, 0.01, 0.02, 0.01])
        w_m = 3.0 * rng.standard_normal((3, 800))
        v = (W @ chi + w_m * m) / G[:, None] + 2e-4 * rng.standard_normal((3, 800))
        obs.append(Observations(f"r{i}", "loaded" if m else "unloaded", m, W, v, w_m,
                                t=np.arange(800) * DT, row_period_s=DT))
    problem = TLSProblem([RecordFactors.from_observations(o) for o in obs])
    base = problem.solve()
    for method in ("keep_gains", "paper"):
        res = essential_parameters(lambda a: problem.solve(a, reweight=False), 7, 10.0, start=base,
                                   method=method, names=list("abcdefg"))
        assert set(res.removed) == {4, 5, 6}, method
        assert [s.name for s in res.steps if s.accepted] == [("abcdefg")[k] for k in res.removed]
        assert np.abs(res.solution.g_tau / base.g_tau - 1).max() < 0.003


def test_ripple_columns_from_the_moments_are_the_rows_own():
    """The augmented normal equations (solve/drive_fit.py) equal those of rows with the two columns
    w cos(2π q/λ), w sin(2π q/λ), w = sign(q̇) H, written out; and the ripple is recovered."""
    from orthoglide_ident.identify.columns import drive_terms
    from orthoglide_ident.identify.solve import drive_fit
    from orthoglide_ident.identify.solve.uncertainty import WAVELENGTHS_M, fir_gain

    obs = _blocks(4, r=3000, noise=1e-4, ripple=0.5)
    for o in obs:
        o.decimation = 10
    f = [RecordFactors.from_observations(o) for o in obs]
    i = int(np.argmin(np.abs(WAVELENGTHS_M - 0.01)))
    terms = drive_terms.Terms((drive_terms.RippleTerm(1, float(WAVELENGTHS_M[i]), True, i),))
    aug = drive_fit.augmented_factors(f, terms)
    lam = WAVELENGTHS_M[i]
    for o, a in zip(obs, aug):
        j = 1
        w = np.sign(o.qd[:, j]) * fir_gain(np.abs(o.qd[:, j]) / lam, 10, DT / 10)
        ph = 2 * np.pi * o.q[:, j] / lam
        X = np.column_stack([o.W[j], w * np.cos(ph), w * np.sin(ph), o.w_m[j], o.v_tau[j]])
        assert np.allclose(a.R[j].T @ a.R[j], X.T @ X, rtol=1e-9, atol=1e-9 * np.abs(X.T @ X).max())
    sol = TLSProblem(aug).solve()
    view, rip, _ = drive_fit.split(sol, 4, terms, ("q11", "q12", "q13"))
    assert view.chi.shape == (4,) and view.cov.shape == (7, 7)
    # the synthetic ripple is 0.5 N sin(2π q/λ) sign(q̇) in the force (its rows' H is ~1: slow)
    assert abs(rip[0].amplitude_n - 0.5) < 0.1 and abs(rip[0].phase_rad + np.pi / 2) < 0.2


def _flips(v: np.ndarray, rows: int = 3) -> np.ndarray:
    """(3, r) the rows from each sign change of v (per joint) on, ``rows`` of them."""
    out = np.zeros(v.shape, bool)
    for j in range(v.shape[0]):
        for k in np.flatnonzero(np.sign(v[j, 1:]) != np.sign(v[j, :-1])) + 1:
            out[j, k:k + rows] = True
    return out


def test_a_residual_at_current_reversals_is_said_and_folded_as_at_once():
    """An error on the rows where each joint's current reverses (as a backlash crossed there
    leaves): the rms there over elsewhere is measured and said, naming the joint; on white
    errors the ratio is ~1 and nothing is said. The reversal rows do not depend on how rows
    arrive."""
    blocks = _blocks(7, smooth=True)
    clean = TLSProblem(blocks).solve()
    for obs in blocks:  # away from zero: the same sign changes
        obs.v_tau[:] += 20 * 2e-4 * np.sign(obs.v_tau) * _flips(obs.v_tau)
    hit = TLSProblem(blocks).solve()
    names = ("q11", "q12", "q13")
    assert np.all(np.abs(clean.uncertainty.reversal_ratio - 1) < 0.3), (
        clean.uncertainty.reversal_ratio
    )
    assert np.all(hit.uncertainty.reversal_ratio > 5), hit.uncertainty.reversal_ratio
    for sol, said in ((clean, 0), (hit, 3)):
        d, warnings = diagnose(sol.uncertainty, 10, 4, names, gain_index=slice(4, 7))
        assert sum("where its current reverses" in w and "backlash" in w for w in warnings) == said
        assert set(d.reversal_residual_ratio) == set(names)
    # the rows folded are the rows of each sign change on (here, three), in pieces as at once
    obs = blocks[0]
    X = np.concatenate([obs.W.transpose(2, 0, 1), obs.w_m[None], obs.v_tau[None]])  # (n_c, 3, r)
    whole, parts = ResidualMoments(X.shape[0], 3, DT), ResidualMoments(X.shape[0], 3, DT)
    whole.fold(X, None, obs.t)
    for a, b in ((0, 1), (1, 7), (7, 399), (399, 1500)):
        parts.fold(X[:, :, a:b], None, obs.t[a:b])
    flags = _flips(obs.v_tau)
    Z = X.transpose(1, 2, 0)
    for j in range(3):
        np.testing.assert_allclose(whole.reversal[j], Z[j, flags[j]].T @ Z[j, flags[j]], rtol=1e-12)
    np.testing.assert_allclose(parts.reversal, whole.reversal, rtol=1e-12)
    assert np.array_equal(parts.reversal_rows, flags.sum(axis=1))


def _decimated_autocorrelation(series: np.ndarray, n_d: int = 10) -> np.ndarray:
    """(LAGS + 1,) autocorrelation of ``series`` (1 kHz) after the decimation the pipeline does:
    the windowed-sinc FIR (scipy's, as decimation.fir_taps documents), every n_d-th row."""
    from scipy.signal import firwin

    y = np.convolve(series, firwin(8 * n_d + 1, 0.8 / n_d, window="hamming"), "valid")[::n_d]
    y = y - y.mean()
    return np.array([1.0] + [y[:-L] @ y[L:] / (y @ y) for L in range(1, uncertainty.LAGS + 1)])


def _residual_of(series: list[np.ndarray], reversal=None) -> uncertainty.Uncertainty:
    ac = np.array([_decimated_autocorrelation(x) for x in series])
    n = len(series)
    eye = np.eye(n)
    return uncertainty.Uncertainty(eye, eye, np.ones(n), np.ones(n), 40, 1.0, ac,
                                   np.full(n, 1000), reversal_ratio=reversal)


def test_a_clean_residual_is_not_said_far_from_white_a_slow_one_is_with_its_likely_cause():
    """White current noise, and the encoders' quantisation through q̈ (white noise differenced
    twice: blue), each through the pipeline's decimation: not far from white (the blue one was,
    on every joint of the clean simulated UR5, before the check became one-sided on the slow
    part); a slow force the model lacks (an AR(1) of 50 ms beside the same noise) is, named as a
    friction or elasticity, or as a backlash where the residual peaks at current reversals."""
    rng = np.random.default_rng(3)
    n = 40_000
    white = rng.standard_normal(n)
    blue = np.diff(rng.standard_normal(n + 2), 2)
    slow = np.zeros(n)
    e = rng.standard_normal(n)
    for k in range(1, n):  # AR(1), time constant 50 ms at 1 kHz
        slow[k] = 0.98 * slow[k - 1] + e[k]
    slow = white + 0.1 * slow
    names = ("white", "blue", "slow", "slow_at_reversals")
    unc = _residual_of([white, blue, slow, slow], reversal=np.array([1.0, 1.0, 1.2, 3.0]))
    d, warnings = diagnose(unc, 10, 4, names)
    said = {n: [w for w in warnings if w.startswith(f"the residual of {n} is far from white")]
            for n in names}
    assert not said["white"] and not said["blue"], warnings
    assert d.slow_ratio["slow"] > uncertainty.SLOW_WARN > d.slow_ratio["white"]
    assert len(said["slow"]) == 1 and "Stribeck" in said["slow"][0]
    assert len(said["slow_at_reversals"]) == 1 and "backlash" in said["slow_at_reversals"][0]
