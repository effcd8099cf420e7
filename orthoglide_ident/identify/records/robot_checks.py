"""A record checked against the robot it is said to be of, before any row is built (issue 43).

A log in the wrong unit or of another robot gives no error downstream, only a wrong answer:
positions logged in degrees and read as radians (130 "rad" against ±2π limits) gave a WLS
answer with zz_1R 0.028 instead of 0.734, and a TLS refusal blaming the payload. So:

- a position beyond the joint's limits by more than ``POSITION_MARGIN`` of its range is refused,
  in one line naming the file, the joint and the likely cause (degrees, an offset, another
  robot);
- a velocity beyond ``FAR_BEYOND`` times the joint's velocity limit, or a current whose torque
  at the nominal gain is beyond ``FAR_BEYOND`` times the joint's effort limit, is a warning
  naming the joint (a wrong unit, a wrong gain or another robot; the record is still used).

Joints without limits (infinite, or the description gives none) are not checked.

- a current that sits at ± its extreme on more than ``AT_EXTREME_SHARE`` of the samples is a
  controller at its current limit (``current_at_limit``; no limit needed: a clipped reference's
  plateau is its own extreme), chattering there when it also jumps by more than ``SWING`` of its
  range from one sample to the next on more than ``SWING_SHARE`` of them. The chatter dithers the
  joint's velocity through zero (0.13-0.26 rad/s rms at ~250 Hz on a simulated UR10), which
  smooths its Coulomb friction: the friction is no longer the model's fs sign(q̇) of the filtered
  velocity, and the gains come out biased (UR10: 0.5-0.7 %, 4-7 honest σ; without Coulomb friction
  in the plant, the same chatter leaves them within 1 σ); through the mass matrix the other
  joints' velocities are dithered too (wrist 2 3.2 σ off with the chattering rows left out). A
  warning names the joint; with a chattering joint no gain is marked determined
  (solve/partial.at_limit, validate/records.py).
"""
from __future__ import annotations

import math

import numpy as np

from orthoglide_ident.errors import DataError

POSITION_MARGIN = 0.1  # of the joint's range: encoders overshoot a soft limit, never by this
FAR_BEYOND = 2.0  # x the velocity or effort limit: beyond any overshoot a controller allows
ROBUST_QUANTILE = 0.999  # of |q̇| and |τ|: one spike or a missed sample is not a verdict
DEG = math.pi / 180.0
# a current at its extreme: within this fraction of its largest |v_τ| (a clipped reference is
# exactly there; a sinusoid of constant amplitude is within 1e-4 of its peak 0.9 % of the time)
EXTREME_BAND = 1.0e-4
# ... on more than this share of the samples (measured: 23-35 % on the simulated UR10's
# chattering shoulder and elbow)
AT_EXTREME_SHARE = 0.03
SWING = 0.25  # of a current's range in one sample: a switch, not a motion
SWING_SHARE = 0.01  # of the samples (measured: 0 on stable runs, 12-28 % chattering)


def _limits_by_name(robot) -> dict:
    """Actuated joints by name: the robot's (motors behind a transmission) and, behind a
    transmission, the joints' too (a record may hold either side)."""
    joint_side = robot.joint_model
    out = {j.name: j for j in joint_side.joints} if joint_side is not None else {}
    out.update({j.name: j for j in robot.joints})
    return out


def _columns(names, by_name) -> list[tuple[int, object]]:
    return [(k, by_name[n]) for k, n in enumerate(names) if n in by_name]


def check_positions(rec, model) -> None:
    """DataError naming ``rec.source`` if a joint's positions leave its limits by more than
    ``POSITION_MARGIN`` of its range, with the likely cause."""
    by_name = _limits_by_name(model)
    q = np.asarray(rec.q, float)
    for k, j in _columns(rec.names_q, by_name):
        span = j.upper - j.lower
        if not math.isfinite(span) or span <= 0:
            continue
        col = q[:, k][np.isfinite(q[:, k])]
        if not col.size:
            continue
        lo, hi = float(col.min()), float(col.max())
        margin = POSITION_MARGIN * span
        if lo >= j.lower - margin and hi <= j.upper + margin:
            continue
        raise DataError(
            f"{rec.source}: joint {j.name} goes over [{lo:.4g}, {hi:.4g}] {j.unit}, beyond its "
            f"limits [{j.lower:.4g}, {j.upper:.4g}] {j.unit} by more than "
            f"{100 * POSITION_MARGIN:g} % of its range: "
            f"{_motor_side_twice(rec, model, by_name) or _likely_cause(rec, by_name, j, lo, hi)}")


MAPPED = "joint-side positions mapped to the motors"  # record.motor_side's note in ``sources``


def _motor_side_twice(rec, model, by_name) -> str:
    """The cause when a record's positions were motor-side already but read as joint-side (the
    robot file or the bag's tag says joint): mapped back through the reduction, every motor is
    inside its box. "" otherwise."""
    t = model.transmission
    if t is None or MAPPED not in (rec.sources or ""):
        return ""
    raw = t.to_joint_position(np.asarray(rec.q, float))  # the values the record held
    cols = _columns(rec.names_q, by_name)
    if not cols or not all(_fits(raw[:, k], j) for k, j in cols):
        return ""
    return ("this record's positions are motor-side already (N⁻¹ of them is inside every "
            "motor's range) but were read as joint-side and mapped through the reduction again: "
            "the records disagree on their drive chain; tag this bag orthoglide.position_side: "
            "actuator (or set the transmission's position_side)")


def _likely_cause(rec, by_name, j, lo: float, hi: float) -> str:
    """Degrees when every revolute joint would fit in radians and this one is a whole range
    or more away (a turn counted twice is not), an offset when the motion fits in the range but
    not where it is, else another robot."""
    span = j.upper - j.lower
    revolute = [(k, jj) for k, jj in _columns(rec.names_q, by_name) if jj.kind == "revolute"]
    far = hi - lo > span or lo < j.lower - span or hi > j.upper + span
    if j.kind == "revolute" and far and all(_fits(np.asarray(rec.q)[:, k] * DEG, jj)
                                            for k, jj in revolute):
        return ("the positions look like degrees (× π/180 every revolute joint is inside its "
                "limits): import the log with --angle-unit deg")
    if hi - lo <= span:
        centre = 0.5 * (lo + hi) - 0.5 * (j.lower + j.upper)
        return (f"the motion fits in the range but {centre:+.4g} {j.unit} off its centre: an "
                "offset (the encoder's zero, a turn counted twice)? Or another robot (--robot)")
    return ("the motion is wider than the joint's whole range: a log of another robot "
            "(check --robot) or in another unit")


def _fits(col: np.ndarray, j) -> bool:
    col = col[np.isfinite(col)]
    margin = POSITION_MARGIN * (j.upper - j.lower)
    return not col.size or (col.min() >= j.lower - margin and col.max() <= j.upper + margin)


def motion_warnings(rec, model) -> list[str]:
    """One line per joint whose velocity or current is far beyond what the robot allows."""
    by_name = _limits_by_name(model)
    out = []
    t = np.asarray(rec.stamps_q_ns, float) * 1e-9
    q = np.asarray(rec.q, float)
    if q.shape[0] > 2:
        dt = np.diff(t)
        for k, j in _columns(rec.names_q, by_name):
            if not math.isfinite(j.velocity_limit):
                continue
            v = np.abs(np.diff(q[:, k]) / dt)
            v = float(np.quantile(v[np.isfinite(v)], ROBUST_QUANTILE)) if v.size else 0.0
            if v > FAR_BEYOND * j.velocity_limit:
                out.append(f"{rec.source}: joint {j.name} moves at {v:.4g} {j.unit}/s, "
                           f"{v / j.velocity_limit:.3g} times its velocity limit "
                           f"{j.velocity_limit:.4g} {j.unit}/s: a position unit, a clock unit or "
                           "another robot?")
    limits = model.effort_limits()
    cur = np.asarray(rec.v_tau, float)
    for k, j in _columns(rec.names_v, by_name):
        lim = limits.get(j.name, math.inf)
        col = np.abs(cur[:, k][np.isfinite(cur[:, k])]) * j.nominal_gain
        if not math.isfinite(lim) or not col.size:
            continue
        tau = float(np.quantile(col, ROBUST_QUANTILE))
        if tau > FAR_BEYOND * lim:
            out.append(f"{rec.source}: joint {j.name}'s current at its nominal gain "
                       f"{j.nominal_gain:g} is {tau:.4g} {j.effort_unit}, {tau / lim:.3g} times "
                       f"its effort limit {lim:.4g} {j.effort_unit}: a current unit (mA?), a "
                       "torque logged as a current, or other nominal gains?")
    return out + list(current_at_limit(rec).values())


def current_at_limit(rec, chatter_only: bool = False) -> dict[str, str]:
    """Joints (by ``rec.names_v``) whose current sits at its extreme or chatters (module
    docstring), each with one line naming the record and the joint; ``chatter_only``: only the
    chattering ones (the gains not determined: a current held at its limit without chatter is
    still the current applied)."""
    cur = np.asarray(rec.v_tau, float)
    out = {}
    for k, name in enumerate(rec.names_v):
        col = cur[:, k][np.isfinite(cur[:, k])]
        top = float(np.abs(col).max()) if col.size > 2 else 0.0
        if top == 0.0:
            continue
        at = float(np.mean(np.abs(col) >= (1.0 - EXTREME_BAND) * top))
        swing = float(np.mean(np.abs(np.diff(col)) > SWING * float(np.ptp(col))))
        if at <= AT_EXTREME_SHARE:  # noise jumps too, but not at a plateau
            continue
        if swing > SWING_SHARE:
            out[name] = (f"{rec.source}: joint {name}'s current jumps by over {SWING:g} of its "
                         f"range in one sample on {100 * swing:.1f} % of the samples (at ±"
                         f"{top:.4g}, its extreme, on {100 * at:.1f} %): a controller chattering "
                         "at its current limit, whose dither smooths the joint's Coulomb "
                         "friction (not the model's fs sign(q̇)): its gain is not determined; "
                         "lower that joint's controller bandwidth and record again")
        elif not chatter_only:
            out[name] = (f"{rec.source}: joint {name}'s current sits at ±{top:.4g}, its extreme, "
                         f"on {100 * at:.1f} % of the samples: a controller at its current "
                         "limit (the motion asks more than the drive gives)")
    return out
