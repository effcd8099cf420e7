"""Which robot: ``--robot FILE`` (CLI) and the ``robot`` parameter (nodes) to a RobotModel.

- empty / ``orthoglide``: the Orthoglide's closed form (``model/base.py``), as without ``--robot``;
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
from pathlib import Path
from typing import Any

import yaml

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.model.robot import RobotModel

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
    if path.exists():
        return path.resolve()
    bundled = ROBOTS_DIR / f"{text}.yaml"
    if bundled.exists() and path.suffix == "":
        return bundled
    raise ConfigError(f"robot {text!r}: no such file, and not a bundled robot "
                      f"({', '.join(bundled_robots())})")


def read_yaml(path: Path) -> dict[str, Any]:
    try:
        data = yaml.safe_load(path.read_text())
    except (OSError, yaml.YAMLError) as exc:
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise ConfigError(f"robot file {path}: cannot read it ({reason})") from None
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
        from orthoglide_ident.model.base import base_model

        return base_model()
    p = Path(path)
    if p.suffix.lower() == ".urdf":
        return _pinocchio({"description": p.name}, p.parent)
    if p.suffix.lower() not in (".yaml", ".yml"):
        raise ConfigError(f"robot file {p}: expected a .urdf or a robot .yaml")
    data = read_yaml(p)
    kind = str(data.get("model", "pinocchio"))
    if kind == "orthoglide":
        from orthoglide_ident.model.base import base_model

        return base_model()
    if kind != "pinocchio":
        raise ConfigError(f"robot file {p}: model {kind!r} is not orthoglide or pinocchio")
    return _pinocchio(data, p.parent)


def _pinocchio(data: dict[str, Any], base_dir: Path) -> RobotModel:
    try:
        from orthoglide_ident.model.pinocchio_model import PinocchioRobot
    except ImportError as exc:  # the general model lands in its own step
        raise ConfigError(f"the general (Pinocchio) robot model is not available: {exc}") from None
    return PinocchioRobot.from_description(data, base_dir)
