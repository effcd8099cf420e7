"""Physical consistency of standard parameters: pseudo-inertias, bounds, scales and the prior.

A body's 10 inertial parameters (``INERTIAL_KINDS``: inertia I at its frame origin, first
moments h = m c, mass m) are those of a real distribution of mass exactly when its
pseudo-inertia is positive semidefinite (Wensing, Kim & Slotine 2018):

    J = [[½ tr(I) 1 − I, h], [hᵀ, m]] ⪰ 0        (½ tr(I) 1 − I = ∫ x xᵀ dm)

which holds positive mass, a positive-definite inertia about the centre of mass and its
triangle inequalities at once. J is linear in the parameters, so "consistent" is a linear matrix
inequality (LMI). A joint's rotor inertia ia and its viscous and Coulomb friction fv, fs must be
≥ 0; its offset tauoff is free.

Every unknown is scaled to O(1) by its body's mass and length: m by m_ref, h by m_ref L_ref,
inertias by m_ref L_ref², where m_ref, L_ref are the prior's mass and radius of gyration about the
frame origin (√(tr Σ / m)) when it has them, 1 kg and 0.1 m otherwise; drive terms by
max(|prior|, 1) in SI units, or without a prior by the size of the base parameters they enter.
The LMIs are imposed on the scaled pseudo-inertia D J D / m_ref ⪰ ε 1 (D = diag(1/L_ref,
1/L_ref, 1/L_ref, 1), ε = MARGIN): a simulator gets a strictly positive mass and inertia even
for a body the data say nothing about. Each body's mass also lies within a bounding sphere
(``Layout.inequalities``) so that a nearly massless one keeps its centre of mass near it.

The prior (what the solution is pulled to where the data say nothing): given (all or some
standard parameters: CAD values, a previous answer), else the robot's own values when its model
has them (``standard_values()``: a URDF's inertials, damping and friction); where none is
given, a weak default: each body a solid sphere of radius 0.05 m
centred on its frame origin, carrying whatever mass the data give it (xx = yy = zz = 0.4 m R²,
every other inertial parameter 0), and no rotor inertia or friction.
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.identify.consistency.lmi import IDENTITY_SVEC, Block, svec
from orthoglide_ident.model.inertia import pseudo_inertia
from orthoglide_ident.model.robot import DRIVE_KINDS, INERTIAL_KINDS

NONNEGATIVE_KINDS = ("ia", "fv", "fs")  # tauoff is free
DEFAULT_MASS_KG = 1.0  # a body's scale when the prior has no mass for it
DEFAULT_LENGTH_M = 0.1
LENGTH_RANGE_M = (0.01, 1.0)  # radius of gyration taken from a prior, clipped
DEFAULT_SPHERE_M = 0.05  # weak default: a solid sphere of this radius at the frame origin
MARGIN = 1e-6  # scaled pseudo-inertias ⪰ MARGIN · 1
RELAXATION_TOL = 1e-4  # scaled units: a larger relaxation means "inconsistent" (solver noise ~1e-6)
AT_PRIOR_TOL = 1e-3  # scaled units: a parameter this close to its prior "stayed at the prior"
# every body's mass within max(1 m, 4 L_ref) of its frame origin: no link of a robot this product
# identifies is larger, and a body the data leave nearly massless keeps a sane centre of mass
BOUNDING_RADIUS_M = 1.0
BOUNDING_LENGTHS = 4.0
_I = {k: i for i, k in enumerate(INERTIAL_KINDS)}
_LENGTH_POWER = {"xx": 2, "xy": 2, "xz": 2, "yy": 2, "yz": 2, "zz": 2, "mx": 1, "my": 1, "mz": 1,
                 "m": 0}  # an inertial parameter's unit is kg·m^power


def drive_kind(name: str) -> str | None:
    """ia, fv, fs or tauoff for a joint's drive term (``fv_21``, ``ia_3``), None otherwise."""
    kind = name.split("_", 1)[0]
    return kind if kind in DRIVE_KINDS else None



@dataclass(frozen=True)
class Layout:
    """Where the physics sits in χ_st (``RobotModel.standard_names`` order) and how it is scaled.

    ``scale`` (n_st,) SI units per unknown; ``body_scale`` (n_bodies, 2): m_ref kg, L_ref m;
    the prior as rows ``B_s z − b_s`` in scaled unknowns z = χ / scale (one per standard
    parameter), ``prior`` its values at the solution's masses (weak default) or given."""

    names: tuple[str, ...]
    bodies: tuple  # model.robot.Body
    body_scale: np.ndarray
    nonneg: np.ndarray  # indices of ia, fv, fs
    scale: np.ndarray
    B_s: np.ndarray  # (n_st, n_st)
    b_s: np.ndarray
    prior_source: str  # "the robot's description", "given ...", "weak default"

    def prior_values(self, chi_st: np.ndarray) -> np.ndarray:
        """The prior's χ_st (the weak default's sphere inertia follows each body's mass)."""
        z = np.asarray(chi_st, float) / self.scale
        return self.scale * (z - (self.B_s @ z - self.b_s))

    def bounding_radius(self) -> np.ndarray:
        """(n_bodies,) m: each body's mass lies within this distance of its frame origin."""
        return np.maximum(BOUNDING_RADIUS_M, BOUNDING_LENGTHS * self.body_scale[:, 1])

    def inequalities(self) -> tuple[np.ndarray, list[str]]:
        """C (k, n_st) with C z ≥ 0 in scaled unknowns, and what each row says: ia, fv, fs ≥ 0,
        then per body ∫ (R² − |x|²) dm = m R² − ½ tr(I) ≥ 0 (bounding sphere of radius R,
        Wensing, Kim & Slotine 2018), scaled by m_ref L_ref²."""
        n = len(self.names)
        rows, what = [], []
        for i in self.nonneg:
            rows.append(np.eye(n)[i])
            what.append(f"{self.names[i]} >= 0")
        for body, (_m_ref, L_ref), R in zip(self.bodies, self.body_scale, self.bounding_radius()):
            r = np.zeros(n)
            r[body.inertial[_I["m"]]] = (R / L_ref) ** 2
            for k in ("xx", "yy", "zz"):
                r[body.inertial[_I[k]]] = -0.5
            rows.append(r)
            what.append(f"{body.name}: mass within {R:.3g} m of its frame origin")
        return np.array(rows).reshape(len(rows), n), what

    def lmi_blocks(self, margin: float = MARGIN) -> list[Block]:
        """svec(D J D / m_ref) − margin svec(1) = G z_body + h ⪰ 0, one block per body."""
        out = []
        for body, (m_ref, L_ref) in zip(self.bodies, self.body_scale):
            cols = np.asarray(body.inertial)
            D = np.diag([1.0 / L_ref] * 3 + [1.0])
            G = np.column_stack([svec(D @ pseudo_inertia(e) @ D) / m_ref
                                 for e in np.diag(self.scale[cols])])
            out.append(Block(cols, G, -margin * IDENTITY_SVEC))
        return out


def _body_scale(chi10: np.ndarray) -> tuple[float, float]:
    """(m_ref kg, L_ref m) of a body from its prior's parameters (NaN where not given)."""
    m = chi10[9]
    if not (np.isfinite(m) and m > 0):
        return DEFAULT_MASS_KG, DEFAULT_LENGTH_M
    if not np.all(np.isfinite(chi10)):
        return float(m), DEFAULT_LENGTH_M
    L = np.sqrt(max(np.trace(pseudo_inertia(chi10)[:3, :3]), 0.0) / m)
    return float(m), float(np.clip(L, *LENGTH_RANGE_M))


def prior_vector(robot, prior: Mapping[str, float] | np.ndarray | None) -> tuple[np.ndarray, str]:
    """(n_st,) prior values, NaN where none is given, and where they come from: ``prior`` (χ_st
    or a mapping name -> value, some names only), else the robot's ``standard_values()`` (its
    description), else nothing (the weak default everywhere)."""
    names = list(robot.standard_names)
    if prior is None and (values := robot.standard_values()) is not None:
        return np.asarray(values, float), "the robot's description"
    if prior is None:
        return np.full(len(names), np.nan), "weak default"
    if isinstance(prior, Mapping):
        unknown = sorted(set(prior) - set(names))
        if unknown:
            raise ConfigError(f"consistency prior: {unknown[:5]} are not standard parameters of "
                              f"{robot.name} (e.g. {', '.join(names[:3])})")
        vec = np.array([float(prior.get(n, np.nan)) for n in names])
        return vec, f"given for {len(prior)} of {len(names)} standard parameters"
    return np.asarray(prior, float), "given"


def _drive_scale(robot, chi_b: np.ndarray | None) -> np.ndarray:
    """(n_st,) a magnitude for each drive term without a prior: max(1, |χ̂_b| / |K_bi|) over the
    base parameters b it enters (those it alone would have to make up), 1 without an answer."""
    K = np.abs(np.asarray(robot.K, float))
    if chi_b is None:
        return np.ones(K.shape[1])
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(K > 1e-3, np.abs(np.asarray(chi_b, float))[:, None] / K, 0.0)
    return np.maximum(ratio.max(axis=0), 1.0)


def layout(robot, prior: Mapping[str, float] | np.ndarray | None = None,
           chi_b: np.ndarray | None = None) -> Layout:
    """The layout of ``robot`` (a RobotModel): its bodies, bounds, scales and prior
    (:func:`prior_vector`; the weak default of the module docstring where none is given). The
    base answer ``chi_b`` sets the scale of the drive terms the prior says nothing about, so
    that the weak default's zero friction does not pull an 85 N·s/m viscous friction known to
    2 % by a measurable fraction of its σ."""
    names = tuple(robot.standard_names)
    n = len(names)
    values, source = prior_vector(robot, prior)
    given = np.isfinite(values)
    scale = np.ones(n)
    body_scale = []
    for body in robot.bodies:
        cols = np.asarray(body.inertial)
        m_ref, L_ref = _body_scale(values[cols])
        scale[cols] = [m_ref * L_ref ** _LENGTH_POWER[k] for k in INERTIAL_KINDS]
        body_scale.append((m_ref, L_ref))
    drive = np.array([i for i, nm in enumerate(names) if drive_kind(nm)], int)
    scale[drive] = np.maximum(np.where(given[drive], np.abs(values[drive]),
                                       _drive_scale(robot, chi_b)[drive]), 1.0)
    B_s, b_s = np.eye(n), np.where(given, values, 0.0) / scale
    for body, (_m_ref, L_ref) in zip(robot.bodies, body_scale):  # weak default: xx − 0.4 R² m...
        for k in ("xx", "yy", "zz"):
            if not given[body.inertial[_I[k]]]:
                B_s[body.inertial[_I[k]], body.inertial[_I["m"]]] = -0.4 * (
                    DEFAULT_SPHERE_M / L_ref) ** 2
    nonneg = np.array([i for i in drive if drive_kind(names[i]) in NONNEGATIVE_KINDS], int)
    return Layout(names, tuple(robot.bodies), np.array(body_scale, float), nonneg, scale, B_s,
                  b_s, source)


def _chi10_of(J: np.ndarray) -> np.ndarray:
    """The 10 parameters of a pseudo-inertia: I = tr(Σ) 1 − Σ, h, m (inverse of pseudo_inertia)."""
    S = J[:3, :3]
    I_o = np.trace(S) * np.eye(3) - S
    return np.array([I_o[0, 0], I_o[0, 1], I_o[0, 2], I_o[1, 1], I_o[1, 2], I_o[2, 2],
                     *J[:3, 3], J[3, 3]])


def clean(lay: Layout, chi_st: np.ndarray, margin: float = MARGIN) -> np.ndarray:
    """χ_st with every scaled pseudo-inertia's eigenvalues raised to ``margin`` and the bounded
    drive terms to 0: an interior-point answer meets its constraints to the solver's tolerance
    (~1e-6 of the scales on badly scaled data), a simulator needs them exactly; the change is
    of that tolerance."""
    out = np.array(chi_st, float)
    for body, (m_ref, L_ref) in zip(lay.bodies, lay.body_scale):
        idx = list(body.inertial)
        d = np.array([1.0 / L_ref] * 3 + [1.0])
        S = (d[:, None] * pseudo_inertia(out[idx]) * d[None, :]) / m_ref
        lam, V = np.linalg.eigh(0.5 * (S + S.T))
        if lam[0] < margin:
            S = (V * np.maximum(lam, margin)) @ V.T
            out[idx] = _chi10_of(S * m_ref / (d[:, None] * d[None, :]))
    out[lay.nonneg] = np.maximum(out[lay.nonneg], 0.0)
    return out


def min_eigenvalues(lay: Layout, chi_st: np.ndarray) -> np.ndarray:
    """Smallest eigenvalue of each body's scaled pseudo-inertia D J D / m_ref (dimensionless)."""
    out = []
    for body, (m_ref, L_ref) in zip(lay.bodies, lay.body_scale):
        D = np.diag([1.0 / L_ref] * 3 + [1.0])
        out.append(np.linalg.eigvalsh(D @ pseudo_inertia(chi_st[list(body.inertial)]) @ D
                                      / m_ref)[0])
    return np.array(out)
