"""Symmetric base parameters by QR factorisation (paper Sect. 3.1, eqs. 21-23).

The standard observation matrix is built on random regular states and its columns ordered as
eq. (23): platform first, then each leg parameter with the columns of the three legs side by side.
A column whose |R_kk| falls below eps * max|R_jj| (eq. 22) depends on the columns before it and is
regrouped into them: W_D = W_B beta, so W_st chi_st = W_B (chi_B + beta chi_D) and every base
parameter carries the expression chi_b = chi_B + sum beta chi_D it stands for.
"""
from __future__ import annotations

import functools
import json
import re

import numpy as np

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.model.base_parameters import (
    COEF_TOL,
    QR_EPS,
    BaseParameter,
    NamedByParameters,
)
from orthoglide_ident.model.orthoglide.geometry import (
    G_TAU_MANUFACTURER,
    JOINT_NAMES,
    PAPER,
    A,
    Geometry,
)
from orthoglide_ident.model.orthoglide.idim import (
    observation_block,
    observation_columns,
    standard_regressor,
)
from orthoglide_ident.model.orthoglide.kinematics import igm
from orthoglide_ident.model.orthoglide.parameters import (
    INERTIAL,
    N_BODIES,
    N_LEGS,
    N_ST,
    N_ST_LEG,
    PLATFORM_COLUMNS,
    STANDARD_NAMES,
    leg_column,
    leg_name,
)
from orthoglide_ident.model.robot import ActuatedJoint, Body, Payload, RobotModel


def eq23_order() -> list[int]:
    """Standard-parameter columns in the order of eq. (23): W_p, then W_chi_k for legs 1..n."""
    return list(PLATFORM_COLUMNS) + [
        leg_column(leg, k) for k in range(N_ST_LEG) for leg in range(1, N_LEGS + 1)
    ]


def random_states(n: int, seed: int = 0, half_width: float | None = None,
                  geom: Geometry = PAPER):
    """n regular states: platform uniform in a cube around the isotropic point (0, 0, a), half
    width 0.1 m for the paper's a = 0.34 m (scaled with a), random qd, qdd."""
    rng = np.random.default_rng(seed)
    if half_width is None:
        half_width = 0.1 if geom.a == A else 0.1 * geom.a / A
    q = igm(np.array([0.0, 0.0, geom.a]) + rng.uniform(-half_width, half_width, (n, 3)), geom)
    return q, rng.normal(0.0, 1.0, (n, 3)), rng.normal(0.0, 10.0, (n, 3))


def _leg_of(name: str) -> int | None:
    m = re.fullmatch(r"[a-z]+_(\d)(\d)", name)
    return int(m.group(2)) if m else None


def _generic(name: str) -> str:
    """'mx_31' -> 'mx_3i' (platform and payload names unchanged)."""
    m = re.fullmatch(r"([a-z]+)_(\d)(\d)", name)
    return f"{m.group(1)}_{m.group(2)}i" if m else name



PAYLOAD_FRAME = "platform"  # the payload (body 7) is fixed to the translating platform (body 6)


def orthoglide_joints(nominal_gains: tuple[float, float, float] | None = None
                      ) -> tuple[ActuatedJoint, ...]:
    """q11, q12, q13: prismatic, the manufacturer's 637π N/A (Sect. 5.2) unless given."""
    gains = (G_TAU_MANUFACTURER,) * 3 if nominal_gains is None else tuple(nominal_gains)
    return tuple(ActuatedJoint(name, "prismatic", float(g)) for name, g in zip(JOINT_NAMES, gains))


def orthoglide_bodies() -> tuple[Body, ...]:
    """Leg bodies 1..5 of legs 1..3 (MDH frames j_i), then the platform (frame at P)."""
    index = {n: k for k, n in enumerate(STANDARD_NAMES)}
    legs = tuple(Body(f"body {j} of leg {i}", tuple(index[leg_name(k, j, i)] for k in INERTIAL),
                      f"{j}_{i}")
                 for i in range(1, N_LEGS + 1) for j in range(1, N_BODIES + 1))
    return legs + (Body("platform", tuple(PLATFORM_COLUMNS), PAYLOAD_FRAME),)


class BaseModel(NamedByParameters, RobotModel):
    """The Orthoglide's base-parameter IDIM in closed form: W (3 N, n_b) with tau = W chi_b,
    chi_b = K chi_st (eq. 21); the robot model the product uses without ``--robot``."""

    name = "orthoglide"
    payload_frame = PAYLOAD_FRAME
    standard_names = STANDARD_NAMES

    def __init__(self, n_states: int = 600, seed: int = 0, geometry: Geometry = PAPER,
                 nominal_gains: tuple[float, float, float] | None = None):
        self.geometry = geometry
        self.joints = orthoglide_joints(nominal_gains)
        self.bodies = orthoglide_bodies()
        order = eq23_order()
        q, qd, qdd = random_states(n_states, seed, geom=geometry)
        W_r = observation_columns(q, qd, qdd, order, geom=geometry)
        R = np.linalg.qr(W_r, mode="r")  # eq. (22)
        d = np.abs(np.diag(R))
        keep = d > QR_EPS * d.max()
        kept = [order[j] for j in np.flatnonzero(keep)]
        dropped = [order[j] for j in np.flatnonzero(~keep)]
        W_B = W_r[:, keep]
        W_D = W_r[:, ~keep]
        beta = np.linalg.lstsq(W_B, W_D, rcond=None)[0]  # W_D = W_B beta
        beta[np.abs(beta) < COEF_TOL] = 0.0
        self.columns: list[int] = kept
        self.K = np.zeros((len(kept), N_ST))
        self.K[np.arange(len(kept)), kept] = 1.0
        self.K[:, dropped] = beta
        terms = []
        for b, col in enumerate(kept):
            t = [(STANDARD_NAMES[col], 1.0)]
            t += [
                (STANDARD_NAMES[c], float(beta[b, n]))
                for n, c in enumerate(dropped)
                if beta[b, n] != 0.0
            ]
            terms.append(tuple(t))
        self.parameters = [
            BaseParameter(
                name=STANDARD_NAMES[col] + ("R" if len(t) > 1 else ""),
                standard=STANDARD_NAMES[col],
                terms=t,
                legs=self._shared_legs(col, t, kept, terms),
            )
            for col, t in zip(kept, terms)
        ]
        self.rank_gap = (
            float(d[keep].min() / max(d[~keep].max(), 1e-300)) if (~keep).any() else np.inf
        )

    # --- what callers asked by type before: the closed tree's URDF, labels, forward model ----
    @property
    def gravity(self) -> tuple[float, float, float]:
        """m/s², along +y0 (Sect. 5.1): the robot file's g."""
        return tuple(float(x) for x in self.geometry.gravity)

    def identified_urdf(self, chi_st: np.ndarray, gains) -> str:
        """The URDF of the open tree (urdf.py); the loops are closed by forward_model."""
        from orthoglide_ident.model.orthoglide.urdf import orthoglide_urdf

        return orthoglide_urdf(self, chi_st, gains)

    def joint_labels(self, urdf_text: str) -> dict[str, str]:
        from orthoglide_ident.model.orthoglide.urdf import joint_labels

        return joint_labels()

    def forward_model(self, chi_st: np.ndarray, gains, payload: Payload | None):
        """The open tree closed by two welds, Pinocchio's constraint dynamics (forward.py)."""
        from orthoglide_ident.model.orthoglide.forward import orthoglide_forward

        return orthoglide_forward(self, chi_st, gains, payload)

    @staticmethod
    def _shared_legs(col, t, kept, terms) -> tuple[int, ...]:
        leg = _leg_of(STANDARD_NAMES[col])
        if leg is None:
            return ()

        def form(tt):
            return tuple(sorted((_generic(n), round(c, 6)) for n, c in tt))

        mine = form(t)
        generic = _generic(STANDARD_NAMES[col])
        return tuple(
            _leg_of(STANDARD_NAMES[c])
            for c, tt in zip(kept, terms)
            if _generic(STANDARD_NAMES[c]) == generic and form(tt) == mine
        )

    # --- what identification uses (names, expressions: NamedByParameters) -------------
    @property
    def legs(self) -> list[tuple[int, ...]]:
        return [p.legs for p in self.parameters]

    def observation(
        self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """(W (3 N, n_b), W_kl (3 N,)) in one pass: base columns and the payload-mass column m_7."""
        X = observation_columns(q, qd, qdd, self.columns, with_payload_mass=True,
                                geom=self.geometry)
        return X[:, :-1], X[:, -1]

    def observation_block(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray,
                          out: np.ndarray | None = None) -> np.ndarray:
        """[W | W_kl] as (n_b + 1, 3, N): column, joint, sample (written into ``out`` if given)."""
        return observation_block(q, qd, qdd, self.columns, with_payload_mass=True, out=out,
                                 geom=self.geometry)

    def regressor(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        """W (3 N, n_b), rows stacked joint by joint (eq. 20)."""
        return observation_columns(q, qd, qdd, self.columns, geom=self.geometry)

    def payload_mass_column(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        """W_kl (3 N,): efforts per kg of payload (eq. 29); the other 9 payload parameters have no
        effect."""
        return observation_columns(q, qd, qdd, [], with_payload_mass=True,
                                   geom=self.geometry)[:, 0]

    def with_payload(self, payload: Payload) -> BaseModel:
        """The platform only translates, so a payload's only effect is its mass: the same model
        (its column is per kg); ConfigError for a payload fixed elsewhere than the platform."""
        if payload.frame not in ("", PAYLOAD_FRAME):
            raise ConfigError(f"the Orthoglide carries its payload on the {PAYLOAD_FRAME}, not on "
                              f"{payload.frame!r}")
        return self

    def standard_regressor(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        """W_st (3 N, 208), rows joint by joint (eq. 20)."""
        return standard_regressor(q, qd, qdd, self.geometry)[0]

    def random_states(self, n: int, seed: int = 0):
        return random_states(n, seed, geom=self.geometry)

    # --- what people read --------------------------------------------------------------------
    def table(self) -> str:
        w = max(len(n) for n in self.names)
        lines = [
            f"{self.n_b} base parameters of the Orthoglide IDIM (of {N_ST} standard; eq. 23 column "
            "order, "
            f"QR threshold {QR_EPS:g})",
            f"{'#':>3}  {'name':<{w}}  {'legs':<7}  expression",
        ]
        for k, p in enumerate(self.parameters, 1):
            legs = ",".join(map(str, p.legs)) if p.legs else "-"
            lines.append(f"{k:>3}  {p.name:<{w}}  {legs:<7}  {p.expression}")
        g = self.geometry
        lines.append(f"Joints: {', '.join(JOINT_NAMES)}. Geometry a = {g.a:g}, d4 = {g.d4:g}, "
                     f"d6 = {g.d6:g} m. Regrouping coefficients: 1/d4 = {1 / g.d4:.5g}, "
                     f"1/g = {1 / g.g0:.5g}.")
        return "\n".join(lines)

    def to_json(self) -> dict:
        return {
            "n_standard": N_ST,
            "n_base": self.n_b,
            "column_order": "eq. (23): platform, then each leg parameter for legs 1..3",
            "parameters": [
                {
                    "name": p.name,
                    "standard": p.standard,
                    "expression": p.expression,
                    "terms": [{"name": n, "coefficient": c} for n, c in p.terms],
                    "legs": list(p.legs),
                }
                for p in self.parameters
            ],
        }

    def dumps(self) -> str:
        # strict JSON (RFC 8259): the structure's coefficients are finite, a NaN is a bug
        return json.dumps(self.to_json(), indent=2, allow_nan=False)


@functools.lru_cache(maxsize=4)
def base_model(geometry: Geometry = PAPER,
               nominal_gains: tuple[float, float, float] | None = None) -> BaseModel:
    """The Orthoglide base model of that geometry (computed once per process, ~0.2 s)."""
    return BaseModel(geometry=geometry, nominal_gains=nominal_gains)
