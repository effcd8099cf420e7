"""The identified payload of a loaded record known by its mass (paper Sect. 4.3), for people.

χ_ul (payload_unknowns.py) is solved among the base parameters; here it leaves the robot's
parameter list for the result's ``payload`` entry: each identified combination with its σ, and
where the combinations are single parameters, the centre of mass c = h / m (h = mx, my, mz) and
the inertia about it I_c = I_o − (‖h‖² 1 − h hᵀ) / m, with σ propagated to first order from the
covariance of [χ_ul, m] (m: the weighed mass and its σ for TLS, the estimated one for WLS).
"""
from __future__ import annotations

import numpy as np

from orthoglide_ident.identify.columns.layout import ColumnLayout
from orthoglide_ident.results import IdentificationResult, PayloadParameters

FIRST_MOMENTS = ("mx", "my", "mz")
INERTIA = ("xx", "xy", "xz", "yy", "yz", "zz")


def split_payload(result: IdentificationResult, layout: ColumnLayout) -> None:
    """Move χ_ul (``layout.payload_slice``) out of ``result.parameters`` into ``result.payload``
    (and its essential one)."""
    if result.essential is not None:
        split_payload(result.essential, layout)
    if not layout.payload_names:
        return
    names = list(layout.payload_names)
    at = {p.name: i for i, p in enumerate(result.parameters)}
    idx = [at[n] for n in names if n in at]
    if not idx or result.payload_mass is None:
        result.parameters = [p for p in result.parameters if p.name not in names]
        return
    value, C = _values_and_cov(result, idx)
    basis = layout.basis
    kinds = {basis.kinds[c]: k for k, c in enumerate(layout.payload_columns)
             if names[k] in at and _alone(basis.K, c)}
    pos = {name: i for i, name in enumerate(n for n in names if n in at)}
    kinds = {kind: pos[names[k]] for kind, k in kinds.items()}
    known = "mass" if any(basis.kinds[c] in FIRST_MOMENTS for c in layout.payload_columns) \
        else "com"
    com, com_std, inertia, inertia_std = _com_and_inertia(value, C, kinds, known)
    result.payload = PayloadParameters(
        frame=basis.frame or layout.payload_frame, mass=float(value[-1]), known=known,
        parameters=[result.parameters[i] for i in idx],
        std=[float(np.sqrt(max(C[i, i], 0.0))) for i in range(len(idx))],
        com=com, com_std=com_std, inertia=inertia, inertia_std=inertia_std)
    result.parameters = [p for p in result.parameters if p.name not in names]


def _alone(K: np.ndarray, c: int) -> bool:
    """Whether payload column c is one parameter, not a regrouping of several (a row of the
    basis' K)."""
    row = K[c]
    return int(np.count_nonzero(row)) == 1


def _values_and_cov(result: IdentificationResult, idx: list[int]) -> tuple[np.ndarray, np.ndarray]:
    """[χ_ul (those in ``idx``), m] and their covariance: the weighed mass's σ for TLS (known,
    independent), the estimated mass's row of the WLS covariance."""
    n_par = len(result.parameters)
    pm = result.payload_mass
    value = np.array([result.parameters[i].value for i in idx] + [pm.value])
    cov = result.covariance
    if cov is None:
        std = [abs(result.parameters[i].value) * result.parameters[i].rel_std for i in idx]
        return value, np.diag(np.r_[np.square(std), (pm.rel_std * pm.value) ** 2])
    cov = np.asarray(cov)
    if pm.known:
        C = np.zeros((len(idx) + 1, len(idx) + 1))
        C[:-1, :-1] = cov[np.ix_(idx, idx)]
        C[-1, -1] = (pm.rel_std * pm.value) ** 2
        return value, C
    sel = idx + [n_par]  # WLS: the first payload group's mass follows the parameters
    return value, cov[np.ix_(sel, sel)]


def _com_and_inertia(value: np.ndarray, C: np.ndarray, kinds: dict[str, int], known: str):
    """c = h / m per determined first moment; I_c when h and I_o are all single parameters (mass
    known) or I_c itself (CoM known); σ by first-order propagation (numerical Jacobian)."""
    m_i = len(value) - 1
    com: list[float | None] = [None] * 3
    com_std: list[float | None] = [None] * 3
    if known == "mass":
        for a, k in enumerate(FIRST_MOMENTS):
            if k in kinds:
                f = lambda v, i=kinds[k]: np.array([v[i] / v[m_i]])  # noqa: E731
                val, sd = _propagate(f, value, C)
                com[a], com_std[a] = float(val[0]), float(sd[0])
    if not all(k in kinds for k in INERTIA) or (known == "mass" and None in com):
        return com, com_std, None, None
    ii = [kinds[k] for k in INERTIA]
    if known == "com":
        sd = np.sqrt(np.maximum(np.diag(C)[ii], 0.0))
        return com, com_std, [float(value[i]) for i in ii], [float(x) for x in sd]
    hi = [kinds[k] for k in FIRST_MOMENTS]

    def inertia_about_com(v: np.ndarray) -> np.ndarray:
        h, m = v[hi], v[m_i]
        xx, xy, xz, yy, yz, zz = v[ii]
        I_c = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]]) \
            - ((h @ h) * np.eye(3) - np.outer(h, h)) / m
        return I_c[[0, 0, 0, 1, 1, 2], [0, 1, 2, 1, 2, 2]]

    val, sd = _propagate(inertia_about_com, value, C)
    return com, com_std, [float(x) for x in val], [float(x) for x in sd]


def _propagate(f, x: np.ndarray, C: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """f(x) and the σ of each output: sqrt(diag(J C Jᵀ)), J by central differences."""
    y = f(x)
    J = np.empty((y.shape[0], x.shape[0]))
    for k in range(x.shape[0]):
        h = 1e-6 * max(abs(x[k]), 1e-6)
        e = np.zeros_like(x)
        e[k] = h
        J[:, k] = (f(x + e) - f(x - e)) / (2 * h)
    return y, np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", J, C, J), 0.0))
