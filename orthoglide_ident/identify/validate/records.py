"""What the offline pipeline and the live identification both do with the records they received
(issues 43 and 47): one implementation, called from pipeline.py (bags) and live/session.py
(topics).

- ``check_record``: the record against the robot (records/robot_checks.py): positions beyond
  the limits refused (DataError, one line naming the record and the likely cause), velocities
  and currents far beyond the limits warned; and its content's fingerprint (a record given twice,
  whatever its clock, is counted once);
- ``other_readings``: an untagged slow log's other readings as sampled (observe/sampling.py),
  among which ``sampling.best_reading`` chooses by the residual;
- ``undetermine_at_limit``: the gains of joints whose current chattered at its limit in some
  record (records/robot_checks.current_at_limit) not marked determined, with that reason;
- ``noise_by_joint`` and ``misfit_warnings``: behind a transmission, the motors fitted far worse
  than their current noise says (a reduction typed wrong, validate/joint_side.py).
"""
from __future__ import annotations

import hashlib

import numpy as np

from orthoglide_ident.identify.columns.layout import ColumnLayout
from orthoglide_ident.identify.diagnostics import bag_report
from orthoglide_ident.identify.observe.rows import IdentificationModel, observe
from orthoglide_ident.identify.observe.sampling import AUTO_HELD, SLOW_STEP_S, loop_half_ticks
from orthoglide_ident.identify.options import IdentifyOptions
from orthoglide_ident.identify.records.record import Record
from orthoglide_ident.identify.records.robot_checks import (
    check_positions,
    motion_warnings,
)
from orthoglide_ident.identify.solve.methods import get
from orthoglide_ident.identify.validate.joint_side import (
    LONGER,
    current_noise,
    misfit,
    misfit_lines,
)
from orthoglide_ident.results import IdentificationResult


def first_stamp(rec: Record) -> int:
    return int(min(rec.stamps_q_ns[0], rec.stamps_v_ns[0]))


def fingerprint(rec: Record) -> str:
    """What identifies a record's data whatever its path and clock: a digest of its positions,
    currents and stamps counted from its first one (the same bag given twice, a copy of it,
    the same log exported again with another clock origin) and of its tag (the same data
    tagged with another payload is not a copy: the payload checks judge it)."""
    h = hashlib.sha256(f"{rec.condition} {rec.payload_mass!r} {rec.payload!r}".encode())
    t0 = first_stamp(rec)
    for a in (np.asarray(rec.stamps_q_ns) - t0, rec.q, np.asarray(rec.stamps_v_ns) - t0,
              rec.v_tau):
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()


def copy_line(rec: Record, first: str, first_t0: int) -> str:
    """The warning of a record that holds the same data as ``first`` (counted once)."""
    shift = (first_stamp(rec) - first_t0) * 1e-9
    clock = f"; its clock starts {shift:+.6g} s from that one's" if shift else ""
    return (f"{rec.source} is the same record as {first} (the same positions and currents at "
            f"the same steps{clock}): counted once")


def check_record(rec: Record, model: IdentificationModel, seen: dict[str, tuple[str, int]]
                 ) -> tuple[bool, list[str]]:
    """(is it new, its warnings) for a record received: DataError when its positions leave the
    robot's limits (records/robot_checks.check_positions); a record whose content is in ``seen``
    (fingerprint -> first source, first stamp; updated) is a copy, to be counted once."""
    key = fingerprint(rec)
    if key in seen:  # the same data twice would count its equations twice (σ too small)
        return False, [copy_line(rec, *seen[key])]
    check_positions(rec, model)  # degrees read as radians, another robot: refused
    seen[key] = (rec.source, first_stamp(rec))
    return True, list(rec.warnings) + motion_warnings(rec, model)


def by_joint(model: IdentificationModel, at_limit: dict[str, str]) -> dict[int, str]:
    """current_at_limit's joint names -> why, as the model's joint indices -> why."""
    idx = {n: j for j, n in enumerate(model.joint_names)}
    return {idx[n]: why for n, why in at_limit.items() if n in idx}


def undetermine_at_limit(result: IdentificationResult, at_limit: list[dict[str, str]]) -> None:
    """Each gain of a joint named in ``at_limit`` (per record, current_at_limit's joint -> why)
    not determined, value and σ NaN as a partial answer's, the first record's reason: a current
    chattering at its limit biases the gain beyond its σ (records/robot_checks.py)."""
    if get(result.method).gains_given:  # the gains are an input, not identified here
        return
    why: dict[str, str] = {}
    for d in at_limit:
        for name, line in d.items():
            why.setdefault(name, line)
    if why:  # the others' velocities dithered through the coupling (solve/partial.at_limit)
        first = next(iter(why.values()))
        why.update({g.name: first for g in result.drive_gains if g.name not in why})
    for g in result.drive_gains:
        if g.determined and g.name in why:
            g.value, g.rel_std, g.rel_std_paper = float("nan"), float("nan"), None
            g.determined, g.reason = False, why[g.name]


def noise_by_joint(rec: Record, model: IdentificationModel) -> tuple[np.ndarray, float]:
    """(white-noise σ of the record's current per model joint, A, NaN if absent; log rate)."""
    sigma, rate = current_noise(rec.v_tau, rec.stamps_v_ns)
    col = {n: k for k, n in enumerate(rec.names_v)}
    return np.array([sigma[col[n]] if n in col else np.nan for n in model.joint_names]), rate


def misfit_warnings(result: IdentificationResult, g_tau: np.ndarray, model: IdentificationModel,
                    noises: list[tuple[np.ndarray, float]], opts: IdentifyOptions) -> bool:
    """Behind a transmission, the motors fitted far worse than their current noise said (a
    reduction typed wrong) into ``result``'s warnings, and the undetermined gains' advice
    changed to say so. False when the robot has no transmission (nothing to say)."""
    if model.transmission is None or not noises:
        return False
    noise = np.sqrt(np.nanmean([n ** 2 for n, _ in noises], axis=0))
    ratio = misfit(result.residual_rms, g_tau, noise, float(np.median(
        [r for _, r in noises])), opts.observe.decimation_cutoff_hz)
    lines, advice = misfit_lines(ratio, list(model.joint_names))
    result.warnings.extend(lines)
    if advice:  # an undetermined gain's cause is then the drive chain, not the motion
        for g in result.drive_gains:
            g.reason = g.reason.replace(LONGER, advice)
        result.warnings = [w.replace(LONGER, advice) for w in result.warnings]
    return True


def other_readings(rec: Record, model: IdentificationModel, opts: IdentifyOptions, m: float,
                   rep, *, layout: ColumnLayout) -> list | None:
    """A slow record's other readings as sampled (half tick s, rows, report) when its reading
    is open: auto read it held (then sampled at the stamp and at the loop's possible half
    ticks), or it is sampled with its loop's rate unknown (the half ticks); else None."""
    if rep.period_s <= SLOW_STEP_S:
        return None
    auto_held = rep.current_sampling_why.startswith(AUTO_HELD)
    if not auto_held and not (rep.current_sampling == "sampled"
                              and opts.input.current_loop_hz <= 0):
        return None
    shifts = loop_half_ticks(rep.period_s, opts.input.current_loop_hz)
    shifts = ((0.0,) if auto_held and opts.input.current_loop_hz <= 0 else ()) + shifts
    out = []
    for d in shifts:
        o, r, _ = observe(rec, model, opts.replace(current_sampling="sampled",
                                                   current_loop_hz=0.5 / d if d else 0.0), m,
                          layout=layout)
        out.append((d, o, bag_report(r, rec.source, rec.condition, m, o.rows_per_joint(),
                                     rec.sources)))
    return out
