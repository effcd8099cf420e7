"""Reading records: a tagged bag (or the simulator's arrays) to a :class:`Record` in memory.

A record is one recording: positions and currents with their stamps, joints by name, and the
bag's tag (loaded or unloaded, payload mass, frame, centre of mass and inertia, and which of
them are known: paper Sect. 4.3). The offline path reads bags into records (``read_record``);
the live path builds none (its samples go straight to the observation, live_recording.py), but
shares ``payload_knowledge``. BagError if a bag is unusable.
"""
from __future__ import annotations

import dataclasses
import logging
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from orthoglide_ident.errors import BagError, IdentificationError
from orthoglide_ident.identify.options import IdentifyOptions
from orthoglide_ident.model.robot import Payload, RobotModel

__all__ = ["Record", "effort_channels", "motor_side", "payload_knowledge", "read_record",
           "record_payload", "tagged_sides", "torque_as_current"]

log = logging.getLogger("orthoglide_ident.identify")


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
    # whose positions and currents the record holds, as its bag's tag says ("joint" |
    # "actuator"); None: as the robot file's transmission says (tagged_sides)
    position_side: str | None = None
    effort_side: str | None = None
    # how the current relates to its stamps, as the bag's tag says ("held" | "sampled"); None:
    # the option current_sampling decides (observe/sampling.py)
    current_sampling: str | None = None

    @classmethod
    def from_arrays(cls, source: str, stamps_ns: np.ndarray, q: np.ndarray, v_tau: np.ndarray,
                    condition: str, payload_mass: float, joint_names: Sequence[str],
                    payload: Payload | None = None, current_sampling: str | None = None
                    ) -> Record:
        """A record whose positions and currents share stamps and ``joint_names`` (the robot's,
        ``RobotModel.joint_names``); ``current_sampling`` as a bag's tag would say it."""
        names = tuple(joint_names)
        return cls(source, stamps_ns, names, q, stamps_ns, names, v_tau, condition,
                   float(payload_mass), payload=payload, current_sampling=current_sampling)


def read_record(path: str | Path, model: RobotModel,
                opts: IdentifyOptions | None = None,
                progress: Callable[..., None] | None = None) -> Record:
    """Read a tagged bag (directory or lone .mcap) into a :class:`Record`: the robot's joints
    (``model``) by name from whichever topics hold them (bags.sources:
    a DynamicJointState interface, the JointState effort or the CurrentReference), the payload's
    frame, centre of mass and inertia from the tag. An effort that is a torque or force (the
    bag's tag ``orthoglide.effort_unit: torque``, or the option ``effort_unit: torque`` for a bag
    whose tag does not say) is turned into a current with the nominal gains. BagError if
    unusable. ``progress(stage, done, total, unit)`` (None: silent) hears the chunks read."""
    from orthoglide_ident import bags

    opts = opts or IdentifyOptions()
    sides: list[str | None] = [None, None]

    def channels(tags):  # the tag says whose signals the bag holds (tagged_sides)
        sides[:] = tagged_sides(model, tags, str(path))
        return _channels(model, "position", sides[0]), _channels(model, "effort", sides[1])

    data = bags.read_bag(path, channels=channels, interface=opts.input.current_interface or None,
                         progress=progress)
    tags, current = data.tags, data.current
    v_tau, sources = current.current, data.sources.describe()
    qd = data.velocity if opts.input.velocity_source != "derived" else None
    rec = motor_side(Record(
        source=str(path),
        stamps_q_ns=data.positions.stamps_ns, names_q=tuple(data.positions.names),
        q=data.positions.position,
        stamps_v_ns=current.stamps_ns, names_v=tuple(current.names), v_tau=v_tau,
        condition=None if tags is None else tags.condition,
        payload_mass=0.0 if tags is None else float(tags.payload_mass),
        warnings=list(data.warnings), payload=_tagged_payload(tags),
        sources=sources, qd=qd, position_side=sides[0], effort_side=sides[1],
        current_sampling=None if tags is None else tags.current_sampling,
    ), model)
    tagged_unit = None if tags is None else tags.effort_unit
    if (tagged_unit or opts.input.effort_unit) == "torque":
        rec.v_tau = model.effort_as_current(rec.names_v, rec.v_tau)
        if tagged_unit == "torque":
            rec.sources += " (a torque, as tagged: divided by the nominal gains)"
    return rec


def tagged_sides(model: RobotModel, tags, source: str) -> tuple[str | None, str | None]:
    """Whose positions and currents a bag holds: its tag's ``orthoglide.position_side`` and
    ``orthoglide.effort_side`` where it says (None where not: the robot file's transmission
    decides, as before). The tag wins over the robot file: it was written with the signals, by
    what recorded them, while the file says what a hardware publishes by default; a
    disagreement is read as tagged and said in the log. BagError for motor-side positions of
    a robot without a transmission (nothing maps them to its joints)."""
    if tags is None:
        return None, None
    t = model.transmission
    if t is None:
        if tags.position_side == "actuator":
            raise BagError(f"{source}: tagged orthoglide.position_side actuator (the motors' "
                           f"positions) but robot {model.name} has no transmission to map them "
                           "to its joints: give the robot file one (docs/guide/robot_files.md)")
        return None, None
    for what, tagged, filed in (("positions", tags.position_side, t.position_side),
                                ("efforts", tags.effort_side, t.effort_side)):
        if tagged is not None and tagged != filed:
            log.info("%s: %s read %s-side as the bag's tag says (the robot file %s says "
                     "%s-side)", source, what, tagged, t.where, filed)
    return tags.position_side, tags.effort_side


def _channels(model: RobotModel, signal: str, side: str | None = None) -> tuple[str, ...]:
    """The channel names a bag holds ``signal`` ("position" or "effort") under: the model's
    joints, or a transmission's joints when that side (``side``, else the transmission's) is
    the joints' (model/transmission.py; a channel named after a joint carries that index's
    motor when the actuators repeat the joints' names)."""
    t = model.transmission
    if t is None:
        return model.joint_names
    side = side or (t.position_side if signal == "position" else t.effort_side)
    return tuple(t.joints) if side == "joint" else tuple(t.actuators)


def _columns(rec: Record, names: Sequence[str], have: Sequence[str], what: str) -> list[int]:
    missing = [n for n in names if n not in have]
    if missing:
        raise BagError(f"{rec.source}: the {what} of {missing} are not in the record (it has "
                       f"{list(have)}): check the robot file's transmission (actuators, "
                       "position_side, effort_side)")
    return [list(have).index(n) for n in names]


def motor_side(rec: Record, model: RobotModel) -> Record:
    """A record of a robot with a transmission (model/transmission.py) seen from its motors, the
    model's "joints": q_m = N q_j + offset and q̇_m = N q̇_j for joint-side positions, v_m = N⁻ᵀ
    v_j for joint-side efforts (divided through, said in ``sources``); the record itself when
    the model has no transmission. BagError naming the channels a record lacks."""
    t = model.transmission
    if t is None:
        return rec
    q_side = rec.position_side or t.position_side
    v_side = rec.effort_side or t.effort_side
    q_names = t.joints if q_side == "joint" else t.actuators
    v_names = t.joints if v_side == "joint" else t.actuators
    cq = _columns(rec, q_names, rec.names_q, f"{q_side}-side positions")
    cv = _columns(rec, v_names, rec.names_v, f"{v_side}-side currents")
    q, qd, v, how = rec.q[:, cq], None if rec.qd is None else rec.qd[:, cq], rec.v_tau[:, cv], ""
    if q_side == "joint":
        q, qd = t.to_actuator_position(q), None if qd is None else t.to_actuator_rate(qd)
        how += "; joint-side positions mapped to the motors (q_m = N q_j + offset)"
    if v_side == "joint":
        v = t.to_actuator_effort(v)
        how += "; joint-side efforts divided through to the motors (N⁻ᵀ)"
    for what, side, filed in (("positions", rec.position_side, t.position_side),
                              ("efforts", rec.effort_side, t.effort_side)):
        if side is not None and side != filed:
            how += f"; {what} {side}-side as the bag is tagged (the robot file says {filed})"
    return dataclasses.replace(rec, names_q=model.joint_names, q=q, qd=qd,
                               names_v=model.joint_names, v_tau=v, sources=rec.sources + how)


def effort_channels(model: RobotModel) -> tuple[str, ...]:
    """The channel names a feed holds the currents (or efforts) under: the model's joints, or a
    transmission's joints or actuators as its ``effort_side`` says."""
    return _channels(model, "effort")


def torque_as_current(model: RobotModel, names: Sequence[str], effort: np.ndarray) -> np.ndarray:
    """Efforts (N·m or N) under the channels ``names`` -> currents (A), divided by the nominal
    gains on the motors' side as read_record does. Joint-side efforts of a transmission stay in
    the joints' channels: v_j' = Nᵀ diag(g)⁻¹ N⁻ᵀ τ_j, which the live path's v_m = N⁻ᵀ v_j'
    (live_recording.channel_maps) turns into each motor's current; a channel the feed lacks is
    left as it is (the live identification says so)."""
    t = model.transmission
    if t is None or t.effort_side != "joint" or not set(t.joints) <= set(names):
        return model.effort_as_current(names, effort)
    out = np.array(effort, dtype=float)
    cols = [list(names).index(j) for j in t.joints]
    out[:, cols] = t.to_joint_effort(t.to_actuator_effort(out[:, cols]) / model.nominal_gains)
    return out


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
