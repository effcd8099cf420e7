"""A payload known by its mass only: its other parameters join the unknowns (paper Sect. 4.3).

The paper's loaded equations (eqs. 29, 31) split the payload's ten inertial parameters into the
known ones χ_kl (their column W_kl χ_kl is the scale of eq. 33) and the unknown ones χ_ul,
identified with the robot's:

    [ W_a   0      0    ] [ χ    ]
    [ W_b   W_ul   W_kl ] [ χ_ul ]  = g_τ v_τ                                  eqs. (29), (31)
                          [ χ_kl ]

The weighed mass is the accurate one; a CAD centre of mass or inertia is not (Sect. 4.3). With
only the mass known, W_kl is the column of a point mass at the payload frame's origin and χ_ul
holds the first moments (mx, my, mz) and the inertia at that origin; with the centre of mass
known too, χ_ul is the inertia about the centre of mass (whose columns are those of the inertia
at the origin: I_o = I_c + m(‖c‖² 1 − c cᵀ), the second term known).

The payload is fixed to one body, so its parameters regroup as that body's do: its base
combinations come from a QR of its own columns on random states (as base parameters are found,
eq. 22), the known mass column first. Columns that vanish are dropped (the Orthoglide's platform
only translates: only the mass acts, χ_ul is empty and nothing changes). χ_ul needs no
regrouping with the robot's χ: its columns are zero in the unloaded rows, which fix χ alone.
An unknown column that depends on the mass column would bias the scale: refused.

The column layout (layout.py) puts the χ_ul columns after the robot's base columns,
[W | W_ul | W_kl]: zero in an unloaded record and in a loaded one whose payload is known in full
(their rows are those of the robot's own model; :func:`used_columns` finds those some record
fills, the others are dropped before the solve).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from orthoglide_ident.errors import IdentificationError, ModelError
from orthoglide_ident.model.base_parameters import base_parameters
from orthoglide_ident.model.robot import INERTIAL_KINDS, PAYLOAD_UNKNOWN, Payload

LABEL = "L"  # the payload's parameter names: mx_L, xx_LR ... (the paper's l, for load)
N_STATES = 300  # random states for the payload's QR (10 columns × n_j rows each)
STATES_SEED = 7


def payload_name(kind: str) -> str:
    return f"{kind}_{LABEL}"


@dataclass(frozen=True)
class PayloadBasis:
    """The identifiable combinations of a payload's unknown parameters at ``frame``.

    ``kinds``: the unknown kinds kept (their columns are W_ul), ``K`` (n_ul, 9): χ_ul = K χ_u over
    PAYLOAD_UNKNOWN["mass"]; ``names``/``expressions`` of each combination."""

    frame: str
    kinds: tuple[str, ...]
    K: np.ndarray
    names: tuple[str, ...]
    expressions: tuple[str, ...]

    @property
    def n(self) -> int:
        return len(self.kinds)


def payload_basis(model, frame: str) -> PayloadBasis:
    """QR (eq. 22) of [W_m | W_u] of the payload at ``frame`` on random states: the unknown
    kinds that act, their regrouping; ModelError when an unknown cannot be told from the mass."""
    q, qd, qdd = model.random_states(max(N_STATES, 40), STATES_SEED)
    X = model.payload_standard_block(q, qd, qdd, frame)
    unknown = PAYLOAD_UNKNOWN["mass"]
    kinds = ("m",) + unknown
    W = np.stack([X[INERTIAL_KINDS.index(k)].reshape(-1) for k in kinds], axis=1)
    names = [payload_name(k) for k in kinds]
    if not np.any(W[:, 0]):
        raise ModelError(f"a payload at {frame or model.payload_frame} puts no force on any "
                         "actuated joint: its mass cannot scale the drive gains")
    if not np.any(W[:, 1:]):  # only the mass acts (a translating platform)
        return PayloadBasis(frame, (), np.zeros((0, len(unknown))), (), ())
    base = base_parameters(W, names, range(len(kinds)))
    if base.columns[0] != 0 or np.any(base.K[0, 1:]):
        terms = [t for t, c in zip(names[1:], base.K[0, 1:]) if c]
        raise ModelError(f"the payload's {', '.join(terms)} act like its mass at "
                         f"{frame or model.payload_frame}: the mass alone cannot scale the gains "
                         "there; give its centre of mass and inertia (orthoglide.payload_com, "
                         "orthoglide.payload_inertia)")
    params = base.parameters[1:]
    return PayloadBasis(frame, tuple(p.standard.rsplit("_", 1)[0] for p in params),
                        base.K[1:, 1:], tuple(p.name for p in params),
                        tuple(p.expression for p in params))


def used_columns(W: list[np.ndarray], start: int, n: int) -> tuple[int, ...]:
    """Which of the n payload columns at ``start`` are non-zero in any record's W (n_j, r, c)."""
    return tuple(k for k in range(n) if any(np.any(w[:, :, start + k]) for w in W))


def check_one_payload(payloads: list[tuple[str, Payload]]) -> None:
    """IdentificationError unless every loaded record whose payload is partly unknown carries
    the same payload (same mass, frame, knowledge): one χ_ul for all of them."""
    partial = [(src, p) for src, p in payloads if p.unknown]
    for src, p in partial[1:]:
        src0, p0 = partial[0]
        same = (math.isclose(p.mass, p0.mass, rel_tol=0, abs_tol=1e-9) and p.frame == p0.frame
                and p.known == p0.known and (p.known != "com" or p.com == p0.com))
        if not same:
            raise IdentificationError(
                f"{src} and {src0} carry payloads whose other parameters are unknown but differ "
                f"({p.mass:g} kg at {p.frame or 'the payload frame'}, {p.known} known; "
                f"{p0.mass:g} kg at {p0.frame or 'the payload frame'}, {p0.known} known): "
                "identify one such payload at a time, or tag their CoM and inertia")
