"""URDFs of the example-robot-data wheel (a requirement of `make setup`: missing, a test fails
rather than skips)."""
from __future__ import annotations

import importlib.metadata
from pathlib import Path

ROBOTS = "cmeel.prefix/share/example-robot-data/robots"


def urdf(path: str) -> Path:
    """``ROBOTS/<path>`` of the installed wheel, e.g. ``ur_description/urdf/ur10_robot.urdf``."""
    dist = importlib.metadata.distribution("example-robot-data")
    p = Path(dist.locate_file(f"{ROBOTS}/{path}"))
    if not p.is_file():
        raise FileNotFoundError(f"example-robot-data has no {path} ({p})")
    return p
