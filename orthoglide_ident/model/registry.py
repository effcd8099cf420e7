"""Which robot: ``--robot FILE`` (CLI) and the ``robot`` parameter (nodes) to a RobotModel.

- empty / ``orthoglide``: the Orthoglide's closed form (``model/orthoglide/base.py``), as without
  ``--robot``;
- a bundled name (a file ``orthoglide_ident/robots/<name>.yaml``, e.g. ``ur5e``, ``five_bar``);
- a URDF (``.urdf``): every movable joint actuated, the manufacturer's gains 1 per unit;
- a xacro (``.urdf.xacro``, ``.xacro``): expanded in-process with its arguments, then as a URDF
  (model/xacro_files.py);
- an MJCF (``.xml``): as a URDF, its joints' armature, damping and frictionloss the nominal
  ia, fv, fs;
- a robot YAML (``.yaml``/``.yml``, docs/guide/robot_files.md): ``model: orthoglide`` or
  ``model: pinocchio`` with the description (URDF or MJCF), actuated joints, loop closures,
  nominal gains and payload frame.

Every failure is a ConfigError with a one-line reason (a file that does not parse, a joint that
does not exist, a loop that does not close).
"""
from __future__ import annotations

import functools
import logging
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.model.robot import RobotModel
from orthoglide_ident.model.xacro_files import description_cache, is_xacro, parse_xacro_args
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


def load_robot(spec: str | Path | None = None, xacro_args: Mapping[str, str] | None = None,
               package_dirs: Sequence[str | Path] = ()) -> RobotModel:
    """The RobotModel of ``spec`` (see the module docstring); computed once per file and
    arguments. ``xacro_args`` (``--xacro-arg``) override a robot file's ``xacro_args``;
    ``package_dirs`` (``--package-dir``) are searched for a xacro's packages first."""
    path = resolve(spec)
    args = tuple(sorted((str(k), str(v)) for k, v in (xacro_args or {}).items()))
    dirs = tuple(str(Path(d).expanduser().resolve()) for d in package_dirs)
    return _load(str(path) if path else "", args, dirs)


def add_description_options(p, package_dir: bool = True) -> None:
    """``--xacro-arg`` and ``--package-dir`` of a command that takes ``--robot``."""
    p.add_argument("--xacro-arg", action="append", default=[], metavar="NAME:=VALUE",
                   help="an argument of a .xacro robot description (repeatable; overrides the "
                        "robot file's xacro_args)")
    if package_dir:
        p.add_argument("--package-dir", action="append", default=[], metavar="DIR",
                       help="where $(find pkg) and package:// packages are found: the package "
                            "folder or one holding it (repeatable; before ROS_PACKAGE_PATH and "
                            "the ament index)")


def load_robot_from_args(args, spec: str | Path | None = None) -> RobotModel:
    """load_robot of a command's ``--robot`` (or ``spec``), ``--xacro-arg``, ``--package-dir``."""
    items = getattr(args, "xacro_arg", None) or []
    return load_robot(spec if spec is not None else args.robot, parse_xacro_args(items),
                      getattr(args, "package_dir", None) or ())


@functools.lru_cache(maxsize=8)
def _load(path: str, xacro_args: tuple = (), package_dirs: tuple = ()) -> RobotModel:
    if not path:
        if xacro_args:
            raise ConfigError("--xacro-arg is for a .xacro robot description (--robot)")
        from orthoglide_ident.model.orthoglide.base import base_model

        return base_model()
    p = Path(path)
    data: dict[str, Any] = {"description": p.name}
    if is_xacro(p):
        data["xacro_args"] = dict(xacro_args)
    elif p.suffix.lower() in (".urdf", ".xml"):
        if xacro_args:
            raise ConfigError(f"--xacro-arg is for a .xacro robot description, not {p}")
        data.update(_mjcf_gravity(p) if p.suffix.lower() == ".xml" else {})
    elif p.suffix.lower() in (".yaml", ".yml"):
        data = read_yaml(p)
        if xacro_args:
            data["xacro_args"] = {**(data.get("xacro_args") or {}), **dict(xacro_args)}
    else:
        raise ConfigError(f"robot file {p}: expected a .urdf, a .urdf.xacro, an MJCF .xml or a "
                          "robot .yaml")
    kind = str(data.get("model", "pinocchio"))
    if kind == "orthoglide":
        return _orthoglide(data, p)
    if kind != "pinocchio":
        raise ConfigError(f"robot file {p}: model {kind!r} is not orthoglide or pinocchio")
    where = f"robot file {p}" if p.suffix.lower() in (".yaml", ".yml") else None
    return _pinocchio(data, p.parent, where, package_dirs)


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


def _pinocchio(data: dict[str, Any], base_dir: Path, where: str | None = None,
               package_dirs: Sequence[str] = ()) -> RobotModel:
    """The general model of a robot YAML's mapping (``where``: the file named in its errors)."""
    try:
        from orthoglide_ident.model.pinocchio_model import PinocchioRobot
    except ImportError as exc:  # the general model lands in its own step
        raise ConfigError(f"the general (Pinocchio) robot model is not available: {exc}") from None
    robot = PinocchioRobot.from_description(data, base_dir, where, package_dirs)
    if robot.description.path.suffix.lower() == ".xml":
        _say_mjcf_nominals(robot)
    return _with_transmission(robot, where or f"robot {robot.name}")


def _mjcf_gravity(path: Path) -> dict[str, Any]:
    """``{"gravity": [x, y, z]}`` of an MJCF's ``<option gravity>`` (none: the default)."""
    import xml.etree.ElementTree as ET

    try:
        option = ET.parse(path).getroot().find("option")
        text = None if option is None else option.get("gravity")
        return {} if text is None else {"gravity": [float(x) for x in text.split()]}
    except (ET.ParseError, OSError, ValueError):
        return {}  # the description's own reader says what is wrong with it


def _say_mjcf_nominals(robot) -> None:
    """An MJCF's joint armature, damping and frictionloss are the nominal ia, fv, fs: said."""
    import logging

    terms = [f"{j.name} {robot.model.armature[j.iv]:.4g}/{j.damping:.4g}/{j.friction:.4g}"
             for j in robot.actuated if robot.model.armature[j.iv] or j.damping or j.friction]
    if terms:
        logging.getLogger("orthoglide_ident").info(
            "robot %s (MJCF): the joints' armature/damping/frictionloss taken as the nominal "
            "ia/fv/fs: %s", robot.name, ", ".join(terms))


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
        raise ConfigError(
            f"robot_description is not a URDF (root element <{root.tag}>, not <robot>)"
        )
    folder = cache_dir or description_cache()
    path = folder / f"{hashlib.sha256(urdf.encode()).hexdigest()[:32]}.urdf"
    if not path.exists():
        try:
            folder.mkdir(parents=True, exist_ok=True)
            tmp = path.with_suffix(".tmp")
            tmp.write_text(urdf)
            tmp.replace(path)  # whole or not at all: another process may read it
        except OSError as exc:
            raise ConfigError(
                f"cannot keep robot_description in {folder}: {exc.strerror}"
            ) from None
    return _load_description(str(path), root.get("name") or "robot_description")


@functools.lru_cache(maxsize=4)
def _load_description(path: str, name: str) -> RobotModel:
    return _pinocchio({"description": Path(path).name, "name": name}, Path(path).parent)
