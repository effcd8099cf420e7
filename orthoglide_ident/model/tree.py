"""The open tree of a robot description on Pinocchio: loading, joints, links, coordinates.

A URDF (``.urdf``) or an MJCF (``.xml``, with its ``<equality>`` loops) becomes one
``pin.Model``: a body per movable joint (the joint's child link, with the links fixed to it
merged in, Pinocchio's convention), frames for every link, joint and site. This module says
which joints move, which link each joint carries, where a fixed link sits and what it weighs,
and writes joint values into Pinocchio configuration vectors (an unbounded revolute joint is
(cos θ, sin θ) there). Failures are ConfigErrors with the parser's own one-line reason.
"""
from __future__ import annotations

import contextlib
import math
import os
import tempfile
import xml.etree.ElementTree as ET
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.model.loop_constraints import load_mjcf

# Pinocchio's 1-DOF joint models: prismatic, revolute, unbounded revolute (URDF "continuous").
_PRISMATIC = ("JointModelPX", "JointModelPY", "JointModelPZ", "JointModelPrismaticUnaligned")
_REVOLUTE = ("JointModelRX", "JointModelRY", "JointModelRZ", "JointModelRevoluteUnaligned")
_UNBOUNDED = ("JointModelRUBX", "JointModelRUBY", "JointModelRUBZ",
              "JointModelRevoluteUnboundedUnaligned")


@dataclass(frozen=True)
class TreeJoint:
    """A movable joint of the tree: Pinocchio ids and indices, kind, limits, nominal friction."""

    name: str
    id: int  # Pinocchio joint id (1..njoints-1)
    iq: int  # first index in the configuration vector
    iv: int  # first index in the velocity vector
    nv: int
    kind: str  # "prismatic" | "revolute" | "continuous" | a Pinocchio joint name (multi-DOF)
    link: str  # the link it moves (its body)
    lower: float = -math.inf  # m or rad
    upper: float = math.inf
    velocity: float = math.inf  # m/s or rad/s
    damping: float = 0.0  # nominal fv
    friction: float = 0.0  # nominal fs

    @property
    def one_dof(self) -> bool:
        return self.kind in ("prismatic", "revolute", "continuous")

    @property
    def unit_kind(self) -> str:
        """ActuatedJoint kind: prismatic or revolute (continuous is revolute)."""
        return "prismatic" if self.kind == "prismatic" else "revolute"


@dataclass(frozen=True)
class Mimic:
    """A URDF ``<mimic>``: joint q = multiplier · q_leader + offset (m or rad)."""

    joint: str
    leader: str
    multiplier: float = 1.0
    offset: float = 0.0


def urdf_mimics(path: Path) -> dict[str, Mimic]:
    """The mimic joints of a URDF by name (none for an MJCF); ConfigError for a bad number."""
    if path.suffix.lower() != ".urdf":
        return {}
    out = {}
    for el in ET.parse(path).getroot().findall("joint"):
        m = el.find("mimic")
        if m is None:
            continue
        try:
            mult, off = float(m.get("multiplier", 1.0)), float(m.get("offset", 0.0))
        except ValueError:
            raise ConfigError(f"robot description {path}: joint {el.get('name')}'s <mimic> "
                              "multiplier and offset must be numbers") from None
        if not (math.isfinite(mult) and math.isfinite(off) and m.get("joint")):
            raise ConfigError(f"robot description {path}: joint {el.get('name')}'s <mimic> needs "
                              "a joint and finite multiplier and offset")
        out[str(el.get("name"))] = Mimic(str(el.get("name")), str(m.get("joint")), mult, off)
    return out


@contextlib.contextmanager
def _captured_stderr() -> Iterator[list[str]]:
    """The C++ parsers print their reason on file descriptor 2: catch it for the message."""
    lines: list[str] = []
    with tempfile.TemporaryFile(mode="w+b") as tmp:
        saved = os.dup(2)
        os.dup2(tmp.fileno(), 2)
        try:
            yield lines
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            tmp.seek(0)
            lines.extend(tmp.read().decode(errors="replace").splitlines())


def _reason(lines: list[str], exc: Exception) -> str:
    for line in lines:
        if line.strip().startswith("Error:"):
            return line.strip()[len("Error:"):].strip()
    return str(exc).splitlines()[0] if str(exc) else type(exc).__name__


def load_tree(path: Path) -> tuple[pin.Model, list]:
    """(model, the description's own loop constraint models) from a URDF or MJCF file."""
    if not path.is_file():
        raise ConfigError(f"robot description {path}: no such file")
    try:
        ET.parse(path)
    except ET.ParseError as exc:
        raise ConfigError(f"robot description {path} is not valid XML ({exc})") from None
    suffix = path.suffix.lower()
    if suffix not in (".urdf", ".xml"):
        raise ConfigError(f"robot description {path}: expected a .urdf or an MJCF .xml")
    with _captured_stderr() as lines:
        try:
            if suffix == ".urdf":
                model, anchors = pin.buildModelFromUrdf(str(path)), []
            else:
                model, anchors = load_mjcf(path)
        except (ValueError, RuntimeError) as exc:
            failure = exc
        else:
            failure = None
    if failure is not None:
        kind = "URDF" if suffix == ".urdf" else "MJCF"
        raise ConfigError(f"robot description {path} is not a valid {kind}: "
                          f"{_reason(lines, failure)}")
    if model.njoints < 2:
        raise ConfigError(f"robot description {path} has no movable joint")
    return model, anchors


def _kind(joint: pin.JointModel) -> str:
    name = joint.shortname()
    if name in _PRISMATIC:
        return "prismatic"
    if name in _REVOLUTE:
        return "revolute"
    if name in _UNBOUNDED:
        return "continuous"
    return name


def joint_link(model: pin.Model, jid: int) -> str:
    """The link (BODY frame) a joint carries: the first body frame attached to it."""
    for f in model.frames:
        if f.parentJoint == jid and f.type == pin.FrameType.BODY:
            return f.name
    return model.names[jid]


def movable_joints(model: pin.Model) -> list[TreeJoint]:
    """Every movable joint in Pinocchio's order (parents before children)."""
    out = []
    for jid in range(1, model.njoints):
        jm = model.joints[jid]
        kind = _kind(jm)
        iq, iv, nv = jm.idx_q, jm.idx_v, jm.nv
        bounded = kind in ("prismatic", "revolute")
        lo, hi = (float(model.lowerPositionLimit[iq]), float(model.upperPositionLimit[iq])) \
            if bounded else (-math.inf, math.inf)
        out.append(TreeJoint(model.names[jid], jid, iq, iv, nv, kind, joint_link(model, jid),
                             lo if math.isfinite(lo) and lo > -1e10 else -math.inf,
                             hi if math.isfinite(hi) and hi < 1e10 else math.inf,
                             float(model.velocityLimit[iv]) or math.inf,
                             float(model.damping[iv]), float(model.friction[iv])))
    return out


def fixed_link(model: pin.Model, name: str) -> tuple[int, pin.SE3, pin.Inertia]:
    """A link fixed to a moving body: (joint id, placement in the joint frame, its inertia).

    The URDF and MJCF parsers merge the link's inertia into its joint's body and keep it on the
    fixed joint's frame (the link frame's parent, at the same placement)."""
    if not model.existFrame(name, pin.FrameType.BODY):
        raise ConfigError(f"fixed body {name!r}: the description has no link of that name")
    frame = model.frames[model.getFrameId(name, pin.FrameType.BODY)]
    if frame.parentJoint == 0:
        raise ConfigError(f"fixed body {name!r} is fixed to the world: it never moves, so it has "
                          "no parameters to identify")
    if any(j.link == name for j in movable_joints(model)):
        raise ConfigError(f"fixed body {name!r} is moved by a joint of its own: it is a body "
                          "already")
    inertia = frame.inertia
    parent = model.frames[frame.parentFrame]
    if inertia.mass == 0.0 and parent.type == pin.FrameType.FIXED_JOINT:
        inertia = parent.inertia
    return frame.parentJoint, frame.placement, inertia


def set_joint(Q: np.ndarray, joint: TreeJoint, values: np.ndarray) -> None:
    """Write joint values (m,) (m or rad) into configurations Q (m, nq)."""
    if joint.kind == "continuous":
        Q[:, joint.iq] = np.cos(values)
        Q[:, joint.iq + 1] = np.sin(values)
    else:
        Q[:, joint.iq] = values


def get_joint(q: np.ndarray, joint: TreeJoint) -> float:
    """A 1-DOF joint's value (m or rad) in configuration q (nq,)."""
    if joint.kind == "continuous":
        return math.atan2(q[joint.iq + 1], q[joint.iq])
    return float(q[joint.iq])
