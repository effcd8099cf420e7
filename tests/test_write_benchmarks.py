"""bench/write_benchmarks.py: the sections it writes into docs/benchmarks.md, and everything else
on the page kept byte for byte (the hand-written figures, sections others append)."""
from __future__ import annotations

import importlib.util
import json
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
spec = importlib.util.spec_from_file_location("write_benchmarks",
                                              ROOT / "bench" / "write_benchmarks.py")
wb = importlib.util.module_from_spec(spec)
spec.loader.exec_module(wb)

HEAD = "# Benchmarks\n\nHow the page is written.\n\n<!-- written sections -->\n"
HAND = "\n| benchmark | figure |\n|---|---|\n| `a` | 1 s |\n\n- a note\n"
APPENDED = "\n## Someone's section (2026-12-06)\n\nFigures by hand.\n"


def _doc(name: str, value: str) -> dict:
    return {"bench": name, "date": "2026-12-06 05:00 UTC", "commit": "abc1234", "load": "1.0",
            "command": f"python bench/{name}.py",
            "tables": [{"title": "t", "columns": ["figure", "value"], "rows": [["x", value]]}]}


def test_sections_go_after_the_anchor_and_the_rest_is_kept():
    page = wb.write_page(HEAD + HAND + APPENDED, [_doc("a", "1"), _doc("b", "2")])
    assert page.startswith(HEAD) and page.endswith(HAND + APPENDED)
    a, b = page.index("### a"), page.index("### b")
    assert len(HEAD) < a < b < page.index(HAND)
    assert "2026-12-06 05:00 UTC, commit `abc1234`" in page and "| x | 1 |" in page


def test_a_section_written_again_is_replaced_and_later_appends_stay():
    page = wb.write_page(HEAD + HAND, [_doc("a", "1"), _doc("b", "2")])
    page += APPENDED  # another engineer appends at the end
    again = wb.write_page(page, [_doc("a", "3")])
    assert again.count("<!-- bench a ") == 1 and again.count("<!-- /bench a -->") == 1
    assert "| x | 3 |" in again and "| x | 1 |" not in again and "| x | 2 |" in again
    assert again.endswith(HAND + APPENDED)
    assert again.replace("| x | 3 |", "| x | 1 |") == page  # nothing else moved


def test_a_bench_without_json_is_shown_as_printed():
    doc = {"bench": "c", "date": "d", "commit": "e", "stdout": "figure 1.0 s\n"}
    assert "```\nfigure 1.0 s\n```\n<!-- /bench c -->" in wb.render(doc)


def test_from_json_writes_the_saved_runs_without_running(tmp_path):
    saved = tmp_path / "runs"
    saved.mkdir()
    (saved / "read_speed.json").write_text(json.dumps(_doc("read_speed", "0.09")))
    page = tmp_path / "benchmarks.md"
    page.write_text(HEAD + HAND + APPENDED)
    assert wb.main(["--from-json", str(saved), "--page", str(page)]) == 0
    text = page.read_text()
    assert "### read_speed" in text and "| x | 0.09 |" in text
    assert text.endswith(HAND + APPENDED)


def test_which_benches_emit_json():
    assert wb.emits_json("read_speed") and not wb.emits_json("identify_data")  # a helper


def test_a_bench_figures_go_through_the_one_helper_with_units_and_before(tmp_path):
    """bench/_figures.py writes what render shows: units in the header, a | in a cell escaped,
    the notes and the figures before; every bench that emits JSON writes it through it."""
    fspec = importlib.util.spec_from_file_location("_figures", ROOT / "bench" / "_figures.py")
    figures = importlib.util.module_from_spec(fspec)
    fspec.loader.exec_module(figures)
    figs = figures.Figures(before="0.95 % (issue 24)")
    table = figs.table("UR5, 2 seeds", ["seed", ("worst gain error", "%"), "|err|/σ"])
    table.row(0, "0.073", "2.45")
    figs.note("every gain within 3 honest σ")
    figs.write(tmp_path / "out.json")
    text = wb.render({"bench": "x", **json.loads((tmp_path / "out.json").read_text())})
    assert "UR5, 2 seeds:\n\n| seed | worst gain error [%] | \\|err\\|/σ |\n|---|---|---|\n" \
           "| 0 | 0.073 | 2.45 |\n" in text
    assert "- every gain within 3 honest σ\n\nBefore: 0.95 % (issue 24)\n<!-- /bench x -->" in text
    benches = sorted(p.stem for p in (ROOT / "bench").glob("*.py") if not p.stem.startswith("_"))
    emitting = [b for b in benches if wb.emits_json(b)]
    assert "read_speed" in emitting and "arm_accuracy" in emitting
    alone = [b for b in emitting if "from _figures import" not in (ROOT / "bench" / f"{b}.py")
             .read_text()]
    assert not alone, f"{alone} write their JSON without bench/_figures.py"


def test_the_page_opens_with_how_to_regenerate_and_names_every_json_bench():
    head = wb.PAGE.read_text().split(wb.ANCHOR)[0]
    assert "bench/write_benchmarks.py" in head and "Regenerate" in head
    emitting = [p.stem for p in sorted((ROOT / "bench").glob("*.py"))
                if not p.stem.startswith("_") and wb.emits_json(p.stem)]
    assert [b for b in emitting if f"`{b}`" not in head] == []
