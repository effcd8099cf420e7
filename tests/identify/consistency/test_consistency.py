"""Physically consistent standard parameters behind identified base parameters (consistency.py).

On the Orthoglide's base map K (61 × 208): the simulator's true standard parameters are
consistent, a deliberately inconsistent base vector is projected onto the nearest consistent
one (every pseudo-inertia PSD, nothing nearer), the formulation agrees with cvxpy's, the solver's
failure is a one-line reason; on the sample bags (simulator records) the answer stays within
the base answer's σ and costs little residual.
"""
from __future__ import annotations

import json

import numpy as np
import pytest

from orthoglide_ident import cli
from orthoglide_ident.errors import ConfigError, SolverError
from orthoglide_ident.identify import IdentifyOptions, identify, identify_records
from orthoglide_ident.identify.consistency import fit as C
from orthoglide_ident.identify.consistency import lmi
from orthoglide_ident.identify.consistency.pseudo_inertia import MARGIN, layout, min_eigenvalues
from orthoglide_ident.model.inertia import at_com, from_com, pseudo_inertia
from orthoglide_ident.model.registry import load_robot

ORTHOGLIDE = load_robot("orthoglide")  # the robot these records are of

ROBOT = load_robot(None)
K = ROBOT.K
BAGS = ["bags/unloaded", "bags/loaded"]


@pytest.fixture(scope="module")
def truth() -> np.ndarray:
    from orthoglide_sim.orthoglide import truth as true_parameters
    return true_parameters.default_parameters().standard_vector()


@pytest.fixture(scope="module")
def bag_result():
    return identify(BAGS, options=IdentifyOptions.of(consistent=True), model=ORTHOGLIDE)


def _sigma(chi_b: np.ndarray) -> np.ndarray:
    """A plausible σ for base parameters: 2 % of each, at least 1e-3 of their unit."""
    return 0.02 * np.abs(chi_b) + 1e-3


def test_pseudo_inertia_of_a_body_and_its_com_form_agree():
    chi = from_com(2.0, np.array([0.1, -0.05, 0.2]), np.array([0.03, 0.001, -0.002, 0.02,
                                                               0.0005, 0.025]))
    m, c, I = at_com(chi)
    assert m == 2.0 and np.allclose(c, [0.1, -0.05, 0.2]) and np.allclose(I[0], 0.03)
    assert np.linalg.eigvalsh(pseudo_inertia(chi))[0] > 0
    # Ixx > Iyy + Izz about the centre of mass: no mass distribution has it
    bad = from_com(2.0, np.zeros(3), np.array([0.05, 0.0, 0.0, 0.02, 0.0, 0.02]))
    assert np.linalg.eigvalsh(pseudo_inertia(bad))[0] < 0


def test_true_parameters_are_consistent_and_reproduced_exactly(truth):
    chi_b = K @ truth
    lay = layout(ROBOT, chi_b=chi_b)
    assert min_eigenvalues(lay, truth).min() > MARGIN
    W = np.diag(1.0 / _sigma(chi_b))
    assert C.check_exact(lay, K, W, W @ chi_b).consistent
    fit = C.solve_fit(lay, K, W, W @ chi_b, C.PRIOR_WEIGHT, "test")
    assert np.abs((fit.chi_b - chi_b) / _sigma(chi_b)).max() < 0.01  # the prior moves < 0.01 σ
    assert min_eigenvalues(lay, fit.chi_st).min() > 0.99 * MARGIN


def _inconsistent(truth: np.ndarray) -> np.ndarray:
    """χ_b with zz_31R = zz_31 − 0.31 mx_31 far below anything body 3 of leg 1 can have."""
    chi_b = K @ truth
    chi_b[ROBOT.names.index("zz_31R")] -= 0.2
    return chi_b


def test_inconsistent_base_vector_projected_to_the_nearest_consistent_one(truth):
    chi_bad = _inconsistent(truth)
    lay = layout(ROBOT, chi_b=chi_bad)
    sigma = _sigma(K @ truth)
    W = np.diag(1.0 / sigma)
    found = C.check_exact(lay, K, W, W @ chi_bad)
    names = [b.name for b, t in zip(lay.bodies, found.relaxation) if t > C.RELAXATION_TOL]
    assert not found.consistent and names == ["body 3 of leg 1"]
    fit = C.solve_fit(lay, K, W, W @ chi_bad, C.PRIOR_WEIGHT, "test")
    assert min_eigenvalues(lay, fit.chi_st).min() > 0.99 * MARGIN  # every pseudo-inertia PSD
    d2 = float(np.sum((W @ (fit.chi_b - chi_bad)) ** 2))
    # nearest: no consistent point is nearer — not the truth, not the projection of a neighbour
    assert d2 < float(np.sum((W @ (K @ truth - chi_bad)) ** 2))
    assert d2 > 1.0  # and the violation cost something (0.2 kg·m² on zz_31R)
    W_b = np.diag(1.0 / sigma)
    assert C.check_exact(lay, K, W_b, W_b @ fit.chi_b).consistent  # the answer itself is
    # the projection moved what the violation is about, not the well-determined rest
    shift = np.abs((fit.chi_b - chi_bad) / sigma)
    assert ROBOT.names[int(np.argmax(shift))] in ("zz_31R", "xx_31R", "zz_21R")


def test_formulation_agrees_with_cvxpy(truth):
    import cvxpy as cp
    chi_bad = _inconsistent(truth)
    lay = layout(ROBOT, chi_b=chi_bad)
    W = np.diag(1.0 / _sigma(K @ truth))
    A, a = (W @ K) * lay.scale, W @ chi_bad
    ours = lmi.fit(A, a, lay.B_s, lay.b_s, C.PRIOR_WEIGHT, lay.lmi_blocks(),
                   lay.inequalities()[0], polish=False)
    z = cp.Variable(A.shape[1])
    cons = [lay.inequalities()[0] @ z >= 0]
    for blk in lay.lmi_blocks():
        X = cp.Variable((4, 4), symmetric=True)
        sv = cp.hstack([X[r, c] * (1.0 if r == c else np.sqrt(2.0)) for r, c in lmi.svec_index()])
        cons += [sv == blk.G @ z[blk.cols] + blk.h, X >> 0]
    obj = cp.sum_squares(A @ z - a) + C.PRIOR_WEIGHT * cp.sum_squares(lay.B_s @ z - lay.b_s)
    prob = cp.Problem(cp.Minimize(obj), cons)
    prob.solve(solver="CLARABEL")
    assert ours.objective == pytest.approx(prob.value, rel=1e-5)
    assert np.allclose(K @ (ours.z * lay.scale), K @ (z.value * lay.scale), rtol=1e-4, atol=1e-5)


def test_solver_failure_is_a_one_line_reason(monkeypatch, truth):
    lay = layout(ROBOT)
    W = np.diag(1.0 / _sigma(K @ truth))
    monkeypatch.setattr(lmi, "MAX_ITER", 2)
    with pytest.raises(SolverError) as exc:
        C.solve_fit(lay, K, W, W @ _inconsistent(truth), C.PRIOR_WEIGHT, "projection")
    msg = str(exc.value)
    assert "\n" not in msg and "MaxIterations" in msg and "not converged" in msg
    monkeypatch.setattr(lmi, "MAX_ITER", lmi.MAX_ITER)
    a = W @ (K @ truth)
    a[0] = np.nan
    with pytest.raises(SolverError) as exc:
        C.solve_fit(lay, K, W, a, C.PRIOR_WEIGHT, "projection")
    assert "\n" not in str(exc.value) and str(exc.value).startswith("projection:")


def test_cli_reports_a_solver_failure_in_one_line(monkeypatch, capsys):
    monkeypatch.setattr(lmi, "MAX_ITER", 2)
    assert cli.main(["identify", *BAGS, "--consistent", "-q"]) == cli.EXIT_BAD_INPUT
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "conic solver stopped" in err and "Traceback" not in err


def test_sample_bags_consistent_answer_within_the_base_sigma(bag_result):
    c = bag_result.consistency
    for fit in (c.projection, c.identified):
        assert min_eigenvalues(c.lay, fit.chi_st).min() > 0.99 * MARGIN
        assert np.all(fit.chi_st[c.lay.nonneg] >= -1e-9)  # ia, fv, fs ≥ 0
        assert np.abs((fit.chi_b - c.chi_hat) / c.sigma_b).max() < 3.0
    # enforcing it costs little: the data barely see the difference
    doc = c.to_json()
    assert doc["projection"]["residual_increase"] < 0.01
    assert doc["identification"]["residual_increase"] < 0.01
    assert doc["projection"]["mahalanobis_d2"] < len(ROBOT.names)
    # the platform's inertia never shows on a translating platform: it stays at the prior
    platform = next(b for b in doc["bodies"] if b["body"] == "platform")
    assert {"xx_6", "yy_6", "zz_6", "xy_6"} <= set(platform["at_prior"])
    assert doc["seconds"] > 0  # reported; bench/consistency.py times it


def test_json_gains_standard_parameters_and_keeps_the_rest(bag_result):
    doc = bag_result.to_json()
    sp = doc["standard_parameters"]
    assert [b["body"] for b in sp] == [b.name for b in ROBOT.bodies]
    for b in sp:
        assert set(b) == {"body", "frame", "mass", "com", "inertia"}
        assert len(b["com"]) == 3 and len(b["inertia"]) == 6 and b["mass"] > 0
        xx, xy, xz, yy, yz, zz = b["inertia"]
        eig = np.linalg.eigvalsh([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
        assert eig[0] > 0 and eig[0] + eig[1] >= eig[2] * (1 - 1e-9)  # triangle inequality
    assert set(doc["consistency"]["standard"]) == set(ROBOT.standard_names)
    assert doc["consistency"]["answer"] == "identification"
    plain = identify(BAGS, model=ORTHOGLIDE).to_json()
    assert "standard_parameters" not in plain and "consistency" not in plain
    for key in ("drive_gains", "parameters", "payload_mass", "residual_rms", "condition_number"):
        assert json.dumps(doc[key]) == json.dumps(plain[key])  # the answer itself unchanged
    text = bag_result.to_text()
    assert "physical consistency" in text and "consistent" in text.split("physical consistency")[1]


def test_prior_from_a_file(tmp_path, bag_result, truth):
    prior = {n: float(v) for n, v in zip(ROBOT.standard_names, truth) if n.startswith("m_")}
    path = tmp_path / "prior.json"
    path.write_text(json.dumps(prior))
    assert C.read_prior(str(path)) == prior
    out = tmp_path / "result.json"
    out.write_text(json.dumps(bag_result.to_json()))
    assert set(C.read_prior(str(out))) == set(ROBOT.standard_names)
    path.write_text(json.dumps({"m_99": 1.0}))
    lay_err = pytest.raises(ConfigError, layout, ROBOT, C.read_prior(str(path)))
    assert "m_99" in str(lay_err.value)
    path.write_text("[1, 2")
    with pytest.raises(ConfigError, match="not valid JSON"):
        C.read_prior(str(path))


@pytest.mark.slow
def test_realistic_records_consistent_answer_within_sigma_and_nearer_the_truth(truth):
    from simulated import simulated_pair

    recs = simulated_pair(15.0, (5, 6), "real", profile="realistic")
    res = identify_records(recs, options=IdentifyOptions.of(consistent=True), model=ORTHOGLIDE)
    c = res.consistency
    W = np.diag(1.0 / c.sigma_b)
    chi_b_true = K @ truth
    d2 = {k: float(np.sum((W @ (x - chi_b_true)) ** 2))
          for k, x in (("tls", c.chi_hat), ("consistent", c.identified.chi_b))}
    for fit in (c.projection, c.identified):
        assert min_eigenvalues(c.lay, fit.chi_st).min() > 0.99 * MARGIN
        assert np.abs((fit.chi_b - c.chi_hat) / c.sigma_b).max() < 3.0
    assert c.to_json()["identification"]["residual_increase"] < 0.005
    # the constraints carry information the records lack: the consistent answer is nearer the
    # plant's true base parameters (bench/consistency.py: d² 86 -> 29 at 30 s + 30 s)
    assert d2["consistent"] < d2["tls"]


def test_cli_writes_the_urdf_and_the_json(tmp_path, capsys):
    import pinocchio as pin
    urdf, out = tmp_path / "identified.urdf", tmp_path / "result.json"
    assert cli.main(["identify", *BAGS, "--urdf-out", str(urdf), "--json", str(out), "-q"]) == 0
    assert "physical consistency" in capsys.readouterr().out
    doc = json.loads(out.read_text())
    model = pin.buildModelFromUrdf(str(urdf))
    masses = {b["body"]: b["mass"] for b in doc["standard_parameters"]}
    assert model.inertias[model.getJointId("q31")].mass == pytest.approx(
        masses["body 3 of leg 1"], rel=1e-15)
    assert cli.main(["identify", "--service", "--consistent"]) == cli.EXIT_BAD_INPUT
    assert "parameter consistent" in capsys.readouterr().err
