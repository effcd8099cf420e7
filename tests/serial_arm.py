"""A small serial arm described by a URDF, as a RobotModel on Pinocchio: a test fixture.

Three revolute joints (z, y, y), a tool link fixed to the last link (Pinocchio merges it into
that body: the identified body holds both), gravity −z. What the general model (URDF robots)
offers the consistency step, written small: bodies named by their links, standard names
``<kind>_<label>`` (INERTIAL_KINDS at the link frame, then ia, fv, fs, tauoff of the joint that
moves it), base parameters by QR on random states (eq. 22), ``standard_values()`` = the URDF's,
``description.path`` = the URDF. Rows from Pinocchio's joint-torque regressor (which omits
armature and friction: their columns are added here).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin

from orthoglide_ident.model.robot import INERTIAL_KINDS, ActuatedJoint, Body, Payload, RobotModel

DRIVE = ("ia", "fv", "fs", "tauoff")
# Pinocchio's dynamic parameters [m, mx, my, mz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz] -> INERTIAL_KINDS
PIN_ORDER = [4, 5, 7, 6, 8, 9, 1, 2, 3, 0]
NOMINAL_GAIN = 10.0  # N·m/A
TRUE_GAINS = np.array([10.6, 9.7, 10.3])
FRICTION = {"1": (0.9, 0.6, 0.05), "2": (1.1, 0.8, -0.04), "3": (0.7, 0.4, 0.02)}  # fv, fs, off
ARMATURE = {"1": 0.02, "2": 0.015, "3": 0.01}  # kg·m²

URDF = """<?xml version="1.0"?>
<robot name="arm3">
  <link name="base_link"/>
  <link name="link1"><inertial><origin xyz="0.01 -0.02 0.08" rpy="0 0 0"/><mass value="3.0"/>
    <inertia ixx="0.020" ixy="0.001" ixz="-0.002" iyy="0.018" iyz="0.0015"
    izz="0.012"/></inertial></link>
  <link name="link2"><inertial><origin xyz="0.15 0.01 0.02" rpy="0 0 0"/><mass value="2.2"/>
    <inertia ixx="0.004" ixy="0.0005" ixz="0.0003" iyy="0.030" iyz="-0.0002"
    izz="0.029"/></inertial></link>
  <link name="link3"><inertial><origin xyz="0.12 -0.01 0.0" rpy="0 0 0"/><mass value="1.4"/>
    <inertia ixx="0.002" ixy="-0.0002" ixz="0.0001" iyy="0.012" iyz="0.0001"
    izz="0.011"/></inertial></link>
  <link name="tool"><inertial><origin xyz="0.0 0.0 0.03" rpy="0 0 0"/><mass value="0.3"/>
    <inertia ixx="0.0003" ixy="0" ixz="0" iyy="0.0003" iyz="0" izz="0.0002"/></inertial></link>
  <joint name="j1" type="revolute"><parent link="base_link"/><child link="link1"/>
    <origin xyz="0 0 0.1" rpy="0 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="100" velocity="5"/></joint>
  <joint name="j2" type="revolute"><parent link="link1"/><child link="link2"/>
    <origin xyz="0 0 0.2" rpy="1.5707963267948966 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="100" velocity="5"/></joint>
  <joint name="j3" type="revolute"><parent link="link2"/><child link="link3"/>
    <origin xyz="0.3 0 0" rpy="0 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="100" velocity="5"/></joint>
  <joint name="tool_fixed" type="fixed"><parent link="link3"/><child link="tool"/>
    <origin xyz="0.25 0 0" rpy="0 0 0"/></joint>
</robot>
"""


@dataclass(frozen=True)
class Description:
    """The parts of a robot file's description (model/robot_file.py) the product reads."""

    path: Path
    gravity: tuple[float, float, float] = (0.0, 0.0, -9.80665)
    current_sampling: str | None = None  # the robot file says nothing (auto decides)


class SerialRobot(RobotModel):
    """Any serial URDF tree whose movable joints are all actuated, on Pinocchio: bodies are the
    joints' child links (labels 1..n from the base), ``friction``/``armature`` per label the
    drive terms ``standard_values()`` adds to the URDF's inertials."""

    def __init__(self, path: Path, name: str, nominal_gains, payload_frame: str,
                 friction: dict[str, tuple[float, float, float]], armature: dict[str, float],
                 n_states: int = 400):
        import xml.etree.ElementTree as ET

        self.name, self.payload_frame = name, payload_frame
        self.description = Description(Path(path))
        self.model = pin.buildModelFromUrdf(str(path))
        self.model.gravity = pin.Motion(np.array(self.description.gravity), np.zeros(3))
        self.data = self.model.createData()
        names = [self.model.names[j] for j in range(1, self.model.njoints)]
        child = {el.get("name"): el.find("child").get("link")
                 for el in ET.parse(path).getroot().findall("joint")}
        self.joints = tuple(ActuatedJoint(n, "revolute", float(g))
                            for n, g in zip(names, nominal_gains))
        labels = [str(k) for k in range(1, len(names) + 1)]
        self.friction, self.armature = friction, armature
        self.standard_names = tuple(f"{k}_{b}" for b in labels for k in INERTIAL_KINDS + DRIVE)
        index = {n: i for i, n in enumerate(self.standard_names)}
        self.bodies = tuple(Body(child[n], tuple(index[f"{k}_{b}"] for k in INERTIAL_KINDS),
                                 child[n]) for n, b in zip(names, labels))
        # 1 kg at the payload frame, as parameters of the body it is fixed to (Pinocchio order)
        f = self.model.frames[self.model.getFrameId(payload_frame)]
        self._payload_joint = f.parentJoint
        self._payload_params = f.placement.act(pin.Inertia.FromDynamicParameters(
            pin_parameters(Payload(1.0, payload_frame).shape()))).toDynamicParameters()
        self._base(n_states)

    def _base(self, n_states: int) -> None:
        """Base parameters by QR of W_st on random states (eq. 22), K = [1 | β] (eq. 21)."""
        W = self.standard_regressor(*self.random_states(n_states, seed=5))
        R = np.linalg.qr(W, mode="r")
        d = np.abs(np.diag(R))
        keep = d > 1e-8 * d.max()
        self.kept = np.flatnonzero(keep)
        beta = np.linalg.lstsq(W[:, keep], W[:, ~keep], rcond=None)[0]
        self.K = np.zeros((keep.sum(), len(self.standard_names)))
        self.K[np.arange(keep.sum()), self.kept] = 1.0
        self.K[:, ~keep] = np.where(np.abs(beta) < 1e-9, 0.0, beta)
        self.names = [self.standard_names[i] + "R" for i in self.kept]
        self.expressions = [""] * len(self.names)

    def _rows(self, q, qd, qdd) -> tuple[np.ndarray, np.ndarray]:
        """(m, n, n_st) standard rows and (m, n) payload rows per kg, sample by sample."""
        m, n = q.shape
        out, pay = np.zeros((m, n, len(self.standard_names))), np.zeros((m, n))
        c = 10 * (self._payload_joint - 1)
        for k in range(m):
            Y = pin.computeJointTorqueRegressor(self.model, self.data, q[k], qd[k], qdd[k])
            for b in range(n):
                out[k, :, 14 * b:14 * b + 10] = Y[:, 10 * b:10 * b + 10][:, PIN_ORDER]
                out[k, b, 14 * b + 10:14 * b + 14] = [qdd[k, b], qd[k, b], np.sign(qd[k, b]), 1.0]
            pay[k] = Y[:, c:c + 10] @ self._payload_params
        return out, pay

    def standard_regressor(self, q, qd, qdd) -> np.ndarray:
        rows, _ = self._rows(*(np.atleast_2d(x) for x in (q, qd, qdd)))
        return rows.transpose(1, 0, 2).reshape(-1, rows.shape[2])

    def observation_block(self, q, qd, qdd, out=None) -> np.ndarray:
        rows, pay = self._rows(*(np.atleast_2d(np.asarray(x, float)) for x in (q, qd, qdd)))
        X = np.concatenate([rows[:, :, self.kept].transpose(2, 1, 0), pay.T[None]])
        if out is not None:
            out[...] = X
            return out
        return X

    def with_payload(self, payload: Payload) -> SerialRobot:
        return self

    def random_states(self, n: int, seed: int = 0):
        rng = np.random.default_rng(seed)
        nj = self.n_joints
        return (rng.uniform(-2, 2, (n, nj)), rng.normal(0, 1, (n, nj)), rng.normal(0, 5, (n, nj)))

    def standard_values(self) -> np.ndarray:
        """The URDF's own χ_st (fixed links merged), the friction and armature given."""
        out = []
        for k, _body in enumerate(self.bodies, start=1):
            pi = self.model.inertias[k].toDynamicParameters()
            fv, fs, off = self.friction[str(k)]
            out += list(pi[PIN_ORDER]) + [self.armature[str(k)], fv, fs, off]
        return np.array(out)

    def table(self) -> str:
        return "\n".join(self.names)

    def to_json(self) -> dict:
        return {"names": list(self.names)}


class SerialArm(SerialRobot):
    """The 3-joint arm above, its URDF written to ``path``."""

    def __init__(self, path: Path, n_states: int = 400):
        path.write_text(URDF)
        super().__init__(path, "arm3", [NOMINAL_GAIN] * 3, "tool", FRICTION, ARMATURE,
                         n_states)


def ur5(n_states: int = 400) -> SerialRobot:
    """The bundled UR5 (orthoglide_ident/robots/ur5.urdf) as a SerialRobot, 2 kg payload at
    tool0, plausible friction and rotor inertias (the URDF has none)."""
    from orthoglide_ident.model.registry import ROBOTS_DIR

    fr = {str(k): (1.5 - 0.1 * k, 2.0 - 0.2 * k, 0.1 * (-1) ** k) for k in range(1, 7)}
    arm = {str(k): (0.3 if k <= 3 else 0.05) for k in range(1, 7)}
    return SerialRobot(ROBOTS_DIR / "ur5.urdf", "ur5", [13.0, 13.0, 13.0, 9.3, 9.3, 9.3],
                       "tool0", fr, arm, n_states)


def pin_parameters(chi10: np.ndarray) -> np.ndarray:
    """INERTIAL_KINDS order -> Pinocchio's [m, mx, my, mz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz]."""
    out = np.empty(10)
    out[PIN_ORDER] = chi10
    return out
