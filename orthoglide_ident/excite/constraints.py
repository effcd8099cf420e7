"""How far samples (q, q̇, q̈) of a trajectory stay from each limit: the slacks the design keeps
and the check reports.

Kinds and units: ``position`` (m or rad to the nearer of lower/upper), ``velocity``,
``acceleration``, ``effort`` (the fraction of the limit left free: 1 - |x| / limit),
``collision`` (m, the smallest distance of a checked pair of bodies), and for a closed chain
``working_mode`` (rad, the passive joints' distance to their limits, which keep the assembly
mode the description states) and ``rate_growth`` (1 - max|G| / (MAX_RATE_GROWTH · max|G| at the
reference): away from the parallel singularities, where the actuated joints stop holding the
passive ones). A kind holds when its worst slack is at least the margin ``Margins`` requires.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from orthoglide_ident.errors import ConfigError, ModelError
from orthoglide_ident.model.pinocchio_model import MAX_RATE_GROWTH
from orthoglide_ident.model.robot import Payload
from orthoglide_ident.model.tree import set_joint

UNITS = {"position": "rad|m", "velocity": "fraction", "acceleration": "fraction",
         "effort": "fraction", "collision": "m", "working_mode": "rad|m", "rate_growth": "fraction",
         "at_rest": "rad/s"}


@dataclass(frozen=True)
class Margins:
    """What a trajectory keeps from each limit (module docstring for the units).

    position 0.05 rad (5 mm for a prismatic joint: ``PRISMATIC_SCALE``); 10 % of the velocity
    and acceleration limits (the controller's tracking overshoots the reference); 20 % of the
    effort (the nominal model is the URDF's, off by the unmodelled friction and the payload's
    uncertainty, and the controller adds its own corrections); 2 cm between bodies (the
    primitives are approximate and the arm tracks its reference to about a millimetre);
    0.05 rad from the passive joints' limits; |G| at most MAX_RATE_GROWTH times the reference's.
    """

    position: float = 0.05
    velocity: float = 0.10
    acceleration: float = 0.10
    effort: float = 0.20
    collision: float = 0.02
    working_mode: float = 0.05
    rate_growth: float = 0.0

    PRISMATIC_SCALE = 0.1  # a prismatic joint's position margin in m per rad of the revolute's

    def to_dict(self) -> dict[str, float]:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: Any, where: str) -> Margins:
        if d is None:
            return cls()
        try:
            return cls(**{k: float(v) for k, v in dict(d).items()})
        except (TypeError, ValueError) as exc:
            raise ConfigError(f"{where}: margins: {exc}") from None

    def position_of(self, kinds: list[str]) -> np.ndarray:
        """(n,) the position margin per joint in its unit."""
        return np.array([self.position * (self.PRISMATIC_SCALE if k == "prismatic" else 1.0)
                         for k in kinds])


@dataclass(frozen=True)
class Slack:
    """The worst slack of one kind over a run: its value, the margin required, where."""

    kind: str
    value: float
    required: float
    where: str  # joint or pair of bodies, run and time
    run: str = ""

    @property
    def ok(self) -> bool:
        return self.value >= self.required

    def to_dict(self) -> dict[str, Any]:
        v = self.value if math.isfinite(self.value) else None
        return {"kind": self.kind, "worst": v, "required": self.required, "unit": UNITS[self.kind],
                "where": self.where, "ok": self.ok}


def worst(kind: str, slack: np.ndarray, required: float | np.ndarray, names: list[str],
          t: np.ndarray, run: str) -> Slack:
    """The worst of ``slack`` (m samples, k columns named ``names``) minus ``required`` per
    column, as a Slack (value and requirement of that column)."""
    req = np.broadcast_to(np.asarray(required, float), (slack.shape[1],))
    if slack.size == 0:
        return Slack(kind, math.inf, float(req.max(initial=0.0)), "nothing to check", run)
    excess = slack - req
    i, j = np.unravel_index(int(np.argmin(excess)), excess.shape)
    return Slack(
        kind, float(slack[i, j]), float(req[j]), f"{names[j]}, {run} run, t = {t[i]:.3f} s", run
    )


def joint_slacks(limits, kinds: list[str], margins: Margins, q: np.ndarray, qd: np.ndarray,
                 qdd: np.ndarray, tau: np.ndarray, t: np.ndarray, run: str) -> list[Slack]:
    """Position, velocity, acceleration and effort slacks of samples (m, n) against ``limits``."""
    names = list(limits.joints)
    pos = np.minimum(q - limits.lower, limits.upper - q)
    return [worst("position", pos, margins.position_of(kinds), names, t, run),
            worst("velocity", 1.0 - np.abs(qd) / limits.velocity, margins.velocity, names, t, run),
            worst("acceleration", 1.0 - np.abs(qdd) / limits.acceleration, margins.acceleration,
                  names, t, run),
            worst("effort", 1.0 - np.abs(tau) / limits.effort, margins.effort, names, t, run)
            ] + mimic_slacks(limits, margins, q, qd, qdd, t, run)


def mimic_slacks(limits, margins: Margins, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray,
                 t: np.ndarray, run: str) -> list[Slack]:
    """Each mimic joint's own position, velocity and acceleration slacks (limits.py), where
    it gives them; its effort is its leader's motor's (in the leader's column)."""
    out = []
    for m in limits.mimics:
        qm, qdm, qddm = (x[:, None] for x in m.motion(q, qd, qdd))
        if math.isfinite(m.lower) and math.isfinite(m.upper):
            out.append(worst("position", np.minimum(qm - m.lower, m.upper - qm),
                             margins.position_of([m.kind]), [m.joint], t, run))
        for kind, x in (("velocity", qdm), ("acceleration", qddm)):
            lim = getattr(m, kind)
            if math.isfinite(lim) and lim > 0:
                out.append(worst(kind, 1.0 - np.abs(x) / lim, getattr(margins, kind), [m.joint],
                                 t, run))
    return out


def payload_of(run) -> Payload | None:
    """The Payload of a loaded run's ``payload`` mapping (mass, frame, com, inertia), or None."""
    p = run.payload
    if not p:
        return None
    try:
        return Payload(float(p["mass"]), str(p.get("frame") or ""),
                       tuple(float(x) for x in (p.get("com") or (0.0, 0.0, 0.0))),
                       tuple(float(x) for x in (p.get("inertia") or (0.0,) * 6)))
    except (KeyError, TypeError, ValueError) as exc:
        raise ConfigError(f"run {run.name}: payload needs mass (kg), and com (3) and inertia (6) "
                          f"when known ({exc})") from None


def payload_dict(payload: Payload | None) -> dict[str, Any] | None:
    if payload is None:
        return None
    return {"mass": payload.mass, "frame": payload.frame, "com": list(payload.com),
            "inertia": list(payload.inertia)}


class TreeStates:
    """Tree configurations of actuated samples: the joints themselves for a serial robot, the
    loops closed on the working mode's branch for a closed chain (with G, q̇_t = G q̇_a)."""

    def __init__(self, robot):
        self.robot = robot
        self.closure = robot.closure
        self.passive = [j for j in robot.tree_joints if j not in robot.actuated and j.one_dof
                        and math.isfinite(j.lower) and math.isfinite(j.upper)]
        self.g_ref = self._g_ref() if self.closure is not None else math.nan

    def _g_ref(self) -> float:
        from orthoglide_ident.model.closure import TreeStates as States

        c = self.closure
        q_a = c.actuated_values(c.reference)[None]
        st = States.empty(1, self.robot.model.nq, self.robot.model.nv, self.robot.n_joints)
        c.states(q_a, 0 * q_a, 0 * q_a, st, c.reference[None])
        return float(np.abs(st.G).max())

    def configurations(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        """(Q (m, nq), max|G| per sample or None); ModelError where the loops do not close."""
        model = self.robot.model
        if self.closure is None:
            import pinocchio as pin

            Q = np.tile(pin.neutral(model), (q.shape[0], 1))
            for a, j in enumerate(self.robot.actuated):
                set_joint(Q, j, q[:, a])
            for j, a, r, o in getattr(self.robot, "mimic_rows", ()):  # q_m = r q_l + o
                set_joint(Q, j, r * q[:, a] + o)
            return Q, None
        from orthoglide_ident.model.closure import TreeStates as States

        st = States.empty(q.shape[0], model.nq, model.nv, self.robot.n_joints)
        self.closure.states(q, np.zeros_like(q), np.zeros_like(q), st)
        return st.q, np.abs(st.G).max(axis=(1, 2))

    def mode_slacks(self, Q: np.ndarray, G: np.ndarray | None, margins: Margins, t: np.ndarray,
                    run: str) -> list[Slack]:
        """A closed chain's working-mode and rate-growth slacks (none for a serial robot)."""
        if G is None:
            return []
        names = [j.name for j in self.passive]
        pos = np.column_stack([np.minimum(Q[:, j.iq] - j.lower, j.upper - Q[:, j.iq])
                               for j in self.passive]) if self.passive else np.zeros((len(Q), 0))
        growth = 1.0 - G[:, None] / (MAX_RATE_GROWTH * self.g_ref)
        return [worst("working_mode", pos, margins.working_mode, names, t, run),
                worst("rate_growth", growth, margins.rate_growth, ["max|G|"], t, run)]


def collision_slack(collision, Q: np.ndarray, margins: Margins, t: np.ndarray,
                    run: str, qd: np.ndarray | None = None, bound: float | None = None
                    ) -> list[Slack]:
    """The smallest distance between checked bodies (none when collision is skipped); with the
    actuated speeds ``qd`` of a serial robot on a uniform grid, the samples at which no pair can
    have come within the margin are skipped (CollisionModel.distances_along), and with ``bound``
    a pair whose bounding spheres are that far apart gets the bound (distances_above): both for
    meshes only (~0.3 ms a pair; primitives cost less than the bookkeeping)."""
    if collision is None or collision.mode == "skip":
        return []
    if not collision.meshes:  # primitives: coal's own loop over every pair is cheaper
        D = collision.distances(Q)
    elif bound is not None:  # the search: exact only for pairs within ``bound``
        D = collision.distances_above(Q, bound)
    elif qd is not None and len(t) > 1 and collision.robot.closure is None:
        D = collision.distances_along(Q, qd, float(t[1] - t[0]), margins.collision)
    else:
        D = collision.distances(Q)
    return [worst("collision", D, margins.collision, collision.pair_names, t, run)]


def failed(kind: str, exc: ModelError, run: str) -> Slack:
    """A run the model cannot follow (loops that do not close, a singularity): -inf slack."""
    return Slack(kind, -math.inf, 0.0, f"{run} run: {exc}", run)
