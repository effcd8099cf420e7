"""Names and order of the standard dynamic parameters (paper Sect. 2.2, docs/design/conventions.md).

Canonical order of the 208 robot parameters: leg 1 bodies 1..5, leg 2 bodies 1..5, leg 3 bodies
1..5,
then the platform (body 6). Each leg body has the inertia at its frame origin (6), first moments
(3),
mass, then the joint's drive/friction terms: ``ia`` (actuated joint 1 only), ``fv``, ``fs``,
``tauoff``. The payload (body 7) has 10 inertial parameters kept apart (W_ul, W_kl of eq. 29).
"""
from __future__ import annotations

INERTIAL = ("xx", "xy", "xz", "yy", "yz", "zz", "mx", "my", "mz", "m")
ACTUATED_EXTRA = ("ia", "fv", "fs", "tauoff")
PASSIVE_EXTRA = ("fv", "fs", "tauoff")

N_LEGS = 3
N_BODIES = 5  # bodies 1 (foot, prismatic) to 5 of each leg


def body_kinds(body: int) -> tuple[str, ...]:
    """Parameter kinds of leg body ``body`` (1..5), in canonical order."""
    return INERTIAL + (ACTUATED_EXTRA if body == 1 else PASSIVE_EXTRA)


# One leg's standard parameters as (kind, body): 14 + 4 x 13 = 66 ("n_stleg" of eq. 23).
LEG_PARAMETERS: tuple[tuple[str, int], ...] = tuple(
    (kind, body) for body in range(1, N_BODIES + 1) for kind in body_kinds(body)
)
N_ST_LEG = len(LEG_PARAMETERS)


def leg_name(kind: str, body: int, leg: int) -> str:
    """Paper-style name, e.g. ``leg_name('m', 1, 3) == 'm_13'`` (second digit = leg)."""
    return f"{kind}_{body}{leg}"


STANDARD_NAMES: tuple[str, ...] = tuple(
    leg_name(kind, body, leg) for leg in range(1, N_LEGS + 1) for kind, body in LEG_PARAMETERS
) + tuple(f"{kind}_6" for kind in INERTIAL)
PAYLOAD_NAMES: tuple[str, ...] = tuple(f"{kind}_7" for kind in INERTIAL)
N_ST = len(STANDARD_NAMES)  # 208
INDEX = {name: k for k, name in enumerate(STANDARD_NAMES)}


def leg_column(leg: int, k_leg: int) -> int:
    """Column in the canonical order of leg parameter ``k_leg`` (0..65) of ``leg`` (1..3)."""
    return (leg - 1) * N_ST_LEG + k_leg


PLATFORM_COLUMNS = tuple(range(N_LEGS * N_ST_LEG, N_ST))
