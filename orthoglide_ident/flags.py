"""One grammar for the command line's flags, whatever the command.

- vectors (``--payload-com``, ``--payload-inertia``, a column map's ``payload_com``): numbers
  separated by commas, spaces or both (``0.02,0,0.05``, ``'0.02 0 0.05'``) or a YAML list;
- output paths (``--out``, ``--json``, ``--urdf-out``, ...): their missing parent folders are
  created before any long work, or the command refuses at once, naming the flag.
"""
from __future__ import annotations

import math
import os
import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from orthoglide_ident.errors import ConfigError

# every flag that names a file or folder a command writes (argparse dest names)
OUTPUT_FLAGS = ("out", "json", "urdf_out", "mjcf_out", "mcap", "samples")


def parse_vector(value: Any, n: int | None, what: str) -> tuple[float, ...]:
    """``n`` finite numbers (any count for None) from ``X,Y,Z``, ``'X Y Z'`` or a list."""
    if isinstance(value, str):
        items: Sequence[Any] = [x for x in re.split(r"[,\s]+", value.strip()) if x]
    elif isinstance(value, (list, tuple)):
        items = value
    else:
        items = [value]
    try:
        vals = tuple(float(x) for x in items)
    except (TypeError, ValueError):
        vals = ()
    if not vals or (n is not None and len(vals) != n) or not all(map(math.isfinite, vals)):
        count = f"{n} numbers" if n is not None else "numbers"
        raise ConfigError(f"{what}: expected {count} separated by commas (X,Y,Z) or spaces "
                          f"('X Y Z'), got {value!r}")
    return vals


def prepare_output(path: str | Path, flag: str) -> Path:
    """``path``'s parent folders created; ConfigError now if it cannot be written there."""
    p = Path(path).expanduser()
    parent = p.parent if str(p.parent) else Path(".")
    try:
        parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ConfigError(f"{flag} {path}: cannot create the folder {parent} "
                          f"({exc.strerror or exc})") from None
    if not os.access(parent, os.W_OK | os.X_OK):
        raise ConfigError(f"{flag} {path}: the folder {parent} is not writable")
    if p.exists() and not os.access(p, os.W_OK):
        raise ConfigError(f"{flag} {path}: the file exists and is not writable")
    return p


def prepare_outputs(args: Any) -> None:
    """:func:`prepare_output` for every output flag a command was given."""
    for dest in OUTPUT_FLAGS:
        value = getattr(args, dest, None)
        if isinstance(value, str) and value:
            prepare_output(value, "--" + dest.replace("_", "-"))
