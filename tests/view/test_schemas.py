"""The view's JSON channels: messages that match their schemas, plottable numbers, browser-safe
stamps; stamp decimation; the Foxglove layout refers only to fields that exist."""
from __future__ import annotations

import json
import math
import re
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from orthoglide_ident.view import schemas
from orthoglide_ident.view.decimate import StampDecimator, cdr_stamps

ROOT = Path(__file__).resolve().parents[2]
_TYPES = {
    "object": dict,
    "array": list,
    "string": str,
    "boolean": bool,
    "integer": int,
    "number": (int, float),
    "null": type(None),
}


def conforms(value, schema: dict, where: str = "$") -> None:
    """A small JSON-schema check (type, properties, required, items): enough for these schemas."""
    types = schema.get("type", [])
    types = [types] if isinstance(types, str) else types
    if types:
        ok = any(
            isinstance(value, _TYPES[t])
            and not (t in ("integer", "number") and isinstance(value, bool))
            for t in types
        ) or (value is None and "number" in types)  # null: a non-finite number
        assert ok, f"{where}: {value!r} is not {types}"
    if isinstance(value, dict):
        for key in schema.get("required", []):
            assert key in value, f"{where}: {key} missing"
        for key, sub in schema.get("properties", {}).items():
            if key in value:
                conforms(value[key], sub, f"{where}.{key}")
        assert set(value) <= set(schema.get("properties", value)), (
            f"{where}: fields beyond the schema"
        )
    if isinstance(value, list) and "items" in schema:
        for i, item in enumerate(value):
            conforms(item, schema["items"], f"{where}[{i}]")


def _time(ns):
    return SimpleNamespace(sec=ns // 10**9, nanosec=ns % 10**9)


STAMP = 1_796_221_347_705_600_829  # ns: more digits than a double holds


def _messages() -> dict[str, dict]:
    live = {
        "status": "gains known to 0.14 %",
        "enough_data": True,
        "joint_names": ["q11", "q12", "q13"],
        "drive_gains": [2170.0, 2100.0, 2070.0],
        "drive_gains_rel_std": [0.0014, 0.0011, 0.0008],
        "unloaded_seconds": 15.0,
        "loaded_seconds": 9.0,
        "singular_ratio": 0.01,
        "condition_number": math.inf,
        "residual_rms": [0.5, 0.4, 0.3],
        "lag": 0.9,
        "warnings": ["lost 3 ticks", "NaN dropped"],
    }
    status = {
        "recording": True,
        "condition": "loaded",
        "payload_mass": 1.983,
        "bag_path": "bags/loaded_1",
        "ticks_written": 14415,
        "ticks_missing": 2,
        "first_tick": _time(STAMP),
        "last_tick": _time(STAMP),
        "message": "recording loaded",
    }
    ident = {
        "method": "tls",
        "joint_names": ["q11", "q12", "q13"],
        "drive_gains": [2176.8, 2100.3, 2064.0],
        "drive_gains_rel_std": [0.0014, 0.0011, 0.0008],
        "names": ["m_6R", "fv_1R"],
        "values": [1.2, 80.0],
        "rel_std": [0.01, -1.0],
        "payload_mass": 1.983,
        "residual_rms": 0.53,
        "condition_number": 2.6e4,
        "source_bags": ["live"],
    }
    return {
        schemas.JOINT_STATES: schemas.joint_values(
            STAMP, ["q11", "q12", "q13"], position=[0.01, 0.02, math.nan]
        ),
        schemas.CURRENT_REFERENCE: schemas.joint_values(STAMP, ["a", "b"], current=[0.1, -0.2]),
        schemas.SETPOINTS: schemas.joint_values(
            STAMP, ["q11"], position=[0.0], velocity=[0.1], acceleration=[2.0]
        ),
        schemas.LIVE: schemas.live(STAMP, live),
        schemas.RECORDER_STATUS: schemas.recorder_status(STAMP, status),
        schemas.IDENTIFIED: schemas.identified(STAMP, ident),
        schemas.FORCES: schemas.forces(STAMP, ["q11", "q12"], [10.0, 20.0], [9.5, 21.0], 20),
        schemas.REPORT_CONVERGENCE: schemas.convergence(
            STAMP, 5.0, 5.0, 5.0, ["q11"], [2170.0], [0.002]
        ),
    }


@pytest.mark.parametrize("kind", list(_messages()))
def test_every_message_matches_its_schema_and_is_strict_json(kind):
    msg = _messages()[kind]
    conforms(msg, schemas.SCHEMAS[kind])
    json.dumps(msg, allow_nan=False)  # NaN/inf would break a browser's JSON.parse
    assert msg["header"]["stamp"] == {"sec": STAMP // 10**9, "nanosec": STAMP % 10**9}


def test_gains_carry_sigma_and_the_band_as_numbers():
    live = _messages()[schemas.LIVE]
    g = live["gains"][0]
    assert g["joint"] == "q11" and g["value"] == 2170.0
    assert g["sigma"] == pytest.approx(2170.0 * 0.0014) and g["rel_std_percent"] == pytest.approx(
        0.14
    )
    assert g["low"] == pytest.approx(2170.0 - g["sigma"]) and g["high"] == pytest.approx(
        2170.0 + g["sigma"]
    )
    assert live["warnings"] == "lost 3 ticks | NaN dropped" and live["condition_number"] is None
    assert _messages()[schemas.JOINT_STATES]["position"][2] is None
    params = _messages()[schemas.IDENTIFIED]["parameters"]
    assert params[1]["rel_std_percent"] is None  # -1: undefined in the message
    forces = _messages()[schemas.FORCES]
    assert forces["residual"] == [0.5, -1.0]
    empty = schemas.live(
        STAMP, {**_messages_live_fields(), "drive_gains": [], "drive_gains_rel_std": []}
    )
    assert empty["gains"] == []  # not solvable yet


def _messages_live_fields():
    return {
        "status": "collecting",
        "enough_data": False,
        "joint_names": ["q11"],
        "drive_gains": [],
        "drive_gains_rel_std": [],
        "unloaded_seconds": 0.0,
        "loaded_seconds": 0.0,
        "singular_ratio": math.nan,
        "condition_number": math.nan,
        "residual_rms": [],
        "lag": 0.0,
        "warnings": [],
    }


def test_decimation_keeps_the_first_message_of_each_period_whatever_the_batches():
    stamps = 1_000_000_000 + np.arange(1000) * 1_000_000  # 1 kHz for 1 s
    expected = np.flatnonzero(stamps % 20_000_000 == 0)
    for batch in (1, 7, 100, 1000):
        d = StampDecimator(20_000_000)
        got = np.concatenate(
            [a + d.pick(stamps[a : a + batch]) for a in range(0, len(stamps), batch)]
        )
        np.testing.assert_array_equal(got, expected)
    d = StampDecimator(20_000_000)
    d.pick(stamps[:500])
    assert d.pick(stamps[100:200]).size == 0  # late or repeated stamps: not sent again


def test_cdr_stamps_reads_the_header_of_serialized_messages():
    from rclpy.serialization import serialize_message

    from orthoglide_msgs.msg import JointSetpoint

    raw = []
    for ns in (STAMP, 5, 2**31 * 10**9 - 1):
        m = JointSetpoint(name=["q11"], position=[0.0], velocity=[0.0], acceleration=[0.0])
        m.header.stamp.sec, m.header.stamp.nanosec = divmod(ns, 10**9)
        raw.append(serialize_message(m))
    assert cdr_stamps(raw).tolist() == [STAMP, 5, 2**31 * 10**9 - 1]


_FOXGLOVE_TYPES = ("boolean", "string", "number", "integer", "object", "array")


def foxglove_parses(schema: dict, where: str) -> None:
    """What Foxglove's JSON-schema parser (mcap-support parseJsonSchema) accepts, or it refuses the
    channel: an object whose every property has one type of _FOXGLOVE_TYPES, arrays of those but
    arrays, strings without a contentEncoding other than base64 (none here)."""
    assert schema.get("type") == "object", where
    for name, prop in schema["properties"].items():
        assert isinstance(prop.get("type"), str) and prop["type"] in _FOXGLOVE_TYPES, (
            where,
            name,
            prop,
        )
        if prop["type"] == "object":
            foxglove_parses(prop, f"{where}.{name}")
        if prop["type"] == "array":
            item = prop["items"]
            assert isinstance(item.get("type"), str) and item["type"] in _FOXGLOVE_TYPES[:-1], (
                where,
                name,
            )
            if item["type"] == "object":
                foxglove_parses(item, f"{where}.{name}[]")


@pytest.mark.parametrize("kind", list(schemas.SCHEMAS))
def test_every_schema_is_one_foxglove_can_parse(kind):
    foxglove_parses(schemas.SCHEMAS[kind], kind)


def _field(schema: dict, path: str) -> dict:
    """The sub-schema at a Foxglove message path like ``gains[0].value``."""
    for part in re.findall(r"[A-Za-z_]+|\[\d+\]", path):
        schema = schema["items"] if part.startswith("[") else schema["properties"][part]
    return schema


def test_the_layout_plots_fields_that_exist():
    layout = json.loads((ROOT / "resource" / "orthoglide_layout.json").read_text())
    topics = {"/" + k: v for k, v in schemas.SCHEMAS.items()}
    panels = layout["configById"]
    seen = set()
    for pid, cfg in panels.items():
        paths = [p["value"] for p in cfg.get("paths", [])] + (
            [cfg["topicPath"]] if "topicPath" in cfg else []
        )
        for value in paths:
            topic, _, path = value.partition(".")
            assert topic in topics, (pid, value)
            leaf = _field(topics[topic], path) if path else topics[topic]
            if pid.startswith("Plot!"):
                assert "number" in leaf["type"], (pid, value)  # something a plot can draw
            seen.add(topic)
    # gains ± σ, measured vs model force (live and report), positions, currents, status: one view
    assert {
        "/orthoglide/identification/live",
        "/orthoglide/report/convergence",
        "/orthoglide/forces",
        "/orthoglide/report/forces",
        "/orthoglide/joint_states",
        "/orthoglide/current_reference",
        "/orthoglide/recorder/status",
        "/orthoglide/identified_parameters",
    } <= seen

    def leaves(node):
        return [node] if isinstance(node, str) else leaves(node["first"]) + leaves(node["second"])

    assert sorted(leaves(layout["layout"])) == sorted(panels)  # every panel placed, none twice
