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

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from orthoglide_ident.errors import OrthoglideError
from orthoglide_ident.results import LagEstimate

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
# a sampled current acts half its loop's tick after the stamp: with that loop's rate unknown on a
# slow log, the half tick is fitted among these (loops of 4, 2, 1 kHz and 500 Hz) by the residual,
# kept when below SHIFT_MARGIN x the stamp's (measured on the ~250 Hz UR5 log of a 1 kHz loop:
# 0.92 / 0.87 / 0.87 at 0.25 / 0.5 / 1 ms, wrist_2 4.5 σ -> 1.2 σ at 0.5 ms)
LOOP_HALF_TICKS_S = (1.25e-4, 2.5e-4, 5.0e-4, 1.0e-3)
SHIFT_MARGIN = 0.995
# said with a refusal of a slow log read as sampled: what a point-sampled log cannot undo
ALIASED = ("or, a current point-sampled from a faster loop, that loop's content above the "
           "log's Nyquist frequency aliased into the band as noise: log the current averaged "
           "over each step (then it is held) or at the loop's own rate")
NEGATIVE_LAG_SIGMAS = 3.0  # τ below -this x its σ on most joints: no current loop leads


def robot_file_sampling(model: Any) -> str | None:
    """The robot file's ``current_sampling`` (held | sampled), None when it says nothing."""
    for m in (model, model.joint_model):  # behind a transmission, the joints' file
        desc = None if m is None else m.description
        if desc is not None and desc.current_sampling is not None:
            return desc.current_sampling
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
        return opts.replace(zoh_shift=False, current_sampling=sampling)
    return opts.replace(current_sampling=sampling)


def sampled_shift_s(opts) -> float:
    """Where a sampled current acts after its stamp, s: the loop that made it holds it over
    its own tick, so at the middle of that tick, 1 / (2 current_loop_hz); 0 when that rate is
    not known (the states at the stamp) or the current is held (zoh_shift)."""
    if opts.observe.zoh_shift or not opts.input.current_loop_hz > 0:
        return 0.0
    return 0.5 / opts.input.current_loop_hz


def lag_says_sampled(current_lag: Sequence[LagEstimate]) -> str | None:
    """Why the identified lags (``IdentificationResult.current_lag``, τ in ms) say the current
    is a point sample at the stamp, or None: a current loop cannot act before its reference,
    so τ below -NEGATIVE_LAG_SIGMAS σ on more than half the joints is a current read as held
    that was sampled (the states half a step late)."""
    neg = [x for x in current_lag
           if x.tau_ms < -NEGATIVE_LAG_SIGMAS * max(x.tau_std_ms, 1e-9)]
    if not current_lag or 2 * len(neg) <= len(current_lag):
        return None
    taus = ", ".join(f"{x.tau_ms:+.3f}" for x in current_lag)
    return (f"the identified current-loop lag is negative on {len(neg)} of {len(current_lag)} "
            f"joints ({taus} ms), impossible for a current held over its step: read as sampled "
            "at the stamps (current_sampling: auto)")


def loop_half_ticks(step_s: float, loop_hz: float) -> tuple[float, ...]:
    """Where a sampled current may act after its stamp, s: the known loop's half tick, else
    LOOP_HALF_TICKS_S below half the log step (the loop is faster than the log)."""
    if loop_hz > 0:
        return (0.5 / loop_hz,)
    return tuple(d for d in LOOP_HALF_TICKS_S if d < 0.5 * step_s)


def _residual_ratio(a, b) -> float:
    """Geometric mean over the joints of the residual rms of solve ``a`` over ``b``'s."""
    ra = np.asarray(a.result.residual_rms, float)
    rb = np.asarray(b.result.residual_rms, float)
    ok = np.isfinite(ra) & np.isfinite(rb) & (ra > 0) & (rb > 0)
    return float(np.exp(np.mean(np.log(ra[ok] / rb[ok])))) if ok.any() else 1.0


def best_reading(solve_rows: Callable, blocks: list, reports: list, alts: list
                 ) -> tuple[Any, list, str]:
    """Slow logs whose reading is open (``alts[i]``: record i's other readings, a list of
    (half tick s, rows, report) read as sampled, or None): every reading solved by
    ``solve_rows(blocks, reports)``. The first reading is auto's held (then sampled is kept
    when its best residual is below RESIDUAL_MARGIN x held's, or when held is refused) or
    sampled at the stamp with the loop's rate unknown (then the half tick whose residual is
    least, below SHIFT_MARGIN x the stamp's). All refused: the first one's error. Returns
    (what solve_rows returned, the reports, one line why)."""
    which = [i for i, a in enumerate(alts) if a]
    names = ", ".join(reports[i].bag for i in which)
    step = max(reports[i].period_s for i in which)
    held = reports[which[0]].current_sampling == "held"
    tries = [(None, blocks, reports)] + [
        (alts[which[0]][j][0], [b if not a else a[j][1] for a, b in zip(alts, blocks)],
         [r if not a else a[j][2] for a, r in zip(alts, reports)])
        for j in range(len(alts[which[0]]))]
    out, first_error = [], None
    for shift, b, r in tries:
        try:
            out.append((shift, solve_rows(b, r), r))
        except OrthoglideError as exc:
            first_error = first_error or exc
    if not out:
        raise first_error
    main = out[0] if out[0][0] is None else None
    ref = (main or out[0])[1][3]
    shifts = [x for x in out if x[0] is not None]
    best = min(shifts, key=lambda x: _residual_ratio(x[1][3], ref)) if shifts else None
    head = (f"current_sampling: auto on {names} (no tag, steps up to {1e3 * step:.3g} ms, no "
            "lag to tell by): read" if held else
            f"{names}: current sampled at steps up to {1e3 * step:.3g} ms, its loop's rate "
            "unknown (current_loop_hz 0):")
    tick = "" if best is None else (" at the stamp" if best[0] == 0 else
                                    f" {1e3 * best[0]:.3g} ms after the stamp")
    if main is None:
        return best[1], best[2], (f"{head} sampled{tick} (held is refused: "
                                  f"{str(first_error)[:80]}...)" if held else
                                  f"{head} read{tick} (at the stamp it is refused)")
    if best is None:
        return main[1], main[2], (f"{head} held, sampled is refused ({str(first_error)[:80]}...)"
                                  if held else f"{head} read at the stamp")
    ratio = _residual_ratio(best[1][3], ref)
    margin = RESIDUAL_MARGIN if held else SHIFT_MARGIN
    what = "held's" if held else "at the stamp"
    if ratio < margin:
        return best[1], best[2], (f"{head} {'sampled' if held else 'read'}{tick}: its residual "
                                  f"is {ratio:.3g} x {what} (geometric mean over the joints; "
                                  f"below {margin:g} wins)")
    return main[1], main[2], (f"{head} {'held' if held else 'read at the stamp'}: the best "
                              f"other reading's residual ({tick.strip()}) is {ratio:.3g} x "
                              f"{what} (below {margin:g} wins)")
