"""Which robot: ``--robot FILE`` (CLI) and the ``robot`` parameter (nodes) to a RobotModel.

- empty / ``orthoglide``: the Orthoglide's closed form (``model/orthoglide/base.py``), as without
  ``--robot``;
- a bundled name (a file ``orthoglide_ident/robots/<name>.yaml``, e.g. ``ur5e``, ``five_bar``);
- a URDF (``.urdf``): every movable joint actuated, the manufacturer's gains 1 per unit;
- a robot YAML (``.yaml``/``.yml``, docs/architecture.md "Robot files"): ``model: orthoglide`` or
  ``model: pinocchio`` with the description (URDF or MJCF), actuated joints, loop closures,
  nominal gains and payload frame.

Every failure is a ConfigError with a one-line reason (a file that does not parse, a joint that
does not exist, a loop that does not close).
"""
from __future__ import annotations

import functools
import logging
from pathlib import Path
from typing import Any

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.model.robot import RobotModel
from orthoglide_ident.yaml_files import load_yaml

ROBOTS_DIR = Path(__file__).resolve().parent.parent / "robots"  # bundled descriptions
DEFAULT_ROBOT = "orthoglide"


def bundled_robots() -> list[str]:
    """Names ``--robot`` accepts without a path, the Orthoglide first."""
    return [DEFAULT_ROBOT] + sorted(p.stem for p in ROBOTS_DIR.glob("*.yaml")
                                    if p.stem != DEFAULT_ROBOT)


def resolve(spec: str | Path | None) -> Path | None:
    """The robot file ``spec`` names (None: the Orthoglide's closed form)."""
    text = str(spec or "").strip()
    if text in ("", DEFAULT_ROBOT):
        return None
    path = Path(text).expanduser()
    bundled = ROBOTS_DIR / f"{text}.yaml"
    if bundled.exists() and path.suffix == "" and Path(text).name == text:
        if path.exists():  # a local ./ur5 (a folder of bags, a file without suffix): say so
            logging.getLogger("orthoglide_ident").warning(
                "robot %r: took the bundled robot %s, not the local %s %s (write ./%s/FILE.yaml "
                "for a file in it)", text, bundled, "folder" if path.is_dir() else "file",
                path.resolve(), text)
        return bundled
    if path.exists():
        return path.resolve()
    raise ConfigError(f"robot {text!r}: no such file, and not a bundled robot "
                      f"({', '.join(bundled_robots())})")


def read_yaml(path: Path) -> dict[str, Any]:
    data = load_yaml(path, "robot file")
    if not isinstance(data, dict):
        raise ConfigError(f"robot file {path}: expected a mapping of keys (name, model, "
                          "description, ...), got " + type(data).__name__)
    return data


def load_robot(spec: str | Path | None = None) -> RobotModel:
    """The RobotModel of ``spec`` (see the module docstring); computed once per file."""
    path = resolve(spec)
    return _load(str(path) if path else "")


@functools.lru_cache(maxsize=8)
def _load(path: str) -> RobotModel:
    if not path:
        from orthoglide_ident.model.orthoglide.base import base_model

        return base_model()
    p = Path(path)
    if p.suffix.lower() == ".urdf":
        return _pinocchio({"description": p.name}, p.parent)
    if p.suffix.lower() not in (".yaml", ".yml"):
        raise ConfigError(f"robot file {p}: expected a .urdf or a robot .yaml")
    data = read_yaml(p)
    kind = str(data.get("model", "pinocchio"))
    if kind == "orthoglide":
        return _orthoglide(data, p)
    if kind != "pinocchio":
        raise ConfigError(f"robot file {p}: model {kind!r} is not orthoglide or pinocchio")
    return _pinocchio(data, p.parent, f"robot file {p}")


ORTHOGLIDE_KEYS = ("name", "model", "geometry", "nominal_gains")


def _orthoglide(data: dict[str, Any], path: Path) -> RobotModel:
    """The closed form with the file's geometry (a, d4, d6 in m; gravity in m/s² along y0) and
    nominal gains (N/A: three numbers or one for all)."""
    from orthoglide_ident.model.orthoglide.base import base_model
    from orthoglide_ident.model.orthoglide.geometry import PAPER, Geometry

    unknown = sorted(set(data) - set(ORTHOGLIDE_KEYS))
    if unknown:
        raise ConfigError(f"robot file {path}: unknown key(s) {unknown} for model: orthoglide "
                          f"(known: {', '.join(ORTHOGLIDE_KEYS)})")
    geo = data.get("geometry") or {}
    if not isinstance(geo, dict) or set(geo) - {"a", "d4", "d6", "gravity"}:
        raise ConfigError(f"robot file {path}: geometry takes a, d4, d6 (m) and gravity (m/s²)")
    try:
        geometry = Geometry(float(geo.get("a", PAPER.a)), float(geo.get("d4", PAPER.d4)),
                            float(geo.get("d6", PAPER.d6)), float(geo.get("gravity", PAPER.g0)))
        gains = data.get("nominal_gains")
        if gains is not None:
            gains = tuple(float(x) for x in (gains if isinstance(gains, list) else [gains] * 3))
            if len(gains) != 3:
                raise ValueError("nominal_gains needs 3 numbers (q11, q12, q13) or one")
    except (TypeError, ValueError) as exc:
        raise ConfigError(f"robot file {path}: {exc}") from None
    return base_model(geometry, gains)


def _pinocchio(data: dict[str, Any], base_dir: Path, where: str | None = None) -> RobotModel:
    """The general model of a robot YAML's mapping (``where``: the file named in its errors)."""
    try:
        from orthoglide_ident.model.pinocchio_model import PinocchioRobot
    except ImportError as exc:  # the general model lands in its own step
        raise ConfigError(f"the general (Pinocchio) robot model is not available: {exc}") from None
    robot = PinocchioRobot.from_description(data, base_dir, where)
    return _with_transmission(robot, where or f"robot {robot.name}")


def _with_transmission(robot, where: str) -> RobotModel:
    """``robot`` seen from its motors (model/actuator_space.py) when its file has a
    ``transmission`` or its URDF ``<ros2_control>`` transmissions; else ``robot`` itself."""
    from orthoglide_ident.model.actuator_space import ActuatorSpaceRobot
    from orthoglide_ident.model.transmission import read_transmission, urdf_transmission

    desc = robot.description
    if desc.transmission is not None:
        t = read_transmission(desc.transmission, robot.joint_names, where)
    elif desc.path.suffix.lower() == ".urdf":
        t = urdf_transmission(desc.path, robot.joint_names)
    else:
        t = None
    return robot if t is None else ActuatorSpaceRobot(robot, t)


def description_cache() -> Path:
    """Where URDFs received as text are kept as files ($XDG_CACHE_HOME/orthoglide_ident)."""
    import os

    root = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(root) / "orthoglide_ident" / "robot_description"


def load_robot_description(urdf: str, cache_dir: Path | None = None) -> RobotModel:
    """The RobotModel of a URDF given as text (the ``robot_description`` topic): written once to
    ``<cache_dir>/<sha256 of the text>.urdf`` and loaded as a bare URDF (every movable joint
    actuated, nominal gains 1); the same text gives the same model without loading it again.
    ConfigError with a one-line reason if it is not a URDF."""
    import hashlib
    import xml.etree.ElementTree as ET

    try:
        root = ET.fromstring(urdf)
    except ET.ParseError as exc:
        raise ConfigError(f"robot_description is not valid XML ({exc})") from None
    if root.tag != "robot":
        raise ConfigError(f"robot_description is not a URDF (root element <{root.tag}>, not <robot>)")
    folder = cache_dir or description_cache()
    path = folder / f"{hashlib.sha256(urdf.encode()).hexdigest()[:32]}.urdf"
    if not path.exists():
        try:
            folder.mkdir(parents=True, exist_ok=True)
            tmp = path.with_suffix(".tmp")
            tmp.write_text(urdf)
            tmp.replace(path)  # whole or not at all: another process may read it
        except OSError as exc:
            raise ConfigError(f"cannot keep robot_description in {folder}: {exc.strerror}") from None
    return _load_description(str(path), root.get("name") or "robot_description")


@functools.lru_cache(maxsize=4)
def _load_description(path: str, name: str) -> RobotModel:
    return _pinocchio({"description": Path(path).name, "name": name}, Path(path).parent)
