"""ROS parameters from one table: declared with descriptors, typed leniently, listed in --help.

Each node keeps a tuple of ``Param``; the same table declares the parameters (with their
descriptions, so ``ros2 param describe`` explains them), checks values given on the command line
or in a YAML file (an integer where a float is expected is fine, and YAML's true/false where a
string is, as the words on/off it was written as; anything else gets a one-line
reason naming the parameter), refuses changes to read-only parameters at run time with a reason,
and writes the parameter section of ``--help``.
"""
from __future__ import annotations

import array
import math
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from typing import Any

from orthoglide_ident.errors import ConfigError, OrthoglideError


@dataclass(frozen=True)
class Param:
    """One ROS parameter: name, default (its type is the parameter's type), what it means, and
    whether it may change while the node runs (``ros2 param set``)."""

    name: str
    default: Any
    description: str
    dynamic: bool = False
    any_type: bool = False  # e.g. payload: "none" or 1.983

    @property
    def kind(self) -> str:
        d = self.default
        if self.any_type:
            return "any"
        if isinstance(d, bool):
            return "bool"
        if isinstance(d, int):
            return "int"
        if isinstance(d, float):
            return "float"
        if isinstance(d, str):
            return "string"
        if isinstance(d, (list, tuple)) and d and isinstance(d[0], str):
            return "string[]"
        return "float[]"

    def coerce(self, value: Any) -> Any:
        """The value as the parameter's type; ConfigError with a one-line reason otherwise."""
        kind = self.kind

        def bad() -> ConfigError:
            return ConfigError(f"parameter {self.name}: expected {kind}, got {value!r}")

        if kind == "any":
            return value
        if kind == "bool":
            if isinstance(value, bool):
                return value
            raise bad()
        if kind == "string":
            if isinstance(value, str):
                return value
            if isinstance(value, bool):  # `ros2 param set ... off` arrives as YAML's false
                return "on" if value else "off"
            raise bad()
        if kind == "int":
            if isinstance(value, int) and not isinstance(value, bool):
                return value
            raise bad()
        if kind == "float":
            if (
                isinstance(value, (int, float))
                and not isinstance(value, bool)
                and math.isfinite(value)
            ):
                return float(value)
            raise bad()
        if isinstance(value, array.array):  # rclpy hands numeric arrays over as array.array
            value = value.tolist()
        if kind == "string[]":
            if isinstance(value, (list, tuple)) and all(isinstance(v, str) for v in value):
                return list(value)
            raise bad()
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            value = [value]
        if isinstance(value, (list, tuple)) and all(
            isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
            for v in value
        ):
            return [float(v) for v in value]
        raise bad()


def usage(synopsis: str, doc: str, table: Iterable[Param]) -> str:
    """--help text: usage line, the node's description, then every parameter."""
    lines = [
        synopsis,
        "",
        doc.strip(),
        "",
        "ROS parameters (--ros-args -p NAME:=VALUE or --params-file FILE.yaml;"
        " * = may be changed while running with ros2 param set):",
    ]
    for p in table:
        default = repr(p.default) if not isinstance(p.default, str) else f'"{p.default}"'
        lines.append(f"  {p.name + (' *' if p.dynamic else ''):<22} {p.kind:<8} default {default}")
        lines.append(f"      {p.description}")
    return "\n".join(lines)


def declare(node: Any, table: Iterable[Param]) -> dict[str, Any]:
    """Declare every parameter of ``table`` on ``node`` and return the checked values by name.

    Declared with dynamic typing so that ``-p duration:=2`` (an integer) reaches our check instead
    of an rclpy traceback; read-only unless ``dynamic``. Raises ConfigError on a bad value.
    """
    from rcl_interfaces.msg import ParameterDescriptor

    values = {}
    for p in table:
        desc = ParameterDescriptor(
            description=p.description, dynamic_typing=True, read_only=not p.dynamic
        )
        value = node.declare_parameter(p.name, p.default, desc).value
        values[p.name] = p.coerce(value)
    return values


def on_set(node: Any, table: Iterable[Param], apply: Callable[[Mapping[str, Any]], None]) -> None:
    """Accept run-time changes of dynamic parameters: checked, then ``apply({name: value})``; an
    OrthoglideError from ``apply`` refuses the change with its one-line reason."""
    from rcl_interfaces.msg import SetParametersResult

    by_name = {p.name: p for p in table}

    def callback(params: list) -> Any:
        changes = {}
        try:
            for prm in params:
                spec = by_name.get(prm.name)
                if spec is None:
                    continue  # e.g. use_sim_time: rclpy's own
                changes[prm.name] = spec.coerce(prm.value)
            if changes:
                apply(changes)
        except OrthoglideError as e:
            return SetParametersResult(successful=False, reason=str(e).splitlines()[0])
        return SetParametersResult(successful=True)

    node.add_on_set_parameters_callback(callback)


def from_command_line(argv: list[str], name: str, nodes: Iterable[str]) -> Any:
    """The value the command line gives parameter ``name`` before the node exists (which node to
    build: the driver's ``robot``): ``-p/--param NAME:=VALUE`` after ``--ros-args``, else a
    ``--params-file`` entry under ``/**`` or one of the node names ``nodes`` (or the name
    ``-r __node:=`` gives; the last file that has it wins); None when not given. ConfigError for
    a params file that cannot be read."""
    import yaml

    value, ros, files, names = None, False, [], list(nodes)
    for i, arg in enumerate(argv):
        if arg == "--ros-args":
            ros = True
        elif arg == "--":
            ros = False
        elif (
            ros
            and arg in ("-p", "--param")
            and i + 1 < len(argv)
            and argv[i + 1].startswith(f"{name}:=")
        ):
            value = yaml.safe_load(argv[i + 1].split(":=", 1)[1])
        elif ros and arg == "--params-file" and i + 1 < len(argv):
            files.append(argv[i + 1])
        elif (
            ros
            and arg in ("-r", "--remap")
            and i + 1 < len(argv)
            and argv[i + 1].startswith("__node:=")
        ):
            names.append(argv[i + 1].split(":=", 1)[1])
    if value is not None:
        return value
    for path in reversed(files):
        try:
            with open(path) as f:
                data = yaml.safe_load(f) or {}
        except (OSError, yaml.YAMLError) as exc:
            raise ConfigError(f"--params-file {path}: {str(exc).splitlines()[0]}") from None
        for key in ("/**", "**", *names, *(f"/{n}" for n in names)):
            section = data.get(key) if isinstance(data, dict) else None
            params = section.get("ros__parameters") if isinstance(section, dict) else None
            if isinstance(params, dict) and name in params:
                return params[name]
    return None
