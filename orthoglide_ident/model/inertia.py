"""A body's 10 inertial parameters (``INERTIAL_KINDS`` order: inertia at the frame origin, first
moments, mass) and the forms other code wants them in: the inertia matrix, the pseudo-inertia,
mass, centre of mass and inertia about it (URDF's ``<inertial>``), and back.
"""
from __future__ import annotations

import numpy as np

__all__ = ["at_com", "from_com", "inertia_matrix", "pseudo_inertia"]


def inertia_matrix(chi10: np.ndarray) -> np.ndarray:
    """(3, 3) inertia at the frame origin from the 10 parameters (INERTIAL_KINDS order)."""
    xx, xy, xz, yy, yz, zz = chi10[:6]
    return np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])


def pseudo_inertia(chi10: np.ndarray) -> np.ndarray:
    """J = [[½ tr(I) 1 − I, h], [hᵀ, m]] (4, 4): kg·m², kg·m, kg."""
    chi10 = np.asarray(chi10, float)
    I_o = inertia_matrix(chi10)
    J = np.empty((4, 4))
    J[:3, :3] = 0.5 * np.trace(I_o) * np.eye(3) - I_o
    J[:3, 3] = J[3, :3] = chi10[6:9]
    J[3, 3] = chi10[9]
    return J


def at_com(chi10: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """(mass kg, centre of mass (3,) m, inertia about it [Ixx, Ixy, Ixz, Iyy, Iyz, Izz] kg·m²),
    axes of the body frame (parallel axis theorem); a massless body has its com at the origin."""
    chi10 = np.asarray(chi10, float)
    m = float(chi10[9])
    c = chi10[6:9] / m if m > 0 else np.zeros(3)
    I_c = inertia_matrix(chi10) - m * ((c @ c) * np.eye(3) - np.outer(c, c))
    return m, c, I_c[[0, 0, 0, 1, 1, 2], [0, 1, 2, 1, 2, 2]]


def from_com(mass: float, com: np.ndarray, inertia: np.ndarray) -> np.ndarray:
    """The 10 parameters at the frame origin of a body given at its centre of mass."""
    c = np.asarray(com, float)
    xx, xy, xz, yy, yz, zz = inertia
    I_o = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]]) + mass * (
        (c @ c) * np.eye(3) - np.outer(c, c))
    return np.array([I_o[0, 0], I_o[0, 1], I_o[0, 2], I_o[1, 1], I_o[1, 2], I_o[2, 2],
                     *(mass * c), mass])
