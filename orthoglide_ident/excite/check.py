"""``excite check``: every constraint of a trajectory file re-verified on a 1 ms grid, apart from
the optimiser that designed it.

Each run is evaluated over one whole period at 1 ms steps (a Fourier series of period T repeats
it exactly, so these are every 1 ms sample of the run up to the grid's phase); the efforts come
from the standard regressor and the description's own parameters (W_st χ_st, eq. 15, plus the
payload's column: not the base-parameter rows the design optimised on), the collision distances
from coal, the closed chain's assembly from its loops. The report gives the worst slack of each
kind (constraints.py) with where it occurs.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from orthoglide_ident.errors import ConfigError, ModelError
from orthoglide_ident.excite.constraints import (
    Margins,
    Slack,
    TreeStates,
    collision_slack,
    failed,
    joint_slacks,
    payload_of,
)
from orthoglide_ident.excite.trajectory import ExcitationTrajectory

CHECK_STEP_S = 1e-3
REST_LIMIT = 1e-6  # rad/s, rad/s²: |q̇(0)|, |q̈(0)| of a run at rest (rest_projection: ~1e-15)


@dataclass(frozen=True)
class CheckReport:
    """The worst slack of each kind over every run; ``ok`` when each keeps its margin."""

    slacks: tuple[Slack, ...]

    def by_kind(self) -> dict[str, Slack]:
        out: dict[str, Slack] = {}
        for s in self.slacks:
            if s.kind not in out or s.value - s.required < out[s.kind].value - out[s.kind].required:
                out[s.kind] = s
        return out

    @property
    def ok(self) -> bool:
        return all(s.ok for s in self.slacks)

    def failures(self) -> list[Slack]:
        return [s for s in self.by_kind().values() if not s.ok]

    def to_text(self) -> str:
        lines = [f"{'constraint':<13} {'worst':>10} {'required':>9}  unit      where"]
        for kind, s in self.by_kind().items():
            lines.append(f"{kind:<13} {s.value:>10.4g} {s.required:>9.4g}  "
                         f"{s.to_dict()['unit']:<9} {s.where}  {'ok' if s.ok else 'VIOLATED'}")
        lines.append("every constraint keeps its margin" if self.ok else
                     "VIOLATED: " + ", ".join(s.kind for s in self.failures()))
        return "\n".join(lines)

    def to_dict(self) -> dict[str, Any]:
        return {kind: s.to_dict() for kind, s in self.by_kind().items()}


def verify_robot(traj: ExcitationTrajectory, robot, where: str) -> None:
    """ConfigError unless ``traj`` was designed for ``robot`` (name and actuated joints)."""
    if traj.robot != robot.name or tuple(traj.joints) != tuple(robot.joint_names):
        raise ConfigError(f"{where} is a trajectory for robot {traj.robot} (joints "
                          f"{', '.join(traj.joints)}), not for robot {robot.name} (joints "
                          f"{', '.join(robot.joint_names)})")
    designed, now = traj.extra.get("locked_joints") or {}, locked_values(robot)
    if "design" in traj.extra and designed != now:  # a file the design wrote
        raise ConfigError(f"{where} was designed with locked joints {designed or 'none'}; robot "
                          f"{robot.name} locks {now or 'none'} (model/locked_joints.py): its "
                          "efforts and collisions differ, design it again")


def locked_values(robot) -> dict[str, float]:
    """The robot's locked joints as the trajectory file keeps them: joint -> m or rad."""
    return {lj.name: float(lj.value) for lj in robot.locked_joints}


def nominal_efforts(robot, payload, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
    """(m, n) N or N·m: W_st χ_st of the description's parameters, plus the payload's efforts."""
    m, n = q.shape
    tau = (robot.standard_regressor(q, qd, qdd) @ robot.standard_values()).reshape(n, m).T
    if payload is not None and payload.mass > 0:
        col = robot.with_payload(payload).payload_mass_column(q, qd, qdd)
        tau = tau + payload.mass * col.reshape(n, m).T
    return tau


def check_trajectory(traj: ExcitationTrajectory, robot, limits, collision, margins: Margins,
                     step: float = CHECK_STEP_S, where: str = "the trajectory") -> CheckReport:
    """Every constraint of every run of ``traj`` on a ``step`` grid (module docstring)."""
    verify_robot(traj, robot, where)
    tree = TreeStates(robot)
    kinds = [j.kind for j in robot.joints]
    slacks: list[Slack] = []
    for name, run in traj.runs.items():
        t = np.arange(0.0, traj.period_s + 0.5 * step, step)
        q, qd, qdd = traj.evaluate(name, t)
        err = traj.rest_error(name)
        slacks.append(Slack("at_rest", REST_LIMIT - err, 0.0, f"{name} run, t = 0 and the end "
                            f"(|q̇|, |q̈| = {err:.2g})", name))
        try:
            tau = nominal_efforts(robot, payload_of(run), q, qd, qdd)
            Q, G = tree.configurations(q)
        except ModelError as exc:
            slacks.append(failed("working_mode", exc, name))
            continue
        slacks += joint_slacks(limits, kinds, margins, q, qd, qdd, tau, t, name)
        slacks += collision_slack(collision, Q, margins, t, name, qd)
        slacks += tree.mode_slacks(Q, G, margins, t, name)
    return CheckReport(tuple(slacks))

