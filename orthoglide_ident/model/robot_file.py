"""The robot YAML of a general (Pinocchio) robot, read and checked key by key.

docs/guide/robot_files.md documents every key; :class:`RobotDescription` holds them with their
defaults. Every mistake is a ConfigError naming the file, the key and what was expected: an
unknown key (a typo would otherwise be ignored), a wrong type, a missing description.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.model.loop_constraints import LOOP_KINDS, Loop
from orthoglide_ident.model.robot import DEFAULT_GRAVITY
from orthoglide_ident.model.xacro_files import expanded_file, is_xacro

KEYS = ("name", "model", "description", "actuated_joints", "nominal_gains", "payload_frame",
        "gravity", "loops", "reference_configuration", "passive_friction", "column_order",
        "body_labels", "fixed_bodies", "excitation", "transmission", "locked_joints",
        "xacro_args", "current_sampling")
# the ``excitation`` section's keys (docs/guide/excitation.md; excite/limits.py reads them)
EXCITATION_KEYS = ("position_limits", "velocity_limits", "acceleration_limits", "effort_limits",
                   "current_limits", "home", "collision")


@dataclass(frozen=True)
class RobotDescription:
    """What a robot YAML says, defaults filled in (see docs/guide/robot_files.md)."""

    path: Path  # the URDF or MJCF, resolved
    name: str
    actuated_joints: tuple[str, ...] | None = None  # None: every movable joint
    # N/A or N·m/A, per actuated joint or one; None: not given (a bare URDF): 1 per unit for the
    # feed-forward, and the identified gains are judged without a magnitude band
    nominal_gains: tuple[float, ...] | float | None = None
    payload_frame: str | None = None  # None: the link of the last movable joint
    gravity: tuple[float, float, float] = DEFAULT_GRAVITY  # m/s², the gravity acceleration
    loops: tuple[Loop, ...] = ()
    reference_configuration: dict[str, float] = field(default_factory=dict)  # joint: m or rad
    passive_friction: bool | None = None  # None: True for closed chains
    column_order: tuple[tuple[str, ...], ...] = ()  # groups of body labels (eq. 23)
    body_labels: dict[str, str] = field(default_factory=dict)  # link: label
    fixed_bodies: tuple[str, ...] = ()  # links on fixed joints kept as bodies of their own
    # limits, home pose and collision geometry for exciting trajectories (excite/limits.py and
    # excite/collision.py read it; only its being a mapping is checked here)
    excitation: dict[str, Any] = field(default_factory=dict)
    # the drive chains (model/transmission.py reads it once the actuated joints are known);
    # None: the URDF's <ros2_control> transmissions, else none (each motor drives its joint)
    transmission: dict[str, Any] | None = None
    # joint: m or rad, fixed before anything else with the mimic joints that follow them
    # (model/locked_joints.py: Pinocchio's reduced model)
    locked_joints: dict[str, float] = field(default_factory=dict)
    # how its records' currents relate to their stamps (held | sampled), for records whose tag
    # does not say, under current_sampling: auto (identify/observe/sampling.py); None: not said
    current_sampling: str | None = None


def _fail(where: str, key: str, what: str) -> ConfigError:
    return ConfigError(f"{where}: {key}: {what}")


def _names(where: str, key: str, value: Any) -> tuple[str, ...]:
    if isinstance(value, str) or not isinstance(value, (list, tuple)) or \
            not all(isinstance(v, str) and v for v in value):
        raise _fail(where, key, f"expected a list of names, got {value!r}")
    return tuple(value)


def _number(where: str, key: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise _fail(where, key, f"expected a number, got {value!r}")
    return float(value)


def _gains(where: str, value: Any) -> tuple[float, ...] | float:
    if isinstance(value, (list, tuple)):
        return tuple(_number(where, "nominal_gains", v) for v in value)
    return _number(where, "nominal_gains", value)


def _gravity(where: str, value: Any) -> tuple[float, float, float]:
    if not isinstance(value, (list, tuple)) or len(value) != 3:
        raise _fail(where, "gravity", f"expected 3 numbers (m/s²), got {value!r}")
    x, y, z = (_number(where, "gravity", v) for v in value)
    return x, y, z


def _loops(where: str, value: Any) -> tuple[Loop, ...]:
    if not isinstance(value, list):
        raise _fail(where, "loops", f"expected a list of {{frame_a, frame_b, type}}, got {value!r}")
    out = []
    for item in value:
        if not isinstance(item, dict) or not {"frame_a", "frame_b"} <= set(item) or \
                not set(item) <= {"frame_a", "frame_b", "type"}:
            raise _fail(where, "loops", f"each loop is {{frame_a, frame_b, type: "
                        f"{'|'.join(LOOP_KINDS)}}}, got {item!r}")
        out.append(Loop(str(item["frame_a"]), str(item["frame_b"]), str(item.get("type", "point"))))
    return tuple(out)


def _mapping(where: str, key: str, value: Any) -> dict:
    if not isinstance(value, dict):
        raise _fail(where, key, f"expected a mapping, got {value!r}")
    return value


def _column_order(where: str, value: Any) -> tuple[tuple[str, ...], ...]:
    if not isinstance(value, list):
        raise _fail(where, "column_order", f"expected a list of body labels or of groups of them, "
                    f"got {value!r}")
    return tuple(tuple(str(x) for x in g) if isinstance(g, list) else (str(g),) for g in value)


def _expanded(where: str, path: Path, args: Any,
              package_dirs: Sequence[str | Path]) -> tuple[Path, str]:
    """(the cached URDF, the robot's name) of a xacro description (model/xacro_files.py)."""
    if not is_xacro(path):
        raise _fail(where, "xacro_args", f"given for {path.name}, which is not a .xacro")
    args = _mapping(where, "xacro_args", {} if args is None else args)
    name = path.name[:-len(".xacro")].removesuffix(".urdf")
    return expanded_file(path, {str(k): _xacro_value(v) for k, v in args.items()},
                         package_dirs), name


def _xacro_value(value: Any) -> str:
    """A YAML scalar as xacro's command line would give it (true -> "true")."""
    return str(value).lower() if isinstance(value, bool) else str(value)


def read_description(data: dict[str, Any], base_dir: Path, where: str = "robot file",
                     package_dirs: Sequence[str | Path] = ()) -> RobotDescription:
    """A :class:`RobotDescription` from a robot YAML's mapping; ``description`` is relative to
    ``base_dir`` (the YAML's folder); a xacro one is expanded with ``xacro_args``, its packages
    found through ``package_dirs`` (model/xacro_files.py)."""
    unknown = sorted(set(data) - set(KEYS))
    if unknown:
        raise ConfigError(f"{where}: unknown keys {unknown} (known: {', '.join(KEYS)})")
    if not isinstance(data.get("description"), str) or not data["description"]:
        raise _fail(where, "description", "the URDF or MJCF file of the robot is missing")
    path = (base_dir / data["description"]).resolve()
    kw: dict[str, Any] = {"path": path, "name": str(data.get("name") or path.stem)}
    if is_xacro(path) or "xacro_args" in data:
        kw["path"], name = _expanded(where, path, data.get("xacro_args"), package_dirs)
        kw["name"] = str(data.get("name") or name)
    if "actuated_joints" in data:
        kw["actuated_joints"] = _names(where, "actuated_joints", data["actuated_joints"])
    if "nominal_gains" in data:
        kw["nominal_gains"] = _gains(where, data["nominal_gains"])
    if "payload_frame" in data:
        kw["payload_frame"] = str(data["payload_frame"])
    if "gravity" in data:
        kw["gravity"] = _gravity(where, data["gravity"])
    if "loops" in data:
        kw["loops"] = _loops(where, data["loops"])
    if "reference_configuration" in data:
        ref = _mapping(where, "reference_configuration", data["reference_configuration"])
        kw["reference_configuration"] = {str(k): _number(where, f"reference_configuration.{k}", v)
                                         for k, v in ref.items()}
    if "passive_friction" in data:
        if not isinstance(data["passive_friction"], bool):
            raise _fail(where, "passive_friction", f"expected true or false, got "
                        f"{data['passive_friction']!r}")
        kw["passive_friction"] = data["passive_friction"]
    if "column_order" in data:
        kw["column_order"] = _column_order(where, data["column_order"])
    if "body_labels" in data:
        labels = _mapping(where, "body_labels", data["body_labels"])
        kw["body_labels"] = {str(k): str(v) for k, v in labels.items()}
    if "fixed_bodies" in data:
        kw["fixed_bodies"] = _names(where, "fixed_bodies", data["fixed_bodies"])
    if "excitation" in data:
        kw["excitation"] = dict(_mapping(where, "excitation", data["excitation"]))
    if "locked_joints" in data:
        locked = _mapping(where, "locked_joints", data["locked_joints"])
        kw["locked_joints"] = {str(k): _number(where, f"locked_joints.{k}", v)
                               for k, v in locked.items()}
    if "transmission" in data:
        kw["transmission"] = dict(_mapping(where, "transmission", data["transmission"]))
    if "current_sampling" in data:
        if data["current_sampling"] not in ("held", "sampled"):
            raise _fail(where, "current_sampling", "held (over the step that follows) or sampled "
                        f"(at the stamp, from a faster loop), not {data['current_sampling']!r}")
        kw["current_sampling"] = data["current_sampling"]
    return RobotDescription(**kw)


def per_joint(value: Any, joints: tuple[str, ...], what: str, width: int = 1) -> dict[str, Any]:
    """A robot-file value given as one number for all joints, a list in joint order, or a
    mapping joint -> value (``width`` 2: [lower, upper] pairs) -> {joint: value}."""
    def number(x: Any) -> Any:
        xs = x if width > 1 else [x]
        if not isinstance(xs, (list, tuple)) or len(xs) != width or not all(
                isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
                for v in xs):
            raise ConfigError(f"{what}: expected {'a number' if width == 1 else f'{width} numbers'}"
                              f" per joint, got {x!r}")
        return tuple(float(v) for v in xs) if width > 1 else float(x)

    if isinstance(value, dict):
        bad = sorted(set(value) - set(joints))
        if bad:
            raise ConfigError(f"{what}: {bad} are not actuated joints ({', '.join(joints)})")
        return {str(k): number(v) for k, v in value.items()}
    if isinstance(value, list) and (width == 1 or (value and isinstance(value[0], list))):
        if len(value) != len(joints):
            raise ConfigError(f"{what}: {len(value)} values for {len(joints)} joints")
        return {j: number(v) for j, v in zip(joints, value)}
    return {j: number(value) for j in joints}


def excitation_section(model) -> tuple[dict[str, Any], Path]:
    """The robot file's ``excitation`` mapping (checked for unknown keys) and its folder."""
    desc = model.description
    if desc is None:
        raise ConfigError(f"robot {model.name}: exciting trajectories need a robot described by a "
                          "URDF (--robot FILE.urdf, a robot YAML or a bundled name such as ur5; "
                          "for the Orthoglide: orthoglide_general)")
    section = dict(desc.excitation)
    unknown = sorted(set(section) - set(EXCITATION_KEYS))
    if unknown:
        raise ConfigError(f"robot {model.name}: excitation: unknown keys {unknown} (known: "
                          f"{', '.join(EXCITATION_KEYS)})")
    return section, desc.path.parent
