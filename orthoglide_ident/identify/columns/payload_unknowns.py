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

:class:`PayloadUnknownsModel` wraps a robot model with the χ_ul columns after its base columns,
[W | W_ul | W_kl]: zero in an unloaded record and in a loaded one whose payload is known in full
(their rows are those of today's model; ``drop_unused`` removes the columns no record fills).
"""
from __future__ import annotations

import math
import weakref
from dataclasses import dataclass

import numpy as np

from orthoglide_ident.errors import ConfigError, IdentificationError, ModelError
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


class PayloadUnknownsModel:
    """A robot model with the unknown payload parameters' columns: [W | W_ul | W_kl].

    Bound to no payload (unloaded) its W_ul columns are zero; ``with_payload`` gives the model
    of a loaded record: W_ul filled for a payload known by its mass (or mass and CoM), W_kl of
    its known part. The robot's sizes and names are the base model's, plus ``payload_names``.
    """

    def __init__(self, model, basis: PayloadBasis, payload: Payload | None = None,
                 columns: tuple[int, ...] | None = None):
        self.base, self.basis, self.payload = model, basis, payload
        self.columns = tuple(range(basis.n)) if columns is None else tuple(columns)
        self.n_base = len(model.names)
        self.joints, self.name = model.joints, model.name
        self.joint_names, self.n_joints = model.joint_names, model.n_joints
        self.nominal_gains = model.nominal_gains
        self.payload_frame = model.payload_frame
        self.payload_names = [basis.names[k] for k in self.columns]
        self.payload_expressions = [basis.expressions[k] for k in self.columns]
        self.names = list(model.names) + self.payload_names
        self.expressions = list(getattr(model, "expressions", [""] * self.n_base)) \
            + self.payload_expressions

    @property
    def payload_slice(self) -> slice:
        """Where χ_ul sits among the unknowns (after the robot's base parameters)."""
        return slice(self.n_base, self.n_base + len(self.columns))

    def observation_block(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray,
                          out: np.ndarray | None = None) -> np.ndarray:
        """[W | W_ul | W_kl] of states (m, n_j) as (n_b + n_ul + 1, n_j, m)."""
        n, k, m = self.n_base, len(self.columns), np.shape(q)[0]
        if out is None:
            out = np.empty((n + k + 1, self.n_joints, m))
        if self.payload is None or not self.payload.unknown or not k:
            self.base.observation_block(q, qd, qdd, out=out[:n + 1])
            out[n + k] = out[n]  # W_kl goes last
            out[n:n + k] = 0.0
            return out
        X = self.base.observation_and_payload_block(q, qd, qdd, self.payload.frame)
        out[:n] = X[:n]
        out[n + k] = X[n]
        for i, c in enumerate(self.columns):
            kind = self.basis.kinds[c]
            out[n + i] = X[n + 1 + INERTIAL_KINDS.index(kind)] if kind in self.payload.unknown \
                else 0.0
        return out

    @property
    def rough_columns(self) -> tuple[int, ...] | None:
        """The robot's rough columns (identify/stream.py): among W's, the same indices; the
        payload's columns W_ul, W_kl are smooth. None when the robot does not say."""
        return getattr(self.base, "rough_columns", None)

    def rough_block(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray,
                    out: np.ndarray | None = None) -> np.ndarray:
        return self.base.rough_block(q, qd, qdd, out)

    def regressor(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        X = self.observation_block(q, qd, qdd)[:-1]
        return X.reshape(X.shape[0], -1).T

    def payload_mass_column(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        return self.observation_block(q, qd, qdd)[-1].reshape(-1)

    def payload_standard_block(self, q, qd, qdd, frame: str):
        return self.base.payload_standard_block(q, qd, qdd, frame)

    def random_states(self, n: int, seed: int = 0):
        return self.base.random_states(n, seed)

    def with_payload(self, payload: Payload) -> PayloadUnknownsModel:
        """The model of a loaded record carrying ``payload``: its known part in W_kl, its
        unknown kinds in W_ul (ConfigError when they regroup otherwise at its frame)."""
        if payload.unknown and (payload.frame or self.payload_frame) != \
                (self.basis.frame or self.payload_frame):
            other = payload_basis(self.base, payload.frame)
            if other.kinds != self.basis.kinds:
                raise ConfigError(
                    f"a payload known by its mass at {payload.frame} has identifiable parameters "
                    f"{list(other.kinds)}, not those at {self.basis.frame or self.payload_frame} "
                    f"({list(self.basis.kinds)}): give orthoglide.payload_frame as "
                    f"{self.basis.frame or self.payload_frame}, or its CoM and inertia")
        bound = self.base.with_payload(payload.known_part())
        return PayloadUnknownsModel(bound, self.basis, payload, self.columns)

    def keeping(self, columns: tuple[int, ...]):
        """The model with only these of its payload columns (indices into ``self.columns``);
        the base model itself when none is left."""
        if not columns:
            return self.base
        return PayloadUnknownsModel(self.base, self.basis, self.payload,
                                    tuple(self.columns[c] for c in columns))

    def at_frame(self, frame: str) -> PayloadUnknownsModel:
        """The same columns named and regrouped as at ``frame`` (a loaded payload's)."""
        if (frame or self.payload_frame) == (self.basis.frame or self.payload_frame):
            return self
        return PayloadUnknownsModel(self.base, payload_basis(self.base, frame), self.payload,
                                    self.columns)

    # what else the pipeline reads from a robot model
    def __getattr__(self, name: str):
        if name == "base":
            raise AttributeError(name)
        return getattr(self.base, name)


_BASES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()  # model -> its basis


def with_payload_unknowns(model):
    """``model`` with the columns of a payload known by its mass (at its payload frame), when
    any of its parameters other than the mass acts; else ``model`` unchanged. The basis is
    found once per model (a closed chain's random states take a while)."""
    if isinstance(model, PayloadUnknownsModel) or getattr(model, "payload_frame", None) is None:
        return model
    try:
        basis = _BASES.get(model, False)
    except TypeError:  # a model that cannot be weakly referenced: found each time
        basis = False
    if basis is False:
        probe = model.payload_standard_block(*model.random_states(2, STATES_SEED),
                                             model.payload_frame)
        basis = None if probe is None else payload_basis(model, "")
        try:
            _BASES[model] = basis
        except TypeError:
            pass
    return PayloadUnknownsModel(model, basis) if basis is not None and basis.n else model


def unknowns_of(model) -> PayloadUnknownsModel | None:
    """The PayloadUnknownsModel inside ``model`` (wrapped by the drive terms, or itself)."""
    while model is not None:
        if isinstance(model, PayloadUnknownsModel):
            return model
        model = model.__dict__.get("base") if hasattr(model, "__dict__") else None
    return None


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
