"""The loaded/unloaded tag of a bag (docs/architecture.md §4)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from orthoglide_ident.errors import BagError, ConfigError

CONDITION_KEY = "orthoglide.condition"
MASS_KEY = "orthoglide.payload_mass"
METADATA_NAME = "orthoglide"
CONDITIONS = ("loaded", "unloaded")


@dataclass(frozen=True)
class BagTags:
    """``condition``: ``loaded`` | ``unloaded``; ``payload_mass`` in kg (0 when unloaded)."""

    condition: str
    payload_mass: float

    @classmethod
    def checked(cls, condition: str, payload_mass: float) -> BagTags:
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
        return cls(condition, mass)

    def to_dict(self) -> dict[str, str]:
        """The two keys as stored in custom_data and in the MCAP metadata record."""
        mass = "0" if self.payload_mass == 0 else format(self.payload_mass, ".12g")
        return {CONDITION_KEY: self.condition, MASS_KEY: mass}

    @classmethod
    def from_dict(cls, items: dict[str, str] | None, where: str) -> BagTags | None:
        """Parse the two keys; None when neither is there; BagError when they are invalid."""
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
            return cls.checked(cond, value)
        except ConfigError as exc:
            raise BagError(f"{where}: invalid tag: {exc}") from None
