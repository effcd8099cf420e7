"""The search with gradients (issue 46, excite/gradient.py): the analytic gradients of the
criterion's terms and of the effort constraints against central finite differences of the
product's own prediction (prediction.run_rows, information, from_information: not the code
under test), and the polished design passes the 1 ms check or is repaired."""
from __future__ import annotations

import math

import numpy as np
import pytest
from excite_robots import two_link_urdf

from orthoglide_ident.excite.check import check_trajectory
from orthoglide_ident.excite.collision import CollisionModel
from orthoglide_ident.excite.design import (
    COND_WEIGHT,
    SEARCH_CAP,
    DesignOptions,
    Problem,
    design,
)
from orthoglide_ident.excite.gradient import NEAR_SLACK, Polish
from orthoglide_ident.excite.limits import read_limits
from orthoglide_ident.excite.prediction import (
    RunSamples,
    from_information,
    information,
    run_rows,
)
from orthoglide_ident.model.registry import load_robot
from orthoglide_ident.model.robot import Payload

FD_STEP = 1e-6  # on the reduced coefficients (rad/s) and the amplitudes
REL_TOL = 1e-5


def _reference(nlp: Polish, v: np.ndarray) -> np.ndarray:
    """[log σ(g_j)/g_j, log κ, τ_j(t)/τ_max,j of both runs] of v by the prediction module."""
    p = nlp.problem
    traj, F, taus = nlp.trajectory(v), 0.0, []
    for name, payload in p.runs:
        q, qd, qdd = traj.evaluate(name, p.t)
        qd[p.t == 0], qdd[p.t == 0] = 0.0, 0.0  # at rest (|q̇(0)| ~ 1e-17: sign(q̇) would flip)
        X, tau = run_rows(p.robot, p.chi_b, p.gains, RunSamples(q, qd, qdd, traj.duration,
                                                                 payload))
        F = F + information(X, tau, p.gains, p.opt.noise_a, 1000.0 * traj.duration / len(p.t),
                            p.lag_rate(tau))
        taus.append((tau / nlp.effort[:, None]).ravel())
    pred = from_information(F, p.chi_b, p.gains, p.opt.noise_a, SEARCH_CAP)
    return np.concatenate([np.log(pred.gain_rel_std), [math.log(pred.condition_kept)]] + taus)


def _analytic(nlp: Polish, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    t = nlp.terms(v)
    # per run: slack − u, then slack + u (u = τ/τ_max): the second halves, whose Jacobian is +∂u
    u = t["effort"].reshape(2, 2, -1)[:, 1].ravel() - (1 - nlp.opt.margins.effort)
    J = t["effort_jac"].reshape(2, 2, -1, nlp.size)[:, 1].reshape(-1, nlp.size)
    return np.concatenate([t["vals"], u]), np.concatenate([t["grad"], J])


@pytest.mark.parametrize("robot_name,harmonics", [("ur5", 3), ("two_link", 3)])
def test_gradients_match_finite_differences(tmp_path, robot_name, harmonics):
    if robot_name == "two_link":
        robot = load_robot(str(two_link_urdf(tmp_path)))
        limits = read_limits(robot)
        payload = Payload(0.5, "", (0.02, 0.0, 0.05), (1e-3, 0, 0, 1e-3, 0, 1e-3))
    else:
        robot = load_robot("ur5")
        limits = read_limits(robot)
        payload = Payload(2.0, "tool0", (0.035, -0.025, 0.06), (4e-3, 0, 0, 4e-3, 0, 2.5e-3))
    opt = DesignOptions(payload, np.full(robot.n_joints, 0.02), harmonics=harmonics, samples=24)
    problem = Problem(robot, limits, None, opt)
    nlp = Polish(problem, SEARCH_CAP, COND_WEIGHT, np.ones(robot.n_joints, bool))
    rng = np.random.default_rng(7)
    x = np.concatenate([rng.normal(size=problem.size - 2), [0.3, -0.2]])
    v = nlp.start(x)
    vals, J = _analytic(nlp, v)
    nlp._cache = None  # the line search's values, without the partials: the same
    lazy = nlp.terms(v, grad=False)
    full = nlp.terms(v)
    assert full is not lazy
    np.testing.assert_allclose(np.append(lazy["vals"], lazy["effort"]),
                               np.append(full["vals"], full["effort"]), rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(vals, _reference(nlp, v), rtol=1e-9, atol=1e-12)
    fd = np.empty_like(J)
    for k in range(nlp.size - 1):  # the epigraph variable t enters no term
        e = np.zeros(nlp.size)
        e[k] = FD_STEP
        fd[:, k] = (_reference(nlp, v + e) - _reference(nlp, v - e)) / (2 * FD_STEP)
    fd[:, -1] = 0.0
    # the efforts at t = 0 (at rest at P whatever v): a null gradient, up to FD rounding
    at_rest = np.zeros(len(J), bool)
    at_rest[robot.n_joints + 1:] = np.tile(problem.t == 0, 2 * robot.n_joints)
    assert np.abs(J[at_rest]).max() == 0.0 and np.abs(fd[at_rest]).max() < 1e-8
    J, fd = J[~at_rest], fd[~at_rest]
    err = np.linalg.norm(J - fd, axis=1) / np.linalg.norm(fd, axis=1)
    assert err.max() < REL_TOL, (err.argmax(), err.max())


def test_polished_design_passes_the_1ms_check(tmp_path):
    urdf = two_link_urdf(tmp_path)
    y = tmp_path / "arm.yaml"
    y.write_text(f"name: two_link\ndescription: {urdf.name}\nexcitation:\n"
                 "  acceleration_limits: 10.0\n")
    robot = load_robot(str(y))
    limits = read_limits(robot)
    collision = None
    kw = dict(periods=2, restarts=4, steps=20, samples=20)
    walk = design(robot, limits, collision, DesignOptions(Payload(0.5), np.full(2, 0.02), **kw),
                  progress=lambda _: None)
    said = []
    d = design(robot, limits, collision, DesignOptions(Payload(0.5), np.full(2, 0.02),
                                                       search="gradient", **kw),
               progress=said.append)
    # the 1 ms check again, independently of the design's own report
    assert check_trajectory(d.trajectory, robot, limits, collision, d.problem.opt.margins).ok
    assert any(s.startswith("gradient polish") for s in said)
    assert d.criterion <= walk.criterion + 1e-9


def test_collision_gradient_matches_finite_differences():
    """The distance constraints (smallest distance over the UR5's mesh pairs, every 4th sample)
    against central differences of CollisionModel.distances_above on the trajectory's poses; looser
    (1e-3) than the rest: the analytic side is itself a difference of GJK distances."""
    robot = load_robot("ur5")
    collision = CollisionModel(robot, "mesh")
    opt = DesignOptions(Payload(2.0, "tool0"), np.full(robot.n_joints, 0.02), harmonics=2,
                        samples=24)
    problem = Problem(robot, read_limits(robot), collision, opt)
    nlp = Polish(problem, SEARCH_CAP, COND_WEIGHT, np.ones(robot.n_joints, bool), 4)
    x = np.concatenate([np.random.default_rng(3).normal(size=problem.size - 2), [0.3, -0.2]])
    v = nlp.start(x)

    def distances(w: np.ndarray) -> np.ndarray:
        traj, out = nlp.trajectory(w), []
        for name, _ in problem.runs:
            Q, _ = problem.tree.configurations(traj.evaluate(name, problem.t[::4])[0])
            # exact within 2.5 margins (gradient.POSE_BOUND), the spheres' bound beyond
            out.append(collision.distances_above(Q, 0.05).min(axis=1))
        return np.concatenate(out)

    t = nlp.terms(v)
    np.testing.assert_allclose(t["collision"] * 0.02 + 0.02, distances(v), atol=1e-9)
    fd = np.empty_like(t["collision_jac"])
    for k in range(nlp.size):
        e = np.zeros(nlp.size)
        e[k] = 1e-5
        fd[:, k] = (distances(v + e) - distances(v - e)) / 2e-5 / 0.02
    # derived where the slack is within NEAR_SLACK (0 beyond: inactive), not at t = 0 (at P)
    near = t["collision"] < NEAR_SLACK
    assert not t["collision_jac"][~near].any()
    moving = near & (np.linalg.norm(fd, axis=1) > 1e-6)
    err = np.linalg.norm(t["collision_jac"] - fd, axis=1)[moving] / \
        np.linalg.norm(fd, axis=1)[moving]
    assert moving.sum() >= 4 and err.max() < 1e-3, (moving.sum(), err)


def test_cli_search_gradient_writes_a_checked_design(tmp_path, capsys):
    from orthoglide_ident.cli import main
    from orthoglide_ident.excite.trajectory import load_trajectory

    urdf = two_link_urdf(tmp_path)
    y = tmp_path / "arm.yaml"
    y.write_text(f"name: two_link\ndescription: {urdf.name}\nexcitation:\n"
                 "  acceleration_limits: 10.0\n")
    out = tmp_path / "traj.yaml"
    assert main(["excite", "design", "--robot", str(y), "--payload-mass", "0.5", "--out",
                 str(out), "--restarts", "2", "--periods", "2", "--search", "gradient",
                 "--collision", "skip"]) == 0
    traj = load_trajectory(out)
    assert all(v["ok"] for v in traj.extra["margins"]["worst"].values())
    assert traj.extra["design"]["search"] == "gradient" and traj.extra["design"]["steps"] == 0
    with pytest.raises(SystemExit) as exc:  # argparse: one line naming the choices
        main(["excite", "design", "--robot", str(y), "--payload-mass", "0.5", "--out", str(out),
              "--search", "newton"])
    assert exc.value.code == 2 and "choose from 'walk', 'gradient'" in capsys.readouterr().err
