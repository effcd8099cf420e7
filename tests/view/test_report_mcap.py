"""``report --mcap``: the identification's plots as an MCAP file, read back with the mcap
library."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader

from orthoglide_ident.cli import main
from orthoglide_ident.identify import identify
from orthoglide_ident.model.registry import load_robot
from orthoglide_ident.report import validation_for_plot
from orthoglide_ident.view.convergence import gain_convergence, record_seconds
from orthoglide_ident.view.report_mcap import write_report_mcap

ORTHOGLIDE = load_robot("orthoglide")  # the robot these records are of

ROOT = Path(__file__).resolve().parents[2]
# the simulator's, 10 s each
BAGS = [str(ROOT / "bags" / "unloaded"), str(ROOT / "bags" / "loaded")]


@pytest.fixture(scope="module")
def result():
    return identify(BAGS, model=ORTHOGLIDE)


def _read(path: Path):
    with open(path, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        messages: dict[str, list] = {}
        times: list[int] = []
        for _schema, channel, message in reader.iter_messages(log_time_order=False):
            messages.setdefault(channel.topic, []).append(json.loads(message.data))
            times.append(message.log_time)
        meta = {m.name: m.metadata for m in reader.iter_metadata()}
    return summary, messages, times, meta


def test_the_mcap_holds_forces_residual_and_convergence_with_json_schemas(result, tmp_path):
    path = write_report_mcap(result, tmp_path / "report.mcap")
    summary, messages, times, meta = _read(path)
    topics = {c.topic: (summary.schemas[c.schema_id], c) for c in summary.channels.values()}
    assert set(topics) == {"/orthoglide/report/forces", "/orthoglide/report/convergence",
                           "/orthoglide/identified_parameters"}
    for schema, channel in topics.values():  # what Foxglove needs to decode and name the fields
        assert schema.encoding == "jsonschema" and channel.message_encoding == "json"
        assert json.loads(schema.data)["type"] == "object"
    counts = {
        topics[t][1].topic: n
        for t, n in (
            (summary.channels[i].topic, n)
            for i, n in summary.statistics.channel_message_counts.items()
        )
    }
    val, crossed = validation_for_plot(result)
    assert not crossed  # no validation bag: the last identification record, as torques.png
    assert counts["/orthoglide/report/forces"] == val.t.shape[0]  # every decimated row
    assert counts["/orthoglide/identified_parameters"] == 1
    longest = max(record_seconds(o) for o in result.observations)
    assert 10 <= counts["/orthoglide/report/convergence"] <= int(longest / 0.5) + 1
    assert times == sorted(times)  # log times non-decreasing through the file
    assert "bags/loaded" in meta["orthoglide_report"]["forces_record"]

    forces = messages["/orthoglide/report/forces"]
    k = len(forces) // 2
    np.testing.assert_allclose(forces[k]["measured"], val.tau_measured[:, k])
    np.testing.assert_allclose(forces[k]["residual"], val.tau_measured[:, k] - val.tau_model[:, k])
    resid = np.array([m["residual"] for m in forces]).T
    # the rows the identification used (not at velocity reversals)
    keep = result.observations[-1].keep
    rms = [np.sqrt(np.mean(r[k] ** 2)) for r, k in zip(resid, keep)]
    # the figure in torques.png's titles
    np.testing.assert_allclose(rms, val.residual_rms, rtol=1e-9)


def test_the_convergence_ends_on_the_identified_gains(result, tmp_path):
    """The last point is TLS on every equation: the result's gains and σ (no ripple was added on
    these records), and the σ shrinks as the records get longer."""
    assert not result.ripple
    _, messages, _, _ = _read(write_report_mcap(result, tmp_path / "report.mcap"))
    conv = messages["/orthoglide/report/convergence"]
    last = conv[-1]["gains"]
    for g, est in zip(last, result.drive_gains):
        assert g["joint"] == est.name
        assert g["value"] == pytest.approx(est.value, rel=1e-9)
        assert g["rel_std_percent"] == pytest.approx(100 * est.rel_std, rel=1e-6)
        assert g["low"] < g["value"] < g["high"]
    first = conv[0]["gains"]
    assert all(a["sigma"] > b["sigma"] for a, b in zip(first, last))
    assert conv[0]["seconds"] < conv[-1]["seconds"]
    assert conv[-1]["loaded_seconds"] == pytest.approx(record_seconds(result.observations[1]))


def test_convergence_points_need_both_conditions():
    """TLS needs a loaded and an unloaded record (eq. 33): with one of them, no point at all."""
    res = identify(BAGS, model=ORTHOGLIDE)
    assert gain_convergence(res.observations[:1]) == []


def test_report_cli_writes_the_mcap_beside_the_png(tmp_path, capsys):
    out = tmp_path / "report"
    code = main(["report", *BAGS, "--out", str(out), "--mcap", str(out / "report.mcap"), "-q"])
    text = capsys.readouterr().out
    assert code == 0
    assert (out / "torques.png").is_file() and (out / "report.mcap").is_file()
    assert "report.mcap" in text.splitlines()[-1]


def test_report_cli_refuses_an_mcap_it_cannot_write_in_one_line(tmp_path, capsys):
    """A missing folder is made (issue 45: every --out-like flag); one under a file cannot be."""
    (tmp_path / "a_file").write_text("")
    code = main(["report", *BAGS, "--out", str(tmp_path), "--mcap",
                 str(tmp_path / "a_file" / "such" / "r.mcap"), "-q"])
    err = capsys.readouterr().err
    assert code == 2 and "Traceback" not in err
    assert err.strip().splitlines()[-1].startswith("orthoglide-ident: error: ")
    assert "a_file" in err.strip().splitlines()[-1]
