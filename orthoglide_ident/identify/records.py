"""Reading records: a tagged bag (or the simulator's arrays) to a :class:`Record` in memory.

A record is one recording: positions and currents with their stamps, joints by name, and the
bag's tag (loaded or unloaded, payload mass, frame, centre of mass and inertia, and which of
them are known: paper Sect. 4.3). The offline path reads bags into records (``read_record``);
the live path builds none (its samples go straight to the observation, live_recording.py), but
shares ``payload_knowledge``. BagError if a bag is unusable.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path
from typing import Sequence

import numpy as np

from orthoglide_ident.errors import IdentificationError
from orthoglide_ident.identify.options import IdentifyOptions
from orthoglide_ident.model.robot import Payload, RobotModel
from orthoglide_ident.model.transmission import Transmission

__all__ = ["Record", "payload_knowledge", "read_record", "record_payload"]


@dataclass
class Record:
    """One recording in memory: positions and currents with their stamps and the bag's tag.

    ``q (N_q, len(names_q))`` m or rad, ``v_tau (N_v, len(names_v))`` A, joints by name (any
    order, extra ones ignored); ``payload``: where and how the payload is mounted (frame, centre
    of mass, inertia: the tag's ``orthoglide.payload_*`` keys; None: a point mass at the
    robot's payload frame)."""

    source: str
    stamps_q_ns: np.ndarray
    names_q: Sequence[str]
    q: np.ndarray
    stamps_v_ns: np.ndarray
    names_v: Sequence[str]
    v_tau: np.ndarray
    condition: str | None  # "loaded" | "unloaded"
    payload_mass: float  # kg, tagged (0 unloaded)
    warnings: list[str] = field(default_factory=list)
    payload: Payload | None = None
    sources: str = ""  # where q and the current were recorded (bags.BagSources.describe)
    qd: np.ndarray | None = None  # (N_q, len(names_q)) rad/s or m/s: JointState.velocity, if read

    @classmethod
    def from_arrays(cls, source: str, stamps_ns: np.ndarray, q: np.ndarray, v_tau: np.ndarray,
                    condition: str, payload_mass: float, joint_names: Sequence[str],
                    payload: Payload | None = None) -> "Record":
        """A record whose positions and currents share stamps and ``joint_names`` (the robot's,
        ``RobotModel.joint_names``)."""
        names = tuple(joint_names)
        return cls(source, stamps_ns, names, q, stamps_ns, names, v_tau, condition,
                   float(payload_mass), payload=payload)


def read_record(path: str | Path, model: RobotModel,
                opts: IdentifyOptions | None = None) -> Record:
    """Read a tagged bag (directory or lone .mcap) into a :class:`Record`: the robot's joints
    (``model``) by name from whichever topics hold them (bags.sources:
    a DynamicJointState interface, the JointState effort or the CurrentReference), the payload's
    frame, centre of mass and inertia from the tag. An effort that is a torque or force (the
    bag's tag ``orthoglide.effort_unit: torque``, or the option ``effort_unit: torque`` for a bag
    whose tag does not say) is turned into a current with the nominal gains. BagError if
    unusable."""
    from orthoglide_ident import bags

    opts = opts or IdentifyOptions()
    t = model.transmission
    data = bags.read_bag(path, joints=_channels(model, "effort"),
                         position_joints=_channels(model, "position"),
                         interface=opts.current_interface or None)
    tags, current = data.tags, data.current
    v_tau, sources = current.current, data.sources.describe()
    qd = data.velocity if opts.velocity_source != "derived" else None
    q, names_q, names_v = data.positions.position, tuple(data.positions.names), tuple(current.names)
    if t is not None:
        q, qd, v_tau, how = _to_motors(t, q, qd, v_tau)
        names_q = names_v = model.joint_names
        sources += how
    tagged_unit = None if tags is None else tags.effort_unit
    if (tagged_unit or opts.effort_unit) == "torque":
        v_tau = model.effort_as_current(names_v, v_tau)
        if tagged_unit == "torque":
            sources += " (a torque, as tagged: divided by the nominal gains)"
    return Record(
        source=str(path),
        stamps_q_ns=data.positions.stamps_ns, names_q=names_q, q=q,
        stamps_v_ns=current.stamps_ns, names_v=names_v, v_tau=v_tau,
        condition=None if tags is None else tags.condition,
        payload_mass=0.0 if tags is None else float(tags.payload_mass),
        warnings=list(data.warnings), payload=_tagged_payload(tags),
        sources=sources, qd=qd,
    )


def _channels(model: RobotModel, signal: str) -> tuple[str, ...]:
    """The channel names a bag holds ``signal`` ("position" or "effort") under: the model's
    joints, or a transmission's joints when that side is the joints' (model/transmission.py;
    a channel named after a joint carries that index's motor when the actuators repeat the
    joints' names)."""
    t = model.transmission
    if t is None:
        return model.joint_names
    side = t.position_side if signal == "position" else t.effort_side
    return tuple(t.joints) if side == "joint" else tuple(t.actuators)


def _to_motors(t: Transmission, q: np.ndarray, qd: np.ndarray | None,
               v: np.ndarray) -> tuple[np.ndarray, np.ndarray | None, np.ndarray, str]:
    """Positions, velocities and currents of a bag seen from the motors (the model's
    samples): q_m = N q_j + offset, q̇_m = N q̇_j, v_m = N⁻ᵀ v_j for joint-side channels."""
    how = ""
    if t.position_side == "joint":
        q = t.to_actuator_position(q)
        qd = None if qd is None else t.to_actuator_rate(qd)
        how += " (joint-side positions mapped to the motors: q_m = N q_j + offset)"
    if t.effort_side == "joint":
        v = t.to_actuator_effort(v)
        how += " (joint-side efforts divided through: N⁻ᵀ, per motor)"
    return q, qd, v, how


def _tagged_payload(tags) -> Payload | None:
    """The payload of a loaded bag's tag: mass, frame, CoM and inertia as given, and what of
    them is known (orthoglide.payload_known, else what the tag gives: paper Sect. 4.3)."""
    if tags is None or tags.condition != "loaded":
        return None
    return Payload(float(tags.payload_mass), tags.payload_frame or "",
                   tuple(tags.payload_com or (0.0, 0.0, 0.0)),
                   tuple(tags.payload_inertia or (0.0,) * 6), tags.knowledge)


def record_payload(rec: Record, payload_mass: float, known: str = "") -> Payload | None:
    """A loaded record's payload and what is known of it: ``known`` (payload_known option)
    overrides the tag's; an in-memory record without one carries a mass known alone at the
    robot's payload frame. IdentificationError when the knowledge asks for what is not given."""
    if rec.condition != "loaded":
        return None
    return payload_knowledge(rec.source, rec.payload, payload_mass, known)


def payload_knowledge(source: str, payload: Payload | None, payload_mass: float,
                      known: str = "") -> Payload:
    """A loaded record's payload (None: its mass known alone, at the robot's payload frame) with
    the knowledge ``known`` asks for ("" : as it is); IdentificationError when it asks for what
    the record does not give. Shared by the offline records and the live recordings."""
    p = payload or Payload(payload_mass, known="mass")
    if not known or known == p.known:
        return p
    if known in ("com", "all") and p.known in ("mass", "point") and not any(p.com):
        raise IdentificationError(
            f"{source}: payload_known {known} needs the payload's centre of mass in the tag "
            "(orthoglide.payload_com)")
    if known == "all" and p.known != "all":
        raise IdentificationError(
            f"{source}: payload_known all needs the payload's centre of mass and inertia in "
            "the tag (orthoglide.payload_com, orthoglide.payload_inertia)")
    if known == "point" and p.known == "all" and any(p.inertia):
        raise IdentificationError(
            f"{source} is tagged with the payload's inertia: payload_known point would drop "
            "it (use all, or com to identify the inertia)")
    return dataclasses.replace(p, known=known)
