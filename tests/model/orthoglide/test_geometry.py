"""The Orthoglide's dimensions are configuration: another geometry, the same checks as the paper's.

An Orthoglide built smaller (a = 0.24, d4 = 0.22, d6 = 0.02 m; a = d4 + d6 puts q = 0 at the
isotropic point, as the paper's) from a robot YAML: the closed-form
IDIM agrees with the independent virtual-power inverse dynamics of test_idim.py evaluated with those
dimensions, the loops close, and the base model keeps the paper's 61 symmetric base parameters
with the regrouping coefficients of its own d4 and g.
"""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import test_idim as ref

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.model.orthoglide.base import base_model
from orthoglide_ident.model.orthoglide.geometry import Geometry
from orthoglide_ident.model.orthoglide.idim import standard_regressor
from orthoglide_ident.model.orthoglide.kinematics import fgm, igm, loop_closure_residual, tree_state
from orthoglide_ident.model.registry import load_robot

SMALL = Geometry(a=0.24, d4=0.22, d6=0.02, g0=9.81)


@pytest.fixture
def small_reference(monkeypatch):
    """test_idim's virtual-power reference with SMALL's dimensions."""
    a, d4, d6 = SMALL.a, SMALL.d4, SMALL.d6
    monkeypatch.setattr(ref, "a", a)
    monkeypatch.setattr(ref, "d4", d4)
    monkeypatch.setattr(ref, "d6", d6)
    monkeypatch.setattr(ref, "GRAV", jnp.array([0.0, SMALL.g0, 0.0]))
    monkeypatch.setattr(ref, "FOOT", [(0, 0, 0, 0, 0, 0), (np.pi / 2, a, np.pi / 2, 0, 0, -a),
                                      (0, a, -np.pi / 2, 0, -np.pi / 2, -a)])
    monkeypatch.setattr(ref, "PIVOTS", [(-np.pi / 2, 0.0), (-np.pi / 2, 0.0), (0.0, d4),
                                        (np.pi / 2, 0.0)])
    # a new jit boundary: jax caches traces per jitted function, and these globals are not part
    # of the key (jitting reference_tau itself would hand test_idim this geometry's trace)
    return jax.jit(lambda *args: ref.reference_tau(*args))


def test_another_geometry_matches_the_independent_inverse_dynamics(small_reference):
    model = base_model(SMALL)
    q, qd, qdd = model.random_states(5, seed=3)
    qd = qd * 0.5 + np.sign(qd) * 0.3  # every tree joint away from zero velocity (sign())
    chi, chi_l = ref.random_physical(4)
    W, W_l = standard_regressor(q, qd, qdd, SMALL)
    tau = (W @ chi + W_l @ chi_l).reshape(3, -1).T
    for n in range(q.shape[0]):
        expect = np.asarray(small_reference(q[n], qd[n], qdd[n], jnp.asarray(chi),
                                            jnp.asarray(chi_l)))
        assert np.max(np.abs(tau[n] - expect)) <= 1e-8 * np.max(np.abs(expect))
    # the paper's dimensions give other forces: the geometry is really used
    W0, _ = standard_regressor(q, qd, qdd)
    assert np.max(np.abs(W0 @ chi - W @ chi)) > 1e-2 * np.max(np.abs(W @ chi))


def test_another_geometry_kinematics_and_base_parameters(tmp_path):
    f = tmp_path / "small.yaml"
    f.write_text("name: small\nmodel: orthoglide\ngeometry: {a: 0.24, d4: 0.22, d6: 0.02, "
                 "gravity: 9.81}\nnominal_gains: [1500, 1510, 1520]\n")
    model = load_robot(str(f))
    assert model.geometry == SMALL and list(model.nominal_gains) == [1500, 1510, 1520]
    q, qd, qdd = model.random_states(40, seed=5)
    s = tree_state(q, qd, qdd, geom=SMALL)
    assert np.max(np.abs(igm(s.P, SMALL) - q)) < 1e-12
    assert np.max(np.abs(loop_closure_residual(q, s.P, s.qt, SMALL))) < 1e-12
    assert np.allclose(fgm(np.zeros(3), SMALL), [0.0, 0.0, 0.24])
    paper = base_model()
    assert model.names == paper.names  # the same 61 symmetric base parameters
    m_11R = dict(next(p for p in model.parameters if p.name == "m_11R").terms)
    assert m_11R["mx_31"] == pytest.approx(-1 / 0.22, rel=1e-6)  # m_11R = m_11 + ... - mx_31 / d4
    m_13R = dict(next(p for p in model.parameters if p.name == "m_13R").terms)
    assert m_13R["tauoff_13"] == pytest.approx(-1 / 9.81, rel=1e-6)  # the vertical leg: 1/g
    W_st = model.standard_regressor(q, qd, qdd)
    chi = np.random.default_rng(0).normal(size=W_st.shape[1])
    assert np.allclose(model.regressor(q, qd, qdd) @ model.base_values(chi), W_st @ chi,
                       atol=1e-9 * np.abs(W_st @ chi).max())


def test_bad_geometry_is_a_one_line_reason(tmp_path):
    for text, match in (("geometry: {a: 0.3, d4: 0.02, d6: 0.03}", "0 < d6 < d4"),
                        ("geometry: {a: 0.3, length: 1}", "geometry takes"),
                        ("nominal_gains: [1, 2]", "3 numbers"),
                        ("wheels: 4", "unknown key")):
        f = tmp_path / f"bad{len(match)}.yaml"  # one file each: models are cached per file
        f.write_text(f"name: bad\nmodel: orthoglide\n{text}\n")
        with pytest.raises(ConfigError, match=match):
            load_robot(str(f))
