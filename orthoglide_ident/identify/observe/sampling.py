"""How a record's current relates to its stamps: held over the step or sampled at the stamp.

The IDIM (paper eq. 17) pairs each current with the states it acts with. Two loggers exist:

- ``held``: the controller runs at the log rate and holds v_τ[k] over [t_k, t_k+1) (zero-order
  hold): the states are taken at the middle of that step, (t_k + t_k+1) / 2 (time_base.py,
  filtering.half_tick; the paper's Sect. 3 and DESIGN §6.2). Today's assumption.
- ``sampled``: a faster loop (a 1 kHz controller) logged every 10th-14th tick (a ROS node
  subscribed to it): the logged current is the loop's own at the stamp, a point sample of a
  current that moves within the log step, so the states are taken at the stamp t_k, or at
  t_k + 1 / (2 f_loop) when the loop's rate is known (``current_loop_hz``: the loop holds its
  current over its own tick; unmodelled, that half tick biased the UR5's wrist gains ~5 σ at
  ~83 Hz, bench/logger_sampling.py). The loop's
  content above the log's Nyquist frequency is aliased into the band: noise in v_τ that the
  honest σ covers (solve/uncertainty.py takes it from the residual) or, when it drowns the
  gains, the separation test (eq. 37) refuses them.

Treating a sampled current as held puts the states half a log step late: at 1 kHz the
identified current-loop lag comes out negative (-0.45 ... -0.49 ms, impossible), at ~90 Hz the
gains are biased several σ (DESIGN §10). Who says which: the bag's tag
``orthoglide.current_sampling`` first (written with the signals), then the option
``current_sampling`` (held | sampled), then the robot file's key ``current_sampling``; with
``auto`` and nothing said, the record is read as held and :func:`lag_says_sampled` states the
rule that turns it to sampled.
"""
from __future__ import annotations

import dataclasses
from typing import Any, Callable, Sequence

import numpy as np

from orthoglide_ident.errors import OrthoglideError

CURRENT_SAMPLING = ("held", "sampled", "auto")  # the option's values (a tag: held | sampled)
AUTO_HELD = "current_sampling: auto, nothing said"  # the start of auto's first reading's why
SLOW_STEP_S = 2.0e-3  # s: a log step above this, untagged, may be a slower logger's
# sampled chosen for a slow untagged log when its residual is below this x held's (geometric
# mean over the joints; a tie stays held, today's reading): a current read with the wrong timing
# leaves a force half a step out of place. Measured: 0.36 on a point-sampled ~83 Hz UR5 log, 5x
# the other way on a held 91 Hz one (bench/logger_sampling.py), 0.95 on the real Panda log of
# tests/identify/test_real_panda.py (every 10th sample of a 1 kHz torque log: its held-out
# torques 0.150 -> 0.138 N·m rms read as sampled)
RESIDUAL_MARGIN = 0.98
# said with a refusal of a slow log read as sampled: what a point-sampled log cannot undo
ALIASED = ("or, a current point-sampled from a faster loop, that loop's content above the "
           "log's Nyquist frequency aliased into the band as noise: log the current averaged "
           "over each step (then it is held) or at the loop's own rate")
NEGATIVE_LAG_SIGMAS = 3.0  # τ below -this x its σ on most joints: no current loop leads


def robot_file_sampling(model: Any) -> str | None:
    """The robot file's ``current_sampling`` (held | sampled), None when it says nothing."""
    for m in (model, getattr(model, "joint_model", None)):
        desc = getattr(m, "description", None)
        value = getattr(desc, "current_sampling", None)
        if value is not None:
            return value
    return None


def record_sampling(tagged: str | None, option: str, robot_file: str | None = None
                    ) -> tuple[str, str]:
    """(held | sampled, who said it) for a record: its tag, else the option unless auto, else
    the robot file, else held (auto's first reading)."""
    if tagged is not None:
        return tagged, "the bag's tag orthoglide.current_sampling"
    if option != "auto":
        return option, f"current_sampling: {option}"
    if robot_file is not None:
        return robot_file, "the robot file's current_sampling"
    return "held", f"{AUTO_HELD}: held until the lag says otherwise"


def at_sampling(opts, sampling: str):
    """``opts`` for a record whose current is ``sampling`` (resolved: held | sampled): the
    states at the stamps for a sampled current (no half-step shift), as they are for a held
    one."""
    if sampling == "sampled":
        return dataclasses.replace(opts, zoh_shift=False, current_sampling=sampling)
    return dataclasses.replace(opts, current_sampling=sampling)


def sampled_shift_s(opts) -> float:
    """Where a sampled current acts after its stamp, s: the loop that made it holds it over
    its own tick, so at the middle of that tick, 1 / (2 current_loop_hz); 0 when that rate is
    not known (the states at the stamp) or the current is held (zoh_shift)."""
    if opts.zoh_shift or not opts.current_loop_hz > 0:
        return 0.0
    return 0.5 / opts.current_loop_hz


def lag_says_sampled(current_lag: Sequence[dict]) -> str | None:
    """Why the identified lags (``IdentificationResult.current_lag``, τ in ms) say the current
    is a point sample at the stamp, or None: a current loop cannot act before its reference,
    so τ below -NEGATIVE_LAG_SIGMAS σ on more than half the joints is a current read as held
    that was sampled (the states half a step late)."""
    neg = [x for x in current_lag
           if x["tau_ms"] < -NEGATIVE_LAG_SIGMAS * max(x["tau_std_ms"], 1e-9)]
    if not current_lag or 2 * len(neg) <= len(current_lag):
        return None
    taus = ", ".join(f"{x['tau_ms']:+.3f}" for x in current_lag)
    return (f"the identified current-loop lag is negative on {len(neg)} of {len(current_lag)} "
            f"joints ({taus} ms), impossible for a current held over its step: read as sampled "
            "at the stamps (current_sampling: auto)")


def held_or_sampled(solve_rows: Callable, blocks: list, reports: list, alts: list
                    ) -> tuple[Any, list, str]:
    """auto on slow untagged logs (``alts[i]``: record i's rows and report read as sampled, or
    None): both readings solved by ``solve_rows(blocks, reports)``, the one whose residual is
    smaller (sampled only below RESIDUAL_MARGIN x held's), or the one that solves; both
    refused: held's error. Returns (what solve_rows returned, the reports, one line why)."""
    alt_blocks = [b if a is None else a[0] for a, b in zip(alts, blocks)]
    alt_reports = [r if a is None else a[1] for a, r in zip(alts, reports)]
    which = ", ".join(r["bag"] for a, r in zip(alts, reports) if a is not None)
    step = max(r["period_s"] for a, r in zip(alts, reports) if a is not None)
    held = sampled = None
    try:
        held = solve_rows(blocks, reports)
    except OrthoglideError as exc:
        held_error = exc
    try:
        sampled = solve_rows(alt_blocks, alt_reports)
    except OrthoglideError as exc:
        sampled_error = exc
    head = (f"current_sampling: auto on {which} (no tag, steps up to {1e3 * step:.3g} ms, no "
            "lag to tell by): read")
    if held is None and sampled is None:
        raise held_error
    if sampled is None:
        return held, reports, f"{head} held, sampled is refused ({str(sampled_error)[:80]}...)"
    if held is None:
        return sampled, alt_reports, f"{head} sampled, held is refused ({str(held_error)[:80]}...)"
    rh = np.asarray(held[3].result.residual_rms, float)
    rs = np.asarray(sampled[3].result.residual_rms, float)
    ok = np.isfinite(rh) & np.isfinite(rs) & (rh > 0) & (rs > 0)
    ratio = float(np.exp(np.mean(np.log(rs[ok] / rh[ok])))) if ok.any() else 1.0
    pick = "sampled" if ratio < RESIDUAL_MARGIN else "held"
    line = (f"{head} {pick}: the residual read as sampled is {ratio:.3g} x held's (geometric "
            f"mean over the joints; sampled below {RESIDUAL_MARGIN:g})")
    return (sampled, alt_reports, line) if pick == "sampled" else (held, reports, line)
