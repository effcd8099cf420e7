"""The tag of a bag: loaded/unloaded, the payload, and where q and the current were recorded.

Stored as strings, the same keys in metadata.yaml ``custom_data`` and in each .mcap file's
``orthoglide`` metadata record (docs/design/interfaces.md):

==============================  ==================================================================
``orthoglide.condition``        ``loaded`` | ``unloaded``
``orthoglide.payload_mass``     kg, ``"0"`` when unloaded
``orthoglide.payload_frame``    the link the payload is fixed to (optional; default: the robot's
                                payload frame)
``orthoglide.payload_com``      ``"x y z"``: its centre of mass in that frame, m (optional;
                                absent: the frame origin)
``orthoglide.payload_inertia``  ``"Ixx Ixy Ixz Iyy Iyz Izz"``: its inertia about the centre of mass,
                                kg·m², in that frame (optional; absent: a point mass)
``orthoglide.payload_known``    what is known of the payload (paper Sect. 4.3, optional):
                                ``mass`` (its CoM and inertia are identified), ``com`` (mass and
                                CoM known, inertia identified), ``all`` (needs payload_com and
                                payload_inertia), ``point`` (a point mass at the frame, or at
                                payload_com). Absent: ``all`` with com and inertia, ``com`` with
                                com only, else ``mass``
``orthoglide.position_source``  ``"TOPIC FIELD"``: where q was recorded, e.g.
                                ``/joint_states position`` (optional)
``orthoglide.current_source``   ``"TOPIC FIELD"``: where the current (A) was recorded:
                                ``/dynamic_joint_states current`` (a DynamicJointState interface),
                                ``/joint_states effort`` or ``/orthoglide/current_reference
                                current`` (optional; absent: the reader's order of preference)
``orthoglide.effort_unit``      ``A`` | ``torque``: what the current source holds, a current or a
                                torque / force (N·m or N, e.g. a CSV log of joint torques,
                                ``orthoglide-ident import``); identification turns a torque into a
                                current with the nominal gains (optional; absent: the
                                ``effort_unit`` option, default A)
``orthoglide.position_side``    ``joint`` | ``actuator``: the positions are the joints' or the
motors'
                                (encoders, offset included) for a robot with a transmission
                                (optional; absent: the robot file's ``position_side``; identify
                                reads the bag as tagged, docs/design/bags.md)
``orthoglide.effort_side``      ``actuator`` | ``joint``: the currents (efforts) are the motors' or
                                the joints' (optional; absent: the robot file's ``effort_side``)
``orthoglide.current_sampling`` ``held`` | ``sampled``: how the current relates to its stamps: held
                                over the step that follows (a controller at the log rate) or a
                                point sample at the stamp from a faster loop (a logger slower
                                than its controller); optional, absent: the ``current_sampling``
                                option (identify/observe/sampling.py)
``orthoglide.incomplete``       why the recording was stopped before its run ended (a cancelled,
                                aborted or out-of-tolerance excitation run, ``excite run``);
                                absent: complete. Written at the stop, in metadata.yaml and the
                                closing ``rosbag2`` record's ``custom_data`` (not in the
                                ``orthoglide`` record, written when each file opens)
==============================  ==================================================================

The payload's com and inertia need ``loaded``; a source's topic is a ROS name (``/...``) and its
field one word. Values that break these rules are refused with a one-line reason: ConfigError
from :meth:`BagTags.checked` (a recorder's request), BagError from :meth:`BagTags.from_dict` (a
bag on disk).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from orthoglide_ident.errors import BagError, ConfigError

CONDITION_KEY = "orthoglide.condition"
MASS_KEY = "orthoglide.payload_mass"
FRAME_KEY = "orthoglide.payload_frame"
COM_KEY = "orthoglide.payload_com"
INERTIA_KEY = "orthoglide.payload_inertia"
KNOWN_KEY = "orthoglide.payload_known"
PAYLOAD_KNOWLEDGE = ("mass", "com", "all", "point")  # model/robot.py's, spelled out here too
POSITION_SOURCE_KEY = "orthoglide.position_source"
CURRENT_SOURCE_KEY = "orthoglide.current_source"
EFFORT_UNIT_KEY = "orthoglide.effort_unit"
EFFORT_UNITS = ("A", "torque")
POSITION_SIDE_KEY = "orthoglide.position_side"
EFFORT_SIDE_KEY = "orthoglide.effort_side"
CURRENT_SAMPLING_KEY = "orthoglide.current_sampling"
CURRENT_SAMPLINGS = ("held", "sampled")  # a record's own; options.CURRENT_SAMPLING adds auto
SIDES = ("joint", "actuator")  # model/transmission.py's POSITION_SIDES, EFFORT_SIDES
INCOMPLETE_KEY = "orthoglide.incomplete"
METADATA_NAME = "orthoglide"
CONDITIONS = ("loaded", "unloaded")
_INERTIA_TOL = 1e-12  # kg·m², relative to the largest moment: round-off in a principal moment


@dataclass(frozen=True)
class BagTags:
    """``condition``: ``loaded`` | ``unloaded``; ``payload_mass`` in kg (0 when unloaded); the
    payload's frame, centre of mass (m) and inertia about it (kg·m², Ixx Ixy Ixz Iyy Iyz Izz),
    None when not given; the sources as ``"TOPIC FIELD"``, None when not given."""

    condition: str
    payload_mass: float
    payload_frame: str | None = None
    payload_com: tuple[float, float, float] | None = None
    payload_inertia: tuple[float, float, float, float, float, float] | None = None
    position_source: str | None = None
    current_source: str | None = None
    effort_unit: str | None = None
    payload_known: str | None = None
    position_side: str | None = None  # "joint" | "actuator": whose positions the bag holds
    effort_side: str | None = None  # "actuator" | "joint": whose currents (efforts)
    current_sampling: str | None = None  # "held" | "sampled": the current against its stamps

    @property
    def knowledge(self) -> str:
        """What is known of a loaded bag's payload: the tag's payload_known, else ``all`` with a
        CoM and an inertia, ``com`` with a CoM only, ``mass`` otherwise (paper Sect. 4.3)."""
        if self.payload_known is not None:
            return self.payload_known
        if self.payload_com is not None:
            return "all" if self.payload_inertia is not None else "com"
        return "mass"

    @classmethod
    def checked(
        cls,
        condition: str,
        payload_mass: float,
        *,
        payload_frame: str | None = None,
        payload_com: Sequence[float] | None = None,
        payload_inertia: Sequence[float] | None = None,
        position_source: str | None = None,
        current_source: str | None = None,
        effort_unit: str | None = None,
        payload_known: str | None = None,
        position_side: str | None = None,
        effort_side: str | None = None,
        current_sampling: str | None = None,
    ) -> BagTags:
        """Validated tags; ConfigError with the reason otherwise (used for recorder requests)."""
        if condition not in CONDITIONS:
            raise ConfigError(f"unknown condition {condition!r}: use 'loaded' or 'unloaded'")
        mass = float(payload_mass)
        if not math.isfinite(mass):
            raise ConfigError(f"payload_mass {payload_mass!r} is not a finite number")
        if condition == "loaded" and mass <= 0:
            raise ConfigError("condition 'loaded' needs a positive payload_mass (kg)")
        if condition == "unloaded" and mass != 0:
            raise ConfigError(
                f"condition 'unloaded' takes no payload_mass (got {mass:g} kg); use 0"
            )
        com = _numbers(payload_com, 3, "payload_com", "'x y z' (m)")
        inertia = _numbers(payload_inertia, 6, "payload_inertia",
                           "'Ixx Ixy Ixz Iyy Iyz Izz' (kg·m²)")
        if condition == "unloaded" and (com is not None or inertia is not None):
            raise ConfigError("condition 'unloaded' takes no payload_com or payload_inertia")
        if inertia is not None:
            _check_inertia(inertia)
        if effort_unit is not None and effort_unit not in EFFORT_UNITS:
            raise ConfigError(f"effort_unit {effort_unit!r}: use 'A' (a current) or 'torque' "
                              "(N·m or N)")
        for name, side in (("position_side", position_side), ("effort_side", effort_side)):
            if side is not None and side not in SIDES:
                raise ConfigError(f"{name} {side!r}: use 'joint' or 'actuator' (the motors')")
        if current_sampling is not None and current_sampling not in CURRENT_SAMPLINGS:
            raise ConfigError(f"current_sampling {current_sampling!r}: use 'held' (over the step "
                              "that follows) or 'sampled' (at the stamp, from a faster loop)")
        known = _knowledge(payload_known or None, condition, com, inertia)
        return cls(condition, mass, _word(payload_frame, "payload_frame"), com, inertia,
                   _source(position_source, "position_source"),
                   _source(current_source, "current_source"), effort_unit, known,
                   position_side, effort_side, current_sampling)

    def to_dict(self) -> dict[str, str]:
        """The keys as stored in custom_data and in the MCAP metadata record (absent ones left
        out, so an Orthoglide bag keeps exactly the two keys of docs/design/interfaces.md)."""
        mass = "0" if self.payload_mass == 0 else format(self.payload_mass, ".12g")
        out = {CONDITION_KEY: self.condition, MASS_KEY: mass}
        optional = {
            FRAME_KEY: self.payload_frame,
            COM_KEY: None if self.payload_com is None else _join(self.payload_com),
            INERTIA_KEY: None if self.payload_inertia is None else _join(self.payload_inertia),
            KNOWN_KEY: self.payload_known,
            POSITION_SOURCE_KEY: self.position_source,
            CURRENT_SOURCE_KEY: self.current_source,
            EFFORT_UNIT_KEY: self.effort_unit,
            POSITION_SIDE_KEY: self.position_side,
            EFFORT_SIDE_KEY: self.effort_side,
            CURRENT_SAMPLING_KEY: self.current_sampling,
        }
        out.update({k: v for k, v in optional.items() if v is not None})
        return out

    def describe(self) -> str:
        """One line: ``loaded, payload 1.136 kg`` and the payload's frame, CoM, inertia if given."""
        out = f"{self.condition}, payload {self.payload_mass:g} kg"
        if self.payload_frame is not None:
            out += f" at {self.payload_frame}"
        if self.payload_com is not None:
            out += f", CoM {' '.join(f'{x:g}' for x in self.payload_com)} m"
        if self.payload_inertia is not None:
            out += f", inertia {' '.join(f'{x:g}' for x in self.payload_inertia)} kg·m²"
        if self.effort_unit == "torque":
            out += ", effort a torque (N·m or N)"
        for what, side in (("positions", self.position_side), ("efforts", self.effort_side)):
            if side is not None:
                out += f", {what} {side}-side"
        if self.current_sampling is not None:
            out += f", current {self.current_sampling}"
        if self.condition == "loaded":
            out += f" ({_KNOWN_TEXT[self.knowledge]})"
        return out

    @classmethod
    def from_dict(cls, items: dict[str, str] | None, where: str) -> BagTags | None:
        """Parse the keys; None when neither condition nor mass is there; BagError when they are
        incomplete or invalid."""
        items = items or {}
        cond, mass = items.get(CONDITION_KEY), items.get(MASS_KEY)
        if cond is None and mass is None:
            return None
        if cond is None or mass is None:
            missing = CONDITION_KEY if cond is None else MASS_KEY
            raise BagError(f"{where}: tag incomplete, {missing} is missing")
        try:
            value = float(mass)
        except ValueError:
            raise BagError(f"{where}: {MASS_KEY} {mass!r} is not a number") from None
        try:
            return cls.checked(
                cond, value,
                payload_frame=items.get(FRAME_KEY),
                payload_com=_split(items.get(COM_KEY), COM_KEY),
                payload_inertia=_split(items.get(INERTIA_KEY), INERTIA_KEY),
                position_source=items.get(POSITION_SOURCE_KEY),
                current_source=items.get(CURRENT_SOURCE_KEY),
                effort_unit=items.get(EFFORT_UNIT_KEY),
                payload_known=items.get(KNOWN_KEY),
                position_side=items.get(POSITION_SIDE_KEY),
                effort_side=items.get(EFFORT_SIDE_KEY),
                current_sampling=items.get(CURRENT_SAMPLING_KEY),
            )
        except ConfigError as exc:
            raise BagError(f"{where}: invalid tag: {exc}") from None


_KNOWN_TEXT = {"mass": "mass known, CoM and inertia not",
               "com": "mass and CoM known, inertia not",
               "all": "mass, CoM and inertia known", "point": "a point mass"}


def _knowledge(known: str | None, condition: str, com, inertia) -> str | None:
    """The tag's payload_known, checked against the condition and what else the tag gives."""
    if known is None:
        return None
    if known not in PAYLOAD_KNOWLEDGE:
        raise ConfigError(f"payload_known {known!r} is not one of {', '.join(PAYLOAD_KNOWLEDGE)}")
    if condition == "unloaded":
        raise ConfigError("condition 'unloaded' takes no payload_known")
    if known == "com" and com is None:
        raise ConfigError("payload_known 'com' needs payload_com (the centre of mass, m)")
    if known == "all" and (com is None or inertia is None):
        raise ConfigError("payload_known 'all' needs payload_com and payload_inertia")
    if known == "point" and inertia is not None:
        raise ConfigError("payload_known 'point' takes no payload_inertia (a point mass has none)")
    return known


def _join(values: Sequence[float]) -> str:
    return " ".join(repr(float(v)) for v in values)  # shortest text that reads back exactly


def _split(text: str | None, key: str) -> list[float] | None:
    if text is None:
        return None
    try:
        return [float(x) for x in str(text).split()]
    except ValueError:
        raise ConfigError(f"{key} {text!r} is not a list of numbers") from None


def _numbers(values: Sequence[float] | None, n: int, name: str, form: str) -> tuple | None:
    if values is None:
        return None
    try:
        out = tuple(float(v) for v in values)
    except (TypeError, ValueError):
        raise ConfigError(f"{name} {values!r} is not {n} numbers {form}") from None
    if len(out) != n or not all(math.isfinite(v) for v in out):
        shown = _join(out) if out else repr(values)
        raise ConfigError(f"{name} {shown} is not {n} finite numbers {form}")
    return out


def _check_inertia(i: tuple[float, ...]) -> None:
    """A rigid body's inertia about its CoM: symmetric positive semi-definite, and its principal
    moments obey the triangle inequality (I1 + I2 >= I3)."""
    ixx, ixy, ixz, iyy, iyz, izz = i
    m = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
    moments = np.linalg.eigvalsh(m)  # ascending
    tol = _INERTIA_TOL * max(1e-12, float(np.abs(moments).max()))
    if moments[0] < -tol:
        raise ConfigError(f"payload_inertia {_join(i)} is not positive semi-definite (principal "
                          f"moments {', '.join(f'{x:.6g}' for x in moments)} kg·m²)")
    if moments[0] + moments[1] < moments[2] - tol:
        raise ConfigError(f"payload_inertia {_join(i)} is not a rigid body's: principal moments "
                          f"{', '.join(f'{x:.6g}' for x in moments)} kg·m² break I1 + I2 >= I3")


def _word(text: str | None, name: str) -> str | None:
    if text is None:
        return None
    if not isinstance(text, str) or not text or text.split() != [text]:
        raise ConfigError(f"{name} {text!r} is not a link name (one word)")
    return text


def _source(text: str | None, name: str) -> str | None:
    if text is None:
        return None
    parts = text.split() if isinstance(text, str) else []
    if len(parts) != 2 or not parts[0].startswith("/") or " ".join(parts) != text:
        raise ConfigError(f"{name} {text!r} is not 'TOPIC FIELD' (e.g. '/joint_states position')")
    return text
