"""Orthoglide geometry (paper Sect. 5.1, Tables 1-2, eq. 41) and physical constants.

Each leg i is described in its own *leg frame*, the MDH frame of its foot (frame 1_i): its axes are
a
cyclic permutation of the base axes, so the three legs have identical equations in leg coordinates
and differ only by the rotation ``R_LEG[i]``, the foot offset ``FOOT_OFFSET[i]`` and the gravity
direction. See docs/design/conventions.md.

The dimensions are a value (:class:`Geometry`, from the robot file's ``geometry``: a, d4, d6 and
g); ``PAPER`` is the paper's prototype, whose numbers the module constants below name.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.model.robot import G0

A = 0.34  # m, Fig. 3(b)
D4 = 0.31  # m, length of the equivalent parallelogram bar
D6 = 0.03  # m, offset of the bar end C_i from the platform point P along the actuator axis
GRAVITY = np.array([0.0, G0, 0.0])  # acceleration vector, "directed along y0" (Sect. 5.1)

JOINT_NAMES = ("q11", "q12", "q13")
G_TAU_MANUFACTURER = 637.0 * np.pi  # N/A, "637 pi ~ 2001" (Sect. 5.2)

# Columns = (x_1i, y_1i, z_1i) in base coordinates: Table 1 with gamma, b, alpha, theta.
R_LEG = np.array(
    [
        np.eye(3),
        [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],  # x = y0, y = z0, z = x0
        [[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]],  # x = z0, y = x0, z = y0
    ]
)
# Actuator axis e_i in base coordinates (= z_1i).
E_AXIS = R_LEG[:, :, 2].copy()

# Origin of frame 1_i in leg coordinates is FOOT_OFFSET[i] + q1i * z.  Table 1 gives
# r = q11, q12 - a, q13 - a (the paper prints q13 + a: a misprint, f_p of eq. 41 needs q13 - a).
FOOT_OFFSET = np.array([[0.0, 0.0, 0.0], [0.0, A, -A], [A, 0.0, -A]])

# Gravity acceleration in each leg frame: leg 1 (0, g, 0), leg 2 (g, 0, 0), leg 3 (0, 0, g).
GRAVITY_LEG = np.einsum("iab,a->ib", R_LEG, GRAVITY)

# Thresholds for the singularity checks (dimensionless, see kinematics.check_regular).
SERIAL_MARGIN = 0.05  # |u_i . e_i| / d4: bar too close to perpendicular to its actuator
PARALLEL_MARGIN = 0.05  # |det(u_1, u_2, u_3)| / d4³: the three bars close to coplanar


@dataclass(frozen=True)
class Geometry:
    """An Orthoglide's dimensions (m) and gravity (m/s², along y0): the paper's by default."""

    a: float = A
    d4: float = D4
    d6: float = D6
    g0: float = G0
    foot_offset: np.ndarray = field(init=False, repr=False, compare=False)
    gravity: np.ndarray = field(init=False, repr=False, compare=False)
    gravity_leg: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if not (0 < self.d6 < self.d4 and 0 < self.a and self.g0 >= 0):
            raise ConfigError(
                f"Orthoglide geometry a = {self.a}, d4 = {self.d4}, d6 = {self.d6} m, "
                f"g = {self.g0} m/s²: needs a > 0, 0 < d6 < d4 and g >= 0"
            )
        a = self.a
        gravity = np.array([0.0, self.g0, 0.0])
        object.__setattr__(self, "foot_offset", np.array([[0.0, 0.0, 0.0], [0.0, a, -a],
                                                          [a, 0.0, -a]]))
        object.__setattr__(self, "gravity", gravity)
        object.__setattr__(self, "gravity_leg", np.einsum("iab,a->ib", R_LEG, gravity))

    def __hash__(self) -> int:
        return hash((self.a, self.d4, self.d6, self.g0))


PAPER = Geometry()  # the prototype of the paper, Sect. 5.1
