"""What a design writes beside the coefficients (``design``, ``limits``, ``margins``,
``prediction`` keys of the trajectory file) and prints for people: the σ each gain and base
parameter will have, and the duration and payload that reach a target σ."""
from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from orthoglide_ident.excite.check import locked_values
from orthoglide_ident.excite.design import COND_WEIGHT, Design, payload_options
from orthoglide_ident.excite.prediction import periods_needed

PAYLOAD_FACTORS = (0.5, 1.0, 2.0, 4.0)  # payloads the prediction is also given for


def payload_table(d: Design) -> list[dict[str, Any]]:
    """Per payload mass the effort limits allow on the designed motion: the worst gain σ at the
    designed duration and the duration per run that reaches the target."""
    opt = d.problem.opt
    out = []
    for m, pred in payload_options(d.problem, d.trajectory,
                                   [f * opt.payload.mass for f in PAYLOAD_FACTORS]):
        if pred is None:
            out.append({"payload_kg": m, "feasible": False})
            continue
        k = periods_needed(pred, opt.periods, opt.target)
        out.append({"payload_kg": m, "feasible": True,
                    "worst_gain_rel_std": pred.worst_determined_gain(),
                    "seconds_per_run_for_target": k * opt.period_s})
    return out


def sentence(seconds: float, mass: float, worst: float, target: float,
             every: str = "every gain") -> str:
    return (f"{seconds:g} s unloaded + {seconds:g} s with {mass:g} kg gives {every} "
            f"≤ {100 * max(worst, target):.3g} %")


def prediction_dict(d: Design, noise_source: str) -> dict[str, Any]:
    opt, pred, traj = d.problem.opt, d.prediction, d.trajectory
    robot = d.problem.robot
    k = periods_needed(pred, opt.periods, opt.target)
    doc = pred.to_dict(robot.joint_names, robot.names)
    doc.update({
        "noise_source": noise_source,
        "seconds_per_run": traj.duration,
        "payload_kg": opt.payload.mass,
        "target_gain_rel_std": opt.target,
        "seconds_per_run_for_target": k * opt.period_s,
        "for_target": sentence(k * opt.period_s, opt.payload.mass,
                               pred.worst_determined_gain() * math.sqrt(opt.periods / k),
                               opt.target, "every determined gain"
                               if pred.undetermined_gains.any() else "every gain"),
        "payloads": payload_table(d),
    })
    return doc


def extras(d: Design, limits, collision, noise_source: str) -> dict[str, Any]:
    """The trajectory file's ``design``, ``limits``, ``locked_joints`` (if any), ``margins`` and
    ``prediction`` keys."""
    opt = d.problem.opt
    rand = [e.criterion for e in d.random]
    locked = locked_values(d.problem.robot)
    return {
        "design": {"seed": opt.seed, "harmonics": opt.harmonics, "restarts": opt.restarts,
                   "steps": opt.steps, "search": opt.search, "samples_per_period": opt.samples,
                   "start_pose": d.problem.P.tolist(),
                   "criterion": f"log max_j σ(g_j)/g_j + {COND_WEIGHT:g} log κ",
                   "criterion_value": d.criterion,
                   "random_feasible_median": float(np.median(rand)) if rand else None,
                   "seconds": round(d.seconds, 2)},
        "limits": {**limits.to_dict(), "collision": collision.describe()},
        # joints the robot file fixes (their bodies' efforts and collisions are at these values)
        **({"locked_joints": locked} if locked else {}),
        "margins": {"required": opt.margins.to_dict(), "worst": d.check.to_dict()},
        "prediction": prediction_dict(d, noise_source),
    }


def with_extras(d: Design, limits, collision, noise_source: str):
    """The designed trajectory with its extras (the file's full content)."""
    return dataclasses.replace(d.trajectory, extra=extras(d, limits, collision, noise_source))


def prediction_text(pred_doc: dict[str, Any]) -> str:
    lines = [f"prediction ({pred_doc['seconds_per_run']:g} s per run, current noise "
             + ", ".join(f"{j} {v:.3g}" for j, v in pred_doc["current_noise_a"].items())
             + f" A, {pred_doc['noise_source']}):",
             "  gain σ: " + ", ".join(f"{j} {100 * v:.3g} %" if v is not None else
                                      f"{j} not determined"
                                      for j, v in pred_doc["gain_rel_std"].items()),
             f"  condition number κ {pred_doc['condition_number'] or math.inf:.4g}"
             + (f" (of the directions excited: {pred_doc['condition_number_excited']:.4g})"
                if pred_doc.get("not_excited") else "")]
    lines += [f"  not excited: {u}" for u in pred_doc.get("not_excited", [])]
    lines.append(f"  for every determined gain ≤ {100 * pred_doc['target_gain_rel_std']:.3g} %: "
                 + pred_doc["for_target"])
    for row in pred_doc["payloads"]:
        if row["feasible"]:
            lines.append(f"  with {row['payload_kg']:g} kg: worst gain σ "
                         f"{100 * row['worst_gain_rel_std']:.3g} %, "
                         f"{row['seconds_per_run_for_target']:g} s per run for the target")
        else:
            lines.append(
                f"  with {row['payload_kg']:g} kg: beyond the effort limits on this motion"
            )
    return "\n".join(lines)

