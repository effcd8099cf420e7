"""The tags a bag carries in its metadata.yaml (docs/design/interfaces.md): their keys, the
values some take, and ``BagTags`` that reads and writes them: ``bags.tags.MASS_KEY``, ..."""
from __future__ import annotations

from ._tags import (
    COM_KEY,
    CONDITION_KEY,
    CONDITIONS,
    CURRENT_SOURCE_KEY,
    EFFORT_SIDE_KEY,
    EFFORT_UNIT_KEY,
    FRAME_KEY,
    INCOMPLETE_KEY,
    INERTIA_KEY,
    MASS_KEY,
    METADATA_NAME,
    POSITION_SIDE_KEY,
    POSITION_SOURCE_KEY,
    SIDES,
    BagTags,
)

__all__ = [
    "COM_KEY",
    "CONDITIONS",
    "CONDITION_KEY",
    "CURRENT_SOURCE_KEY",
    "EFFORT_SIDE_KEY",
    "EFFORT_UNIT_KEY",
    "FRAME_KEY",
    "INCOMPLETE_KEY",
    "INERTIA_KEY",
    "MASS_KEY",
    "METADATA_NAME",
    "POSITION_SIDE_KEY",
    "POSITION_SOURCE_KEY",
    "SIDES",
    "BagTags",
]
