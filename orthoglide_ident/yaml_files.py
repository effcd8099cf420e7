"""Reading the product's YAML files (options, robot files, plant truths) with one-line reasons.

Every loader said the same three things in its own words: the file cannot be read, it is not
YAML, or it is a mapping wrapped in one section key; they say it here once.
"""
from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from orthoglide_ident.errors import ConfigError


def safe_load(text: str) -> Any:
    """``yaml.safe_load`` by libyaml's parser when PyYAML has it (10x faster: a robot file and
    a bag's metadata are ~1 ms instead of ~8 ms of an identification), else the Python one."""
    import yaml

    return yaml.load(text, Loader=getattr(yaml, "CSafeLoader", yaml.SafeLoader))


def load_yaml(path: str | Path, what: str) -> Any:
    """The content of the YAML file ``path`` (None when empty); ConfigError "cannot read
    {what} {path}: …" or "{what} {path} is not valid YAML: …" (first line of the reason)."""
    import yaml  # on demand: the numerical paths that never read a file skip its import

    p = Path(path)
    try:
        text = p.read_text()
    except OSError as exc:
        raise ConfigError(f"cannot read {what} {p}: {exc.strerror or exc}") from None
    try:
        return safe_load(text)
    except yaml.YAMLError as exc:
        raise ConfigError(f"{what} {p} is not valid YAML: {str(exc).splitlines()[0]}") from None


def unwrap_section(data: Any, key: str) -> Any:
    """``data[key]`` when ``data`` is a mapping holding only ``key`` (a file may name its
    section, e.g. ``arm_plant:``, or hold the section's content directly); else ``data``."""
    if isinstance(data, Mapping) and set(data) == {key}:
        return data[key]
    return data
