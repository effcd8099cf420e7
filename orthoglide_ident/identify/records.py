"""Reading records: a tagged bag (or the simulator's arrays) to a :class:`Record` in memory.

A record is one recording: positions and currents with their stamps, joints by name, and the
bag's tag (loaded or unloaded, payload mass, frame, centre of mass and inertia). The offline path
reads bags into records (``read_record``); the live path builds none (its samples go straight to
the observation, live_recording.py). BagError if a bag is unusable.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Sequence

import numpy as np

from orthoglide_ident.identify.options import IdentifyOptions
from orthoglide_ident.model.robot import Payload, RobotModel

__all__ = ["Record", "read_record"]


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
    frame, centre of mass and inertia from the tag. With ``effort_unit: torque`` an effort that is
    a torque or force is turned into a current with the nominal gains. BagError if unusable."""
    from orthoglide_ident import bags

    opts = opts or IdentifyOptions()
    data = bags.read_bag(path, joints=model.joint_names,
                         interface=opts.current_interface or None)
    tags, current = data.tags, data.current
    v_tau = current.current
    if opts.effort_unit == "torque":
        v_tau = model.effort_as_current(current.names, v_tau)
    return Record(
        source=str(path),
        stamps_q_ns=data.positions.stamps_ns, names_q=tuple(data.positions.names),
        q=data.positions.position,
        stamps_v_ns=current.stamps_ns, names_v=tuple(current.names), v_tau=v_tau,
        condition=None if tags is None else tags.condition,
        payload_mass=0.0 if tags is None else float(tags.payload_mass),
        warnings=list(data.warnings), payload=_tagged_payload(tags),
        sources=data.sources.describe(),
    )


def _tagged_payload(tags) -> Payload | None:
    """The payload of a loaded bag's tag when it is more than a point mass at the robot's payload
    frame (orthoglide.payload_frame / _com / _inertia)."""
    if tags is None or tags.condition != "loaded" or not (
            tags.payload_frame or tags.payload_com or tags.payload_inertia):
        return None
    return Payload(float(tags.payload_mass), tags.payload_frame or "",
                   tuple(tags.payload_com or (0.0, 0.0, 0.0)),
                   tuple(tags.payload_inertia or (0.0,) * 6))
