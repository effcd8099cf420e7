"""The identified model as a URDF (model/urdf.py): Pinocchio loads it with the same inertials.

The Orthoglide's open tree carries every body's 10 parameters in its MDH frame (the platform
merged into body 5 of leg 1 by Pinocchio); closed by two welds it is the closed-form model
(tests/identify/validate/test_direct_dynamics.py). A URDF robot's own file gets its inertials
replaced,
the links merged into a body emptied, friction in <dynamics>.
"""
from __future__ import annotations

import importlib
import math
import xml.etree.ElementTree as ET

import numpy as np
import pinocchio as pin
import pytest
from serial_arm import SerialArm

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.model.forward import pin_inertia
from orthoglide_ident.model.registry import load_robot
from orthoglide_ident.model.urdf import rpy

ROBOT = load_robot(None)
GAINS = [2170.0, 2100.0, 2070.0]


@pytest.fixture(scope="module")
def truth() -> np.ndarray:
    return importlib.import_module("orthoglide_sim.orthoglide.truth").default_parameters() \
        .standard_vector()


@pytest.fixture(scope="module")
def arm(tmp_path_factory) -> SerialArm:
    return SerialArm(tmp_path_factory.mktemp("arm") / "arm3.urdf", n_states=120)


def _params(chi: np.ndarray, body) -> pin.Inertia:
    return pin_inertia(chi[list(body.inertial)])


def test_orthoglide_urdf_loads_in_pinocchio_with_the_same_inertials(truth, tmp_path):
    path = tmp_path / "orthoglide.urdf"
    path.write_text(ROBOT.identified_urdf(truth, GAINS))
    model = pin.buildModelFromUrdf(str(path))
    assert model.nq == model.nv == 15
    platform = model.frames[model.getFrameId("platform")]
    worst = 0.0
    for body in ROBOT.bodies[:-1]:
        j, i = body.frame.split("_")
        expected = _params(truth, body)
        if body.frame == "5_1":  # Pinocchio merges the fixed platform into body 5 of leg 1
            expected = expected + platform.placement.act(_params(truth, ROBOT.bodies[-1]))
        got = model.inertias[model.getJointId(f"q{j}{i}")]
        worst = max(worst, np.abs(got.toDynamicParameters() - expected.toDynamicParameters()).max())
    assert worst < 1e-15
    values = dict(zip(ROBOT.standard_names, truth))
    iv = model.joints[model.getJointId("q23")].idx_v
    assert model.damping[iv] == values["fv_23"] and model.friction[iv] == values["fs_23"]
    text = path.read_text()
    assert "ia_11 = 4.85" in text and "q11 2170 N/A" in text and "closed by the product" in text


def test_rpy_inverts_the_rotation():
    rng = np.random.default_rng(3)
    for a in rng.uniform(-math.pi, math.pi, (20, 3)).tolist() + [[0.3, math.pi / 2, -1.0]]:
        R = pin.rpy.rpyToMatrix(*a)
        assert np.allclose(pin.rpy.rpyToMatrix(*rpy(R)), R, atol=1e-12)


def test_urdf_robot_gets_its_own_file_with_the_inertials_replaced(arm):
    chi = arm.standard_values()
    rng = np.random.default_rng(0)
    for body in arm.bodies:  # another consistent set: each body 20 % heavier, shifted
        idx = list(body.inertial)
        chi[idx] = chi[idx] * (1.2 + 0.1 * rng.uniform())
    text = arm.identified_urdf(chi, [10.6, 9.7, 10.3])
    model = pin.buildModelFromXML(text)
    for k, body in enumerate(arm.bodies, start=1):
        got = model.inertias[k].toDynamicParameters()
        assert np.abs(got - _params(chi, body).toDynamicParameters()).max() < 1e-14
    root = ET.fromstring(text)
    tool = next(el for el in root.findall("link") if el.get("name") == "tool")
    assert tool.find("inertial") is None  # merged into link3, whose identified body holds it
    j2 = next(el for el in root.findall("joint") if el.get("name") == "j2")
    assert float(j2.find("dynamics").get("damping")) == pytest.approx(chi[arm.standard_names.index(
        "fv_2")])
    assert "ia_2 = " in text and "j1 10.6 N·m/A" in text


def test_robot_without_a_urdf_description_is_a_one_line_reason(arm):
    class NoFile(SerialArm):
        description = None

    robot = object.__new__(NoFile)
    robot.__dict__.update({k: v for k, v in arm.__dict__.items() if k != "description"})
    with pytest.raises(ConfigError, match="not described by a URDF"):
        robot.identified_urdf(arm.standard_values(), [1.0, 1.0, 1.0])


def test_mujoco_loads_the_orthoglide_urdf_with_the_same_masses(truth, tmp_path):
    import mujoco
    path = tmp_path / "orthoglide.urdf"
    path.write_text(ROBOT.identified_urdf(truth, GAINS))
    m = mujoco.MjModel.from_xml_path(str(path))
    masses = {mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b): m.body_mass[b]
              for b in range(m.nbody)}
    for body in ROBOT.bodies:
        name = "platform" if body.frame == "platform" else "body_" + body.frame.replace("_", "")
        assert masses[name] == pytest.approx(truth[body.inertial[-1]], rel=1e-12)
