"""The base-parameter count of a robot behind a transmission does not depend on the scale of
its reduction N (issue 43: an invertible reduction scaled by 1e-12 changed the UR5's count,
silently). The reference: the numerical rank of W_st with its columns scaled to unit norm
(SVD, numpy), and the exact regrouping W_st = W_b K (eq. 21) at other random states."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

from orthoglide_ident.model.registry import ROBOTS_DIR, load_robot

# the UR5 with gears and a coupled wrist (motor 5 also drives joint 6), invertible
REDUCTION = np.diag([100.0, 100.0, 100.0, 50.0, 50.0, 50.0])
REDUCTION[4, 5] = 32.0


def _ur5_behind(tmp_path, scale: float):
    data = yaml.safe_load((ROBOTS_DIR / "ur5.yaml").read_text())
    data.pop("excitation")
    data.update(name="ur5_geared", description=str(ROBOTS_DIR / "ur5.urdf"),
                transmission={"reduction": (scale * REDUCTION).tolist()})
    path = tmp_path / f"ur5_geared_{scale:g}.yaml"
    path.write_text(yaml.safe_dump(data))
    return load_robot(path)


def _scaled_rank(W: np.ndarray) -> int:
    norms = np.linalg.norm(W, axis=0)
    s = np.linalg.svd(W[:, norms > 0] / norms[norms > 0], compute_uv=False)
    return int(np.sum(s > 1e-8 * s[0]))


@pytest.mark.parametrize("scale", [1.0, 1e-12, 1e-6, 1e6])
def test_the_base_count_does_not_depend_on_the_reductions_scale(tmp_path, scale):
    robot = _ur5_behind(tmp_path, scale)
    q, qd, qdd = robot.random_states(60, seed=5)
    W_st = robot.standard_regressor(q, qd, qdd)
    assert robot.n_b == _scaled_rank(W_st) == 58  # the UR5's 58 without a transmission
    # the regrouping is exact: each standard column is the base columns times K
    W_b = robot.regressor(q, qd, qdd)
    err = np.linalg.norm(W_b @ robot.K - W_st, axis=0)
    assert np.all(err <= 1e-7 * np.maximum(np.linalg.norm(W_st, axis=0), 1e-300))
