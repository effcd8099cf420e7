"""Locked joints: joints of the description fixed at a value before anything else (issue 43).

A robot file's ``locked_joints: {joint: value}`` (m or rad) fixes those joints; a URDF mimic
joint that follows a locked joint is locked with it, at r·value + o; in a robot file that lists
its ``actuated_joints`` and has no loops, a joint left out of them that a mimic joint follows (a
gripper's finger, as the Panda's) is locked too, at its ``reference_configuration`` value or at
the value in its limits nearest 0, and the model says so. Any other joint left out is still
refused (a forgotten joint, or a closed chain without its loops, would be a silently wrong
model). Pinocchio's
``buildReducedModel`` then turns every locked joint into a fixed one at that value: its link's
inertia is merged into the body it is fixed to, and the rest of the product (identification,
exciting trajectories, the identified URDF) only ever sees the reduced tree.

Every mistake is a ConfigError naming the robot file and the joint: a joint that is not a movable
1-DOF joint of the description, a value outside the joint's limits, a joint both locked and
actuated, a mimic joint locked apart from its leader.
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.model.robot_file import RobotDescription
from orthoglide_ident.model.tree import Mimic, TreeJoint, set_joint

LISTED, FOLLOWS, UNLISTED = "locked_joints", "mimic", "unlisted"  # why a joint is locked
MIMIC_TOL = 1e-9  # m or rad: a mimic locked beside its leader must agree to this
LIMIT_TOL = 1e-12  # m or rad: a value on a limit (written with round-off) is within it


@dataclass(frozen=True)
class LockedJoint:
    """A joint fixed at ``value`` (m or rad) and why: LISTED in the robot file, FOLLOWS its
    locked leader (``leader``: a URDF mimic), or UNLISTED (not in ``actuated_joints``, the
    leader of a mimic joint)."""

    name: str
    value: float
    kind: str  # "prismatic" | "revolute" | "continuous"
    why: str
    leader: str = ""

    @property
    def unit(self) -> str:
        return "m" if self.kind == "prismatic" else "rad"

    def reason(self) -> str:
        return {LISTED: "locked_joints of the robot file",
                FOLLOWS: f"mimic joint of {self.leader}, locked with it",
                UNLISTED: "not in actuated_joints, a mimic joint follows it"}[self.why]

    def to_json(self) -> dict:
        return {"joint": self.name, "value": self.value, "unit": self.unit,
                "reason": self.reason()}


def _in_limits(j: TreeJoint, value: float) -> bool:
    return j.lower - LIMIT_TOL <= value <= j.upper + LIMIT_TOL


def _limits_text(j: TreeJoint) -> str:
    unit = "m" if j.kind == "prismatic" else "rad"
    return f"[{j.lower:g}, {j.upper:g}] {unit}"


def _listed(desc: RobotDescription, by_name: Mapping[str, TreeJoint],
            mimics: Mapping[str, Mimic], where: str) -> dict[str, LockedJoint]:
    """The robot file's own locked joints, each checked against the description."""
    out = {}
    actuated = set(desc.actuated_joints or ())
    for name, value in desc.locked_joints.items():
        j = by_name.get(name)
        if j is None or not j.one_dof:
            what = "a multi-DOF joint" if j is not None else "not a movable joint"
            raise ConfigError(f"{where}: locked_joints: {name!r} is {what} of "
                              f"{desc.path.name} (movable 1-DOF joints: "
                              f"{', '.join(n for n, t in by_name.items() if t.one_dof)})")
        if name in actuated:
            raise ConfigError(f"{where}: locked_joints: {name!r} is also in actuated_joints: "
                              "a joint is either driven or locked")
        if not _in_limits(j, value):
            raise ConfigError(f"{where}: locked_joints: {name} = {value:g} is outside its limits "
                              f"{_limits_text(j)} in {desc.path.name}")
        if name in mimics and mimics[name].leader not in desc.locked_joints:
            raise ConfigError(f"{where}: locked_joints: {name!r} is a mimic joint of "
                              f"{mimics[name].leader!r} in {desc.path.name}: lock its leader "
                              "(the mimic is locked with it)")
        out[name] = LockedJoint(name, float(value), j.kind, LISTED)
    return out


def _unlisted(desc: RobotDescription, by_name: Mapping[str, TreeJoint],
              mimics: Mapping[str, Mimic], locked: Mapping[str, LockedJoint],
              open_tree: bool, where: str) -> dict[str, LockedJoint]:
    """Joints an open tree's robot file leaves out of actuated_joints that a mimic joint
    follows (a gripper's): locked at their reference value, else the value in limits nearest
    0."""
    if desc.actuated_joints is None or not open_tree:
        return {}
    # a mimic named actuated: its leader stays, for the model to say "actuate its leader"
    led = {mimics[n].leader for n in desc.actuated_joints if n in mimics}
    leaders = {m.leader for m in mimics.values()}
    out = {}
    for name, j in by_name.items():
        if name in desc.actuated_joints or name in locked or name in mimics or name in led \
                or name not in leaders or not j.one_dof:
            continue
        value = desc.reference_configuration.get(name, min(max(0.0, j.lower), j.upper))
        if not _in_limits(j, value):
            raise ConfigError(f"{where}: reference_configuration: {name} = {value:g} (where the "
                              "joint, not in actuated_joints, is locked) is outside its limits "
                              f"{_limits_text(j)} in {desc.path.name}")
        out[name] = LockedJoint(name, float(value), j.kind, UNLISTED)
    return out


def _followers(desc: RobotDescription, by_name: Mapping[str, TreeJoint],
               mimics: Mapping[str, Mimic], locked: dict[str, LockedJoint],
               where: str) -> None:
    """Lock, in ``locked``, every mimic joint whose leader is locked (chains of mimics too),
    at r·value + o, within its own limits; a mimic locked in the file must agree."""
    changed = True
    while changed:
        changed = False
        for m in mimics.values():
            if m.leader not in locked or m.joint not in by_name:
                continue
            lead = locked[m.leader]
            value = m.multiplier * lead.value + m.offset
            own = locked.get(m.joint)
            if own is not None:  # locked already: in the file, it must agree with its leader
                if own.why != FOLLOWS and abs(own.value - value) > MIMIC_TOL:
                    raise ConfigError(f"{where}: locked_joints: {m.joint} = {own.value:g}, but "
                                      f"it follows {m.leader} = {lead.value:g} "
                                      f"({m.multiplier:g}·{lead.value:g} + {m.offset:g} = "
                                      f"{value:g}) in {desc.path.name}")
                continue
            j = by_name[m.joint]
            if not j.one_dof or not _in_limits(j, value):
                raise ConfigError(f"{where}: locked_joints: mimic joint {m.joint} follows "
                                  f"{m.leader} = {lead.value:g} to {value:g}, outside its limits "
                                  f"{_limits_text(j)} in {desc.path.name}")
            locked[m.joint] = LockedJoint(m.joint, value, j.kind, FOLLOWS, m.leader)
            changed = True


def locked_joints(joints: list[TreeJoint], mimics: Mapping[str, Mimic], desc: RobotDescription,
                  open_tree: bool, where: str) -> tuple[LockedJoint, ...]:
    """Every joint to lock (module docstring), in the description's joint order."""
    by_name = {j.name: j for j in joints}
    locked = _listed(desc, by_name, mimics, where)
    locked.update(_unlisted(desc, by_name, mimics, locked, open_tree, where))
    _followers(desc, by_name, mimics, locked, where)
    return tuple(locked[j.name] for j in joints if j.name in locked)


def reduced_model(model: pin.Model, joints: list[TreeJoint],
                  locked: tuple[LockedJoint, ...]) -> pin.Model:
    """``model`` with the ``locked`` joints fixed at their values (Pinocchio's
    buildReducedModel: their links merged into the bodies they are fixed to); gravity kept."""
    if not locked:
        return model
    by_name = {j.name: j for j in joints}
    q = pin.neutral(model)[None, :].copy()
    for lj in locked:
        set_joint(q, by_name[lj.name], np.array([lj.value]))
    reduced = pin.buildReducedModel(model, [by_name[lj.name].id for lj in locked], q[0])
    reduced.gravity = model.gravity
    return reduced


def lock_text(locked: tuple[LockedJoint, ...]) -> str:
    """One line for people: which joints are locked, at what, and why."""
    return "Locked joints: " + "; ".join(
        f"{lj.name} = {lj.value:.6g} {lj.unit} ({lj.reason()})" for lj in locked) + "."
