"""The robot as a value: what identification, control, the nodes and the CLI take from a model.

Every size and name the product uses comes from a :class:`RobotModel`, as Pinocchio code takes
its sizes from ``model.nv``: the actuated joints (names, kinds, units, the manufacturer's drive
gains), the standard parameters per body, the base parameters with their regrouping expressions
(eq. 21: chi_b = K chi_st), and the IDIM rows of the actuated joints for samples (q, q̇, q̈)
(eqs. 15, 18, 20), with the known payload's column (eq. 33) last.

Two implementations:

- the Orthoglide's closed form (``model/orthoglide/base.py``: the paper's virtual tree closed by
  J_t = J_k⁻¹ J_tk J_p and its 61 symmetric base parameters);
- the general model on Pinocchio (``model/pinocchio_model.py``): a URDF or MJCF tree, closed
  chains by loop constraints, base parameters by pivoted QR on random states.

Layouts (docs/design/architecture.md): samples ``q, qd, qdd: (m, n)`` with n = ``n_joints`` columns
in
``joint_names`` order; ``observation_block`` is ``(n_b + 1, n, m)`` — column, joint, sample, each
column of each joint contiguous in time (what the parallel decimation filters); ``regressor`` is
``(n m, n_b)`` with rows stacked joint by joint (eq. 20). SI units: m or rad, N or N·m, A,
N/A or N·m/A (a joint's ``kind`` says which).
"""
from __future__ import annotations

import abc
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from orthoglide_ident.errors import ConfigError

# The 10 inertial parameters of a body in the product's order (paper Sect. 2.2): inertia at the
# origin of the body's frame, first moments in that frame, mass.
INERTIAL_KINDS = ("xx", "xy", "xz", "yy", "yz", "zz", "mx", "my", "mz", "m")
# Drive and friction terms of a joint: rotor inertia (actuated joints), viscous, Coulomb, offset.
DRIVE_KINDS = ("ia", "fv", "fs", "tauoff")
# What is known of a loaded record's payload (paper Sect. 4.3): its mass only (first moments and
# inertia identified), mass and centre of mass (inertia identified), all ten parameters, or a
# point mass (no inertia about its centre of mass) because the user says so.
PAYLOAD_KNOWLEDGE = ("mass", "com", "all", "point")
# The payload parameters that stay unknown, per knowledge: χ_ul of eq. (29)
PAYLOAD_UNKNOWN = {"mass": ("mx", "my", "mz", "xx", "xy", "xz", "yy", "yz", "zz"),
                   "com": ("xx", "xy", "xz", "yy", "yz", "zz"), "all": (), "point": ()}
JOINT_KINDS = ("prismatic", "revolute")
G0 = 9.80665  # m/s², standard gravity
DEFAULT_GRAVITY = (0.0, 0.0, -G0)  # z up, as URDF and MJCF robots are described


@dataclass(frozen=True)
class ActuatedJoint:
    """One actuated joint: name, kind, the manufacturer's drive gain and its limits."""

    name: str
    kind: str  # "prismatic" | "revolute"
    nominal_gain: float  # N/A (prismatic) or N·m/A (revolute): the manufacturer's g_tau
    lower: float = -math.inf  # position limits, m or rad
    upper: float = math.inf
    velocity_limit: float = math.inf  # m/s or rad/s

    def __post_init__(self) -> None:
        if self.kind not in JOINT_KINDS:
            raise ConfigError(f"joint {self.name}: kind {self.kind!r} is not prismatic or revolute")
        if not (math.isfinite(self.nominal_gain) and self.nominal_gain > 0):
            raise ConfigError(
                f"joint {self.name}: nominal drive gain {self.nominal_gain!r} must be "
                "a positive number"
            )

    @property
    def unit(self) -> str:
        """Position unit: m or rad."""
        return "m" if self.kind == "prismatic" else "rad"

    @property
    def effort_unit(self) -> str:
        return "N" if self.kind == "prismatic" else "N·m"

    @property
    def gain_unit(self) -> str:
        return f"{self.effort_unit}/A"


@dataclass(frozen=True)
class Body:
    """A body's standard inertial parameters: where its 10 (``INERTIAL_KINDS`` order) sit in
    ``RobotModel.standard_names``, and the frame they are expressed in (a link or a frame name)."""

    name: str
    inertial: tuple[int, ...]  # 10 indices into standard_names
    frame: str = ""


@dataclass(frozen=True)
class Payload:
    """The payload of a loaded record: mass, centre of mass and inertia fixed to a frame, and
    which of them are ``known`` (PAYLOAD_KNOWLEDGE, paper Sect. 4.3).

    ``com`` (m) in ``frame``; ``inertia`` (Ixx, Ixy, Ixz, Iyy, Iyz, Izz, kg·m²) about the centre
    of mass, axes of ``frame``. ``frame`` "" is the model's ``payload_frame``. ``known``: "all"
    (the ten parameters as given), "point" (a point mass at ``com``), "com" (mass and centre of
    mass; the inertia is identified) or "mass" (the first moments and inertia are identified;
    ``com`` and ``inertia`` are then not used). The Orthoglide's platform only translates, so
    only the mass acts whatever is known.
    """

    mass: float
    frame: str = ""
    com: tuple[float, float, float] = (0.0, 0.0, 0.0)
    inertia: tuple[float, float, float, float, float, float] = (0.0,) * 6
    known: str = "all"

    def __post_init__(self) -> None:
        if self.known not in PAYLOAD_KNOWLEDGE:
            raise ConfigError(f"payload knowledge {self.known!r} is not one of "
                              f"{', '.join(PAYLOAD_KNOWLEDGE)}")
        vals = (self.mass, *self.com, *self.inertia)
        if len(self.com) != 3 or len(self.inertia) != 6 or not all(map(math.isfinite, vals)):
            raise ConfigError(f"payload: com needs 3 and inertia 6 finite numbers, got "
                              f"com {self.com}, inertia {self.inertia}")
        if self.mass < 0:
            raise ConfigError(f"payload mass {self.mass:g} kg is negative")

    @property
    def is_point_mass(self) -> bool:
        return not any(self.com) and not any(self.inertia)

    @property
    def unknown(self) -> tuple[str, ...]:
        """The inertial kinds identified with the robot's parameters (χ_ul of eq. 29)."""
        return PAYLOAD_UNKNOWN[self.known]

    def known_part(self) -> Payload:
        """The payload whose ten parameters are the known ones (W_kl of eq. 33 per kg): a point
        mass at the frame origin (mass known), at the centre of mass (com, point), or all."""
        if self.known == "all":
            return self
        com = (0.0, 0.0, 0.0) if self.known == "mass" else self.com
        return Payload(self.mass, self.frame, com)

    def shape(self) -> np.ndarray:
        """(10,) inertial parameters per kg of mass at the frame origin, ``INERTIAL_KINDS`` order:
        mass 1, first moments c, inertia (I_c + m S(c)ᵀ S(c)) / m (parallel axis theorem)."""
        c = np.asarray(self.com, float)
        xx, xy, xz, yy, yz, zz = self.inertia
        I_c = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
        m = self.mass if self.mass > 0 else 1.0
        I_o = I_c / m + (c @ c) * np.eye(3) - np.outer(c, c)
        return np.array([I_o[0, 0], I_o[0, 1], I_o[0, 2], I_o[1, 1], I_o[1, 2], I_o[2, 2],
                         c[0], c[1], c[2], 1.0])


class RobotModel(abc.ABC):
    """What the product needs from a robot: see the module docstring for layouts and units.

    Subclasses set the attributes and implement the abstract methods; the derived properties
    (``joint_names``, ``n_joints``, ``n_b``, ``nominal_gains``...) are written once here.
    """

    name: str
    joints: tuple[ActuatedJoint, ...]
    standard_names: tuple[str, ...]  # every standard parameter: bodies' inertial, joints' drive
    bodies: tuple[Body, ...]
    # where a payload is mounted unless its tag names another frame; None: no payload frame
    payload_frame: str | None = None
    names: list[str]  # base parameters
    expressions: list[str]  # each base parameter's regrouping of standard ones
    K: np.ndarray  # (n_b, n_st): chi_b = K chi_st (eq. 21)
    gravity: tuple[float, float, float] = DEFAULT_GRAVITY  # m/s², the acceleration vector
    # False when the robot file gives no nominal gains (a bare URDF: 1 per unit stands in for
    # the feed-forward): the identified gains are then judged by eq. (37) and their signs only
    nominal_gains_given: bool = True
    # the drive chains when the robot is identified in actuator space (model/actuator_space.py,
    # whose "joints" are the motors); None: each motor drives its joint directly
    transmission = None  # model.transmission.Transmission | None
    # joints of the description fixed before anything else (robot file ``locked_joints``, their
    # mimics, joints left out of actuated_joints): model/locked_joints.LockedJoint
    locked_joints: tuple = ()
    # W's columns that are not smooth functions of the filtered states (a friction's sign(q̇)),
    # built at the sample rate (identify/observe/smooth_rows.py); None: the robot does not say
    rough_columns: tuple[int, ...] | None = None
    # the robot file's description (model/robot_file.RobotDescription); None: none (closed form)
    description = None
    # behind a transmission, the joints' own model (model/actuator_space.py); None: no joint side
    joint_model = None
    # a closed chain's loop closure (model/closure.Closure); None: an open tree
    closure = None
    # (mimic joint, its leader's actuated index, multiplier, offset) of each URDF mimic joint
    mimic_rows: tuple = ()

    @abc.abstractmethod
    def observation_block(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray,
                          out: np.ndarray | None = None) -> np.ndarray:
        """[W | W_payload] as (n_b + 1, n, m): the base columns, then the actuated efforts per kg
        of the bound payload (``with_payload``); written into ``out`` when given."""

    @abc.abstractmethod
    def with_payload(self, payload: Payload) -> RobotModel:
        """The same model whose payload column is that of ``payload``'s shape (frame, com,
        inertia per kg); ConfigError for a frame the robot does not have."""

    def payload_standard_block(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray,
                               frame: str) -> np.ndarray | None:
        """(10, n, m): the actuated efforts of each of a payload's ten inertial parameters
        (INERTIAL_KINDS, at the origin and in the axes of ``frame``), or None when the model has
        only the mass column (the Orthoglide's closed form: its platform only translates)."""
        return None

    def observation_and_payload_block(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray,
                                      frame: str) -> np.ndarray:
        """[W | W_payload | the ten payload columns at ``frame``] as (n_b + 11, n, m): what a
        loaded record whose payload is partly unknown needs (one pass where the model can)."""
        n = self.n_b
        out = np.empty((n + 11, self.n_joints, np.shape(q)[0]))
        self.observation_block(q, qd, qdd, out=out[:n + 1])
        out[n + 1:] = self.payload_standard_block(q, qd, qdd, frame)
        return out

    def standard_values(self) -> np.ndarray | None:
        """χ_st of the robot's description (``standard_names`` order), the consistency step's
        prior; None when there is no description to read (the Orthoglide's closed form)."""
        return None

    def effort_limits(self) -> dict[str, float]:
        """The description's effort limits (N·m or N) per actuated joint that has one; {}
        when the description gives none or the actuators are motors behind a transmission."""
        return {}

    @abc.abstractmethod
    def standard_regressor(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        """W_st (n m, n_st), rows joint by joint: tau = W_st chi_st (checks, consistency)."""

    @abc.abstractmethod
    def random_states(self, n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """n regular states (q, q̇, q̈), each (n, n_joints), inside the joint limits."""

    @abc.abstractmethod
    def table(self) -> str:
        """The base parameters and their regrouping, for people."""

    @abc.abstractmethod
    def to_json(self) -> dict:
        """The base parameters as data (``orthoglide-ident model --base-parameters --json``)."""

    # --- the identified model, written by every robot the same way unless it has its own ----
    def identified_urdf(self, chi_st: np.ndarray, gains: Sequence[float]) -> str:
        """The URDF of the identified model (``identify --urdf-out``): a URDF robot's own file
        with the inertials and drive terms of ``chi_st``; ConfigError for a robot without one."""
        from orthoglide_ident.model.urdf import urdf_with_inertials

        return urdf_with_inertials(self, chi_st, gains)

    def joint_labels(self, urdf_text: str) -> dict[str, str]:
        """URDF joint name -> the label of its drive terms (``fv_<label>``) in ``urdf_text``."""
        from orthoglide_ident.model.urdf import joint_labels

        return joint_labels(self, urdf_text)

    def forward_model(self, chi_st: np.ndarray, gains: Sequence[float],
                      payload: Payload | None):
        """(forward model, engine name) of the identified model (model/forward.py), or (None,
        reason) when it cannot be simulated here (the passive joints of a closed chain)."""
        from orthoglide_ident.model.forward import tree_forward

        return tree_forward(self, chi_st, gains, payload)

    # --- derived, written once -------------------------------------------------------------
    def regressor(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        """W (n m, n_b), rows joint by joint (eq. 20): tau = W chi_b."""
        X = self.observation_block(q, qd, qdd)[:-1]
        return X.reshape(X.shape[0], -1).T

    def payload_mass_column(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        """W_kl (n m,): efforts per kg of the bound payload (eq. 29)."""
        return self.observation_block(q, qd, qdd)[-1].reshape(-1)

    def base_values(self, chi_st: np.ndarray) -> np.ndarray:
        """chi_b = K chi_st for a standard parameter vector in ``standard_names`` order."""
        return self.K @ np.asarray(chi_st, dtype=float)

    @property
    def joint_names(self) -> tuple[str, ...]:
        return tuple(j.name for j in self.joints)

    @property
    def n_joints(self) -> int:
        return len(self.joints)

    @property
    def n_b(self) -> int:
        return len(self.names)

    @property
    def nominal_gains(self) -> np.ndarray:
        """(n,) the manufacturer's drive gains, N/A or N·m/A."""
        return np.array([j.nominal_gain for j in self.joints], dtype=float)

    def effort_as_current(self, names: Sequence[str], effort: np.ndarray) -> np.ndarray:
        """A torque/force effort (m, len(names)) in N·m or N -> currents (A) with the nominal
        gains (``effort_unit: torque``); a joint the model lacks (a gripper) is left as it is."""
        gains = dict(zip(self.joint_names, self.nominal_gains))
        return np.asarray(effort, float) / [gains.get(n, 1.0) for n in names]

    @property
    def motor_scale(self) -> np.ndarray | None:
        """s_a = max_j |N_aj| of each motor behind a transmission (identify/observe/
        joint_units.py: its unknowns in joint-side units); None without a transmission."""
        t = self.transmission
        return None if t is None else np.max(np.abs(np.asarray(t.N, float)), axis=1)

    @property
    def gain_units(self) -> tuple[str, ...]:
        return tuple(j.gain_unit for j in self.joints)

    def check_joint_names(self, names: Sequence[str], what: str) -> None:
        """ConfigError unless ``names`` hold every joint of the model (any order, extras
        allowed)."""
        missing = [j for j in self.joint_names if j not in names]
        if missing:
            raise ConfigError(f"{what} lacks the joints {missing} of robot {self.name} "
                              f"(has {list(names)})")
