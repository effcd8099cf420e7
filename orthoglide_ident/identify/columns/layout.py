"""The columns of the decimated IDIM, laid out once per robot and options (paper eqs. 20, 31, 33).

The robot gives W, the columns of its base parameters χ (eqs. 20-22), and W_kl, the known part
of a payload (eq. 31). Beside W sit the columns this product adds, in this order:

    [ W  |  W_ul  |  lag  |  ripple  |  W_kl ]      n_b + n_ul + k + 1 columns of a block
      χ     χ_ul    (drive terms, k)    χ_kl = 1    (eq. 33's W_tot adds V_τ for g_τ)

- W_ul: a payload known by its mass, its other parameters χ_ul identified with χ (Sect. 4.3,
  payload_unknowns.py), zero in an unloaded record's rows;
- lag: each joint's current-loop lag, one column per joint in its own rows (current_lag.py);
- ripple: a ball screw's friction ripple at a known lead, two columns per prismatic joint
  (drive_terms.py).

A :class:`ColumnLayout` says which of these a run holds, their names and where they sit; it is
built once (:func:`column_layout`) and shared by the offline path (pipeline.py) and the live one
(live/session.py). The robot is never wrapped: code that builds a block is given the robot and
the layout (:meth:`ColumnLayout.observation_block`); a loaded record's payload binds the robot
(:func:`bound_to`). What the solve keeps of the columns (those some record fills, the lag when
every segment had its instrument) is a layout derived once (:meth:`ColumnLayout.keeping`,
:meth:`ColumnLayout.without_lag`). docs/design/adding_a_column_kind.md: how to add a kind.
"""
from __future__ import annotations

import dataclasses
import weakref
from dataclasses import dataclass

import numpy as np

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.identify.columns.drive_terms import RippleTerm, Terms, screw_joints
from orthoglide_ident.identify.columns.payload_unknowns import (
    STATES_SEED,
    PayloadBasis,
    payload_basis,
)
from orthoglide_ident.model.robot import INERTIAL_KINDS, Payload


@dataclass(frozen=True)
class ColumnLayout:
    """Which columns beside W a run holds, their names and index ranges (module docstring).

    ``base_names``/``base_expressions``: the robot's base parameters χ (n_b); ``basis``: the
    payload's identifiable unknowns χ_ul (None: the payload acts by its mass only, or the run
    has no such payload), of which ``payload_columns`` are kept; ``terms``: the drive terms in
    the equations (the lag, a ripple at ``lead_m``); ``robot_rough``: the robot's columns that
    are not smooth functions of the filtered states (observe/smooth_rows.py), None when it
    does not say."""

    base_names: tuple[str, ...]
    base_expressions: tuple[str, ...]
    joint_names: tuple[str, ...]
    payload_frame: str | None = None
    robot_rough: tuple[int, ...] | None = None
    basis: PayloadBasis | None = None
    payload_columns: tuple[int, ...] = ()
    terms: Terms = Terms()
    lead_m: float = 0.0

    # --- sizes and index ranges ---------------------------------------------------------------
    @property
    def n_base(self) -> int:
        """n_b: the robot's base parameters χ (eq. 22)."""
        return len(self.base_names)

    @property
    def n_payload(self) -> int:
        """n_ul: the payload's unknowns χ_ul kept (eq. 33)."""
        return len(self.payload_columns)

    @property
    def n_extra(self) -> int:
        """k: the drive terms' columns (lag, ripple)."""
        return self.terms.n_extra

    @property
    def n_columns(self) -> int:
        """The unknowns beside g_τ: n_b + n_ul + k (W_kl, the last column, is not one)."""
        return self.n_base + self.n_payload + self.n_extra

    @property
    def base_slice(self) -> slice:
        return slice(0, self.n_base)

    @property
    def payload_slice(self) -> slice:
        """Where χ_ul sits among the unknowns (after χ)."""
        return slice(self.n_base, self.n_base + self.n_payload)

    @property
    def terms_start(self) -> int:
        """The first drive-term column (after χ and χ_ul)."""
        return self.n_base + self.n_payload

    @property
    def lag_column(self) -> int | None:
        """Joint 0's lag column (joint j's at + j), None without the lag."""
        return self.terms_start if self.terms.lag else None

    @property
    def ripple_slice(self) -> slice:
        start = self.terms_start + self.terms.lag
        return slice(start, start + 2 * len(self.terms.ripples))

    @property
    def has_payload_unknowns(self) -> bool:
        return self.basis is not None

    # --- names ----------------------------------------------------------------------------
    @property
    def payload_names(self) -> list[str]:
        return [self.basis.names[k] for k in self.payload_columns] if self.basis else []

    @property
    def payload_expressions(self) -> list[str]:
        return [self.basis.expressions[k] for k in self.payload_columns] if self.basis else []

    @property
    def names(self) -> list[str]:
        """The unknowns' names, column by column: χ, χ_ul, the drive terms."""
        return list(self.base_names) + self.payload_names + self.terms.names(self.joint_names)

    @property
    def expressions(self) -> list[str]:
        """Each unknown's regrouping of standard parameters (a drive term: what it multiplies)."""
        names = self.joint_names
        lag = [f"τ g_τ {j}: v̇τ {j} averaged over the other periods" for j in names
               if self.terms.lag]
        ripple = [f"sign(q̇ {names[t.joint]}) {f}(2π {names[t.joint]} / {self.lead_m:g} m)"
                  for t in self.terms.ripples for f in ("cos", "sin")]
        return list(self.base_expressions) + self.payload_expressions + lag + ripple

    @property
    def rough_columns(self) -> tuple[int, ...] | None:
        """Columns that are not smooth functions of the filtered states (observe/stream.py):
        the robot's, the lag's (the currents' instrument) and the ripple's (sign(q̂̇)); the
        payload's are smooth. None when the robot does not say."""
        if self.robot_rough is None:
            return None
        start = self.terms_start
        return tuple(self.robot_rough) + tuple(range(start, start + self.n_extra))

    # --- derived layouts ------------------------------------------------------------------
    def keeping(self, columns: tuple[int, ...]) -> ColumnLayout:
        """Only these of the payload columns (indices into ``payload_columns``); no payload
        unknowns when none is left."""
        if not columns:
            return dataclasses.replace(self, basis=None, payload_columns=())
        return dataclasses.replace(
            self, payload_columns=tuple(self.payload_columns[c] for c in columns))

    def at_frame(self, robot, frame: str) -> ColumnLayout:
        """The same payload columns named and regrouped as at ``frame`` (a loaded payload's)."""
        if self.basis is None or (frame or self.payload_frame) == (self.basis.frame
                                                                   or self.payload_frame):
            return self
        return dataclasses.replace(self, basis=payload_basis(robot, frame))

    def without_lag(self) -> ColumnLayout:
        """The paper's drive model: no lag columns (the ripple at a given lead stays)."""
        return dataclasses.replace(self, terms=Terms(self.terms.ripples, 0))

    # --- blocks of states (the robot given: bound to the record's payload, bound_to) -------
    def observation_block(self, robot, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray,
                          out: np.ndarray | None = None, payload: Payload | None = None
                          ) -> np.ndarray:
        """[W | W_ul | lag (zero: the stream fills it) | ripple | W_kl] of states (m, n_j) as
        (n_b + n_ul + k + 1, n_j, m). ``robot``: bound to the record's payload (:func:`bound_to`),
        whose unknown kinds fill W_ul."""
        n_b, n_ul, k = self.n_base, self.n_payload, self.n_extra
        n, m = n_b + n_ul, np.shape(q)[0]
        if out is None:
            out = np.empty((n + k + 1, robot.n_joints, m))
        self._payload_block(robot, q, qd, qdd, out[:n + 1], payload)
        out[n + k] = out[n]  # W_kl goes last
        out[n:n + k] = 0.0
        self._ripples(q, qd, out[self.ripple_slice.start:])
        return out

    def _payload_block(self, robot, q, qd, qdd, out: np.ndarray, payload: Payload | None
                       ) -> None:
        """[W | W_ul | W_kl] into ``out`` (n_b + n_ul + 1, n_j, m) (eqs. 29, 31)."""
        n, k = self.n_base, self.n_payload
        if payload is None or not payload.unknown or not k:
            robot.observation_block(q, qd, qdd, out=out[:n + 1])
            out[n + k] = out[n]  # W_kl goes last
            out[n:n + k] = 0.0
            return
        X = robot.observation_and_payload_block(q, qd, qdd, payload.frame)
        out[:n] = X[:n]
        out[n + k] = X[n]
        for i, c in enumerate(self.payload_columns):
            kind = self.basis.kinds[c]
            out[n + i] = X[n + 1 + INERTIAL_KINDS.index(kind)] if kind in payload.unknown else 0.0

    def _ripples(self, q: np.ndarray, qd: np.ndarray, out: np.ndarray) -> None:
        """The ripple columns sign(q̂̇_j) cos, sin(2π q̂_j/λ) into ``out`` (2 per term, n_j, m),
        each in its joint's rows (the others left as they are: zero)."""
        ripples = self.terms.ripples
        phi = (2.0 * np.pi / self.lead_m) * np.asarray(q) if ripples else None
        s = np.sign(qd)
        for i, t in enumerate(ripples):
            j = t.joint
            out[2 * i, j] = s[:, j] * np.cos(phi[:, j])
            out[2 * i + 1, j] = s[:, j] * np.sin(phi[:, j])

    def rough_block(self, robot, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray,
                    out: np.ndarray | None = None) -> np.ndarray:
        """The layout's :attr:`~ColumnLayout.rough_columns` (lag zero: the stream fills it) as
        (n_rough, n_j, m)."""
        n_r, k = len(self.robot_rough), self.n_extra
        if out is None:
            out = np.empty((n_r + k, robot.n_joints, np.shape(q)[0]))
        robot.rough_block(q, qd, qdd, out[:n_r])
        out[n_r:] = 0.0
        self._ripples(q, qd, out[n_r + self.terms.lag:])
        return out

    def regressor(self, robot, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        """[W | W_ul | lag (zero: it needs the currents) | ripple] (n_j N, n_columns), rows joint
        by joint."""
        X = self.observation_block(robot, q, qd, qdd)[:-1]
        return X.transpose(1, 2, 0).reshape(-1, X.shape[0])


def plain_layout(robot) -> ColumnLayout:
    """The robot's own columns: [W | W_kl], nothing beside them."""
    return ColumnLayout(tuple(robot.names), tuple(robot.expressions), tuple(robot.joint_names),
                        robot.payload_frame, _robot_rough(robot))


def column_layout(robot, lead_m: float = 0.0, lag: bool = False) -> ColumnLayout:
    """The layout of a run on ``robot``: its payload unknowns when a payload known by its mass
    has parameters other than the mass that act (Sect. 4.3), the screw ripple columns when the
    lead is known (``lead_m`` > 0, options.screw_lead_m), the lag columns when ``lag``
    (options.lag_model auto). Built once per robot and options."""
    layout = plain_layout(robot)
    basis = payload_unknowns_basis(robot)
    if basis is not None and basis.n:
        layout = dataclasses.replace(layout, basis=basis, payload_columns=tuple(range(basis.n)))
    ripples = tuple(RippleTerm(j, float(lead_m), True) for j in screw_joints(robot)) \
        if lead_m > 0 else ()
    return dataclasses.replace(layout, terms=Terms(ripples, robot.n_joints if lag else 0),
                               lead_m=float(lead_m))


def _robot_rough(robot) -> tuple[int, ...] | None:
    rough = robot.rough_columns
    return None if rough is None else tuple(int(c) for c in rough)


_BASES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()  # robot -> its basis


def payload_unknowns_basis(robot) -> PayloadBasis | None:
    """The basis of a payload known by its mass at the robot's payload frame (None when the
    robot has no payload frame, or no payload column). Found once per robot (a closed
    chain's random states take a while)."""
    if robot.payload_frame is None:
        return None
    try:
        basis = _BASES.get(robot, False)
    except TypeError:  # a robot that cannot be weakly referenced: found each time
        basis = False
    if basis is False:
        probe = robot.payload_standard_block(*robot.random_states(2, STATES_SEED),
                                             robot.payload_frame)
        basis = None if probe is None else payload_basis(robot, "")
        try:
            _BASES[robot] = basis
        except TypeError:
            pass
    return basis


def bound_to(robot, layout: ColumnLayout, payload: Payload):
    """The robot bound to a loaded record's payload: its known part in W_kl (eq. 31); its
    unknown kinds go into W_ul (observation_block given ``payload``). ConfigError when they
    regroup otherwise at its frame than the layout's."""
    basis = layout.basis
    if basis is not None and payload.unknown and (payload.frame or robot.payload_frame) != \
            (basis.frame or robot.payload_frame):
        other = payload_basis(robot, payload.frame)
        if other.kinds != basis.kinds:
            raise ConfigError(
                f"a payload known by its mass at {payload.frame} has identifiable parameters "
                f"{list(other.kinds)}, not those at {basis.frame or robot.payload_frame} "
                f"({list(basis.kinds)}): give orthoglide.payload_frame as "
                f"{basis.frame or robot.payload_frame}, or its CoM and inertia")
    return robot.with_payload(payload.known_part())

