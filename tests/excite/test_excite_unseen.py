"""An arm the product never saw, from its URDF alone plus a payload mass (issue 46): the
example-robot-data UR10 (no acceleration limits, no start pose, collision meshes) is designed
with the defaults and stays within its URDF's limits on the 1 ms grid, collision-free."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from example_robots import urdf

from orthoglide_ident.excite.collision import CollisionModel
from orthoglide_ident.excite.design import DesignOptions, design
from orthoglide_ident.excite.limits import read_limits
from orthoglide_ident.excite.prediction import DEFAULT_CURRENT_NOISE
from orthoglide_ident.model.registry import load_robot
from orthoglide_ident.model.robot import Payload

TICK = 1e-3  # s, the controller's grid the design is checked on


def ur10_urdf() -> Path:
    return urdf("ur_description/urdf/ur10_robot.urdf")


@pytest.mark.slow
def test_unseen_ur10_designs_within_its_urdf_limits_on_the_1ms_grid():
    path = ur10_urdf()
    robot = load_robot(str(path))
    d = design(robot, read_limits(robot), CollisionModel(robot, "mesh", [str(path.parents[4])]),
               DesignOptions(Payload(1.0), np.full(robot.n_joints, DEFAULT_CURRENT_NOISE)),
               progress=lambda _: None)
    assert d.check.ok, d.check.to_text()
    # measured (bench/excite_unseen.py): 0.96 % against a random median of 4.6 %
    # a bare mass at its flange sits on both wrist axes: no torque on them, gains not excited
    # (the identification's rule, tests/excite/test_excite_payload_share.py); the rest designed
    random = [e.prediction.worst_determined_gain() for e in d.random if e.prediction is not None]
    assert d.prediction.not_loaded == ("wrist_2_joint", "wrist_3_joint")
    assert np.all(np.isfinite(d.prediction.gain_rel_std[:4]))
    assert d.prediction.worst_determined_gain() < np.median(random)
    assert d.check.by_kind()["collision"].value > 0.0
    # the URDF's own limits, read by Pinocchio, on every 1 ms tick of both runs
    model = pin.buildModelFromUrdf(str(path))
    lo, hi, vmax = model.lowerPositionLimit, model.upperPositionLimit, model.velocityLimit
    for run in ("unloaded", "loaded"):
        t = np.arange(0.0, d.trajectory.duration, TICK)
        q, qd, _ = d.trajectory.evaluate(run, t)
        assert np.all(q >= lo) and np.all(q <= hi), run
        assert np.all(np.abs(qd) <= vmax), run
