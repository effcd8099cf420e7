"""The JSON channels of the Foxglove view: a JSON schema and a message builder per topic.

Channels are named after the ROS topics they show (``/orthoglide/joint_states`` ...); the view's
own series are ``orthoglide/forces`` (measured vs model force, live) and, in a report's MCAP,
``orthoglide/report/forces`` and ``orthoglide/report/convergence``. Conventions a browser needs:

- stamps are ``{sec, nanosec}`` (int64 nanoseconds lose precision in JavaScript's doubles);
- every number a plot wants is a field of its own: a gain, its σ (N/A) and gain ± σ, so that a
  Plot panel draws the band without arithmetic; arrays follow the message's joint order, with
  the joint names beside them (any robot, any number of joints);
- non-finite numbers are sent as null (NaN and Infinity are not JSON); the schemas still say
  "number" (Foxglove's JSON-schema parser takes one type per field), and a plot skips the nulls.

Builders take the fields of the ROS message (``msg.get_fields_and_field_types()`` names, or the
core's ``message_fields()`` dicts) and return plain dicts; nothing here imports rclpy.
"""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

JOINT_STATES = "orthoglide/joint_states"
CURRENT_REFERENCE = "orthoglide/current_reference"
SETPOINTS = "orthoglide/setpoints"
LIVE = "orthoglide/identification/live"
RECORDER_STATUS = "orthoglide/recorder/status"
IDENTIFIED = "orthoglide/identified_parameters"
FORCES = "orthoglide/forces"  # the viewer's: measured g_τ v_τ vs the identified model, live
REPORT_FORCES = "orthoglide/report/forces"  # a report's: the same, over its validation record
REPORT_CONVERGENCE = "orthoglide/report/convergence"  # a report's: the gains as records accumulate

# A number, or null for NaN and ±inf. Only single types: Foxglove's JSON-schema parser (mcap-support
# parseJsonSchema) refuses a type list such as ["number", "null"], and the channel with it.
_NUMBER = {"type": "number", "description": "null when not finite"}
_NUMBERS = {"type": "array", "items": _NUMBER}
_STRINGS = {"type": "array", "items": {"type": "string"}}
_TIME = {"type": "object", "title": "builtin_interfaces/Time",
         "properties": {"sec": {"type": "integer"}, "nanosec": {"type": "integer"}},
         "required": ["sec", "nanosec"]}
_HEADER = {"type": "object", "properties": {"stamp": _TIME}, "required": ["stamp"]}
_GAIN = {
    "type": "object",
    "description": "one drive gain: value, σ and value ± σ in N/A (N·m/A for a revolute joint), %σ",
    "properties": {
        "joint": {"type": "string"},
        "value": _NUMBER,
        "sigma": _NUMBER,
        "low": _NUMBER,
        "high": _NUMBER,
        "rel_std_percent": _NUMBER,
    },
}
_GAINS = {"type": "array", "items": _GAIN}


def _schema(title: str, description: str, properties: dict[str, Any]) -> dict[str, Any]:
    return {"type": "object", "title": title, "description": description,
            "properties": {"header": _HEADER, **properties}}


SCHEMAS: dict[str, dict[str, Any]] = {
    JOINT_STATES: _schema(
        "orthoglide_view/JointPositions",
        "joint positions (m or rad), one message per decimation period",
        {"name": _STRINGS, "position": _NUMBERS},
    ),
    CURRENT_REFERENCE: _schema(
        "orthoglide_view/Currents",
        "current references v_tau (A)",
        {"name": _STRINGS, "current": _NUMBERS},
    ),
    SETPOINTS: _schema(
        "orthoglide_view/Setpoints",
        "the reference q_d, qd_d, qdd_d the controller tracks",
        {"name": _STRINGS, "position": _NUMBERS, "velocity": _NUMBERS, "acceleration": _NUMBERS},
    ),
    LIVE: _schema(
        "orthoglide_view/LiveIdentification",
        "the running IDIM-TLS estimate: gains ± σ, status and warnings as text",
        {
            "status": {"type": "string"},
            "enough_data": {"type": "boolean"},
            "gains": _GAINS,
            "unloaded_seconds": _NUMBER,
            "loaded_seconds": _NUMBER,
            "singular_ratio": _NUMBER,
            "condition_number": _NUMBER,
            "residual_rms": _NUMBERS,
            "lag": _NUMBER,
            "warnings": {"type": "string", "description": "the warnings, joined by ' | '"},
            "warning_list": _STRINGS,
        },
    ),
    RECORDER_STATUS: _schema(
        "orthoglide_view/RecorderStatus",
        "the recorder's state",
        {
            "recording": {"type": "boolean"},
            "condition": {"type": "string"},
            "payload_mass": _NUMBER,
            "bag_path": {"type": "string"},
            "ticks_written": {"type": "integer"},
            "ticks_missing": {"type": "integer"},
            "first_tick": _TIME,
            "last_tick": _TIME,
            "message": {"type": "string"},
            "summary": {"type": "string"},
        },
    ),
    IDENTIFIED: _schema(
        "orthoglide_view/IdentifiedParameters",
        "the last IDIM-TLS result: gains ± σ, base parameters with %σ",
        {
            "method": {"type": "string"},
            "gains": _GAINS,
            "payload_mass": _NUMBER,
            "residual_rms": _NUMBER,
            "condition_number": _NUMBER,
            "parameters": {
                "type": "array",
                "items": {
                    "type": "object",
                    "properties": {
                        "name": {"type": "string"},
                        "value": _NUMBER,
                        "rel_std_percent": _NUMBER,
                    },
                },
            },
            "source_bags": _STRINGS,
            "summary": {"type": "string"},
        },
    ),
}
_FORCES = _schema(
    "orthoglide_view/Forces",
    "measured force g_tau v_tau against the identified model's "
    "W chi + W_kl m_7 per joint (per motor for a robot with a transmission), and their "
    "difference (N or N·m), means over the period",
    {
        "name": _STRINGS,
        "measured": _NUMBERS,
        "model": _NUMBERS,
        "residual": _NUMBERS,
        "ticks": {"type": "integer", "description": "controller ticks averaged"},
        "joint_name": {**_STRINGS, "description": "a transmission's joints (else empty)"},
        "joint_residual": {
            **_NUMBERS,
            "description": "the joints' residual N^T (measured - "
            "model), N·m or N (a transmission's; else empty)",
        },
    },
)
SCHEMAS[FORCES] = _FORCES
SCHEMAS[REPORT_FORCES] = _FORCES
SCHEMAS[REPORT_CONVERGENCE] = _schema(
    "orthoglide_view/GainConvergence",
    "IDIM-TLS on the first seconds of every record: the drive gains ± σ as the data accumulate",
    {"seconds": _NUMBER, "unloaded_seconds": _NUMBER, "loaded_seconds": _NUMBER, "gains": _GAINS},
)


def num(x: Any) -> float | None:
    """A JSON number: None for NaN and ±inf."""
    x = float(x)
    return x if math.isfinite(x) else None


def nums(xs: Sequence[Any]) -> list[float | None]:
    return [num(x) for x in xs]


def stamp(ns: int) -> dict[str, int]:
    """``{sec, nanosec}`` of a time in integer nanoseconds."""
    sec, nanosec = divmod(int(ns), 1_000_000_000)
    return {"sec": sec, "nanosec": nanosec}


def header(ns: int) -> dict[str, Any]:
    return {"stamp": stamp(ns)}


def gains(
    joints: Sequence[str], values: Sequence[float], rel_std: Sequence[float]
) -> list[dict[str, Any]]:
    """One object per joint: value, σ = value·rel_std, value ± σ (N/A), %σ. A relative std < 0
    (unknown, the messages' convention) gives null σ."""
    out = []
    for j, g, r in zip(joints, values, list(rel_std) + [math.nan] * (len(values) - len(rel_std))):
        g, r = float(g), float(r)
        s = abs(g) * r if r >= 0 else math.nan
        out.append({"joint": str(j), "value": num(g), "sigma": num(s), "low": num(g - s),
                    "high": num(g + s), "rel_std_percent": num(100.0 * r if r >= 0 else math.nan)})
    return out


def joint_values(ns: int, names: Sequence[str], **arrays: Sequence[float]) -> dict[str, Any]:
    """Joint states, currents, setpoints: ``name`` and each array in the message's joint order."""
    return {
        "header": header(ns),
        "name": [str(n) for n in names],
        **{k: nums(v) for k, v in arrays.items()},
    }


def live(ns: int, f: Mapping[str, Any]) -> dict[str, Any]:
    """orthoglide_msgs/LiveIdentification fields -> the live channel."""
    warnings = [str(w) for w in f.get("warnings", ())]
    return {
        "header": header(ns),
        "status": str(f["status"]),
        "enough_data": bool(f["enough_data"]),
        "gains": gains(f["joint_names"], f["drive_gains"], f["drive_gains_rel_std"]),
        "unloaded_seconds": num(f["unloaded_seconds"]),
        "loaded_seconds": num(f["loaded_seconds"]),
        "singular_ratio": num(f["singular_ratio"]),
        "condition_number": num(f["condition_number"]),
        "residual_rms": nums(f["residual_rms"]),
        "lag": num(f["lag"]),
        "warnings": " | ".join(warnings),
        "warning_list": warnings,
    }


def _time_ns(t: Any) -> int:
    return int(t.sec) * 1_000_000_000 + int(t.nanosec)


def recorder_status(ns: int, f: Mapping[str, Any]) -> dict[str, Any]:
    """orthoglide_msgs/RecorderStatus fields -> the status channel, with a one-line summary."""
    state = (f"recording {f['condition']} ({float(f['payload_mass']):g} kg)" if f["recording"]
             else "idle")
    summary = (f"{state}: {f['bag_path'] or '-'}, {int(f['ticks_written'])} ticks written, "
               f"{int(f['ticks_missing'])} missing — {f['message']}")
    return {
        "header": header(ns),
        "recording": bool(f["recording"]),
        "condition": str(f["condition"]),
        "payload_mass": num(f["payload_mass"]),
        "bag_path": str(f["bag_path"]),
        "ticks_written": int(f["ticks_written"]),
        "ticks_missing": int(f["ticks_missing"]),
        "first_tick": stamp(_time_ns(f["first_tick"])),
        "last_tick": stamp(_time_ns(f["last_tick"])),
        "message": str(f["message"]),
        "summary": summary,
    }


def identified(ns: int, f: Mapping[str, Any]) -> dict[str, Any]:
    """orthoglide_msgs/IdentifiedParameters fields (or
    ``IdentificationResult.message_fields()``)."""
    g = gains(f["joint_names"], f["drive_gains"], f["drive_gains_rel_std"])
    summary = f"{f['method']}: " + ", ".join(
        f"{x['joint']} {x['value']:.1f} ± {x['sigma'] or 0:.2g}"
        for x in g
        if x["value"] is not None
    )
    params = [{"name": str(n), "value": num(v), "rel_std_percent": num(100 * r) if r >= 0 else None}
              for n, v, r in zip(f["names"], f["values"], f["rel_std"])]
    return {"header": header(ns), "method": str(f["method"]), "gains": g,
            "payload_mass": num(f["payload_mass"]), "residual_rms": num(f["residual_rms"]),
            "condition_number": num(f["condition_number"]), "parameters": params,
            "source_bags": [str(b) for b in f["source_bags"]], "summary": summary}


def forces(ns: int, names: Sequence[str], measured: Sequence[float], model: Sequence[float],
           ticks: int, joint_names: Sequence[str] = (),
           joint_residual: Sequence[float] = ()) -> dict[str, Any]:
    """Measured and model force per joint (N or N·m) and the residual measured − model; for a
    robot with a transmission ``names`` are its motors and ``joint_residual`` the joints'
    Nᵀ (measured − model) under ``joint_names``."""
    residual = [m - p for m, p in zip(measured, model)]
    return {"header": header(ns), "name": [str(n) for n in names], "measured": nums(measured),
            "model": nums(model), "residual": nums(residual), "ticks": int(ticks),
            "joint_name": [str(n) for n in joint_names], "joint_residual": nums(joint_residual)}


def convergence(ns: int, seconds: float, unloaded_s: float, loaded_s: float, joints: Sequence[str],
                values: Sequence[float], rel_std: Sequence[float]) -> dict[str, Any]:
    return {"header": header(ns), "seconds": num(seconds), "unloaded_seconds": num(unloaded_s),
            "loaded_seconds": num(loaded_s), "gains": gains(joints, values, rel_std)}
