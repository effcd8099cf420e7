"""Writes docs/benchmarks.md from the bench runs: one section per bench, with its date and commit.

    python bench/write_benchmarks.py read_speed arm_simulator     run these, write their sections
    python bench/write_benchmarks.py --save DIR read_speed        ... and keep their outputs in DIR
    python bench/write_benchmarks.py --from-json DIR              the sections of the saved outputs

A bench that emits JSON (``EMITS_JSON = True`` in its source) is run with ``--json PATH`` and
writes there, through bench/_figures.py (the one helper that writes it)::

    {"tables": [{"title": "UR5, 5 seeds",                 a line above the table ("" for none)
                 "columns": ["seed", "worst gain [%]"],   names, a unit in [brackets]
                 "rows": [["0", "0.073"], ...]}],         cells as the bench prints them
     "notes": ["every gain within 3 honest σ", ...],      one bullet each, under the tables
     "before": "0.95 % (issue 24)"}                       optional: the figures before

Its section is those tables, the notes and a "Before:" line. Any other bench is run as it is and
its section is what it printed. Either way the run is saved as ``NAME.json`` with ``bench``,
``command``, ``date`` (UTC), ``commit`` and ``load`` (the machine's 5-min load average at the
end: the figures are times on a shared machine) added, so that ``--from-json`` writes the same
section later without running anything.

The page keeps everything it does not write, as it is: a written section stands between
``<!-- bench NAME ... -->`` and ``<!-- /bench NAME -->`` and is replaced when NAME is written
again; a new one goes after the last written section (the first after the page's
``<!-- written sections -->`` line). The hand-written figures (the table and notes from before
this script) and the sections others append at the end stay untouched until a bench's JSON
section takes their place.
"""
from __future__ import annotations

import argparse
import datetime
import json
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BENCH = ROOT / "bench"
PAGE = ROOT / "docs" / "benchmarks.md"
WRITER = "written by bench/write_benchmarks.py"
BEGIN = re.compile(r"^<!-- bench (\S+) .*-->$", re.M)
EMITS = re.compile(r"^EMITS_JSON = True\b", re.M)
ANCHOR = "<!-- written sections -->"  # where the first written section goes


def emits_json(name: str) -> bool:
    """Whether bench/NAME.py writes its figures as JSON (``--json PATH``); read, not imported."""
    return bool(EMITS.search((BENCH / f"{name}.py").read_text()))


def commit() -> str:
    """The checkout's commit (short), ``+changes`` when the tree differs from it."""
    def git(*args: str) -> str:
        return subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True).stdout

    head = git("rev-parse", "--short", "HEAD").strip() or "unknown"
    return head + ("+changes" if git("status", "--porcelain", "--untracked-files=no").strip()
                   else "")


def run(name: str, args: list[str]) -> dict:
    """Run bench/NAME.py (with --json when it emits JSON); its output as a saved document."""
    cmd = [sys.executable, str(BENCH / f"{name}.py"), *args]
    ran = commit()  # the code as the bench starts (the tree may change while it runs)
    with tempfile.TemporaryDirectory() as tmp:
        js = Path(tmp) / "out.json"
        if emits_json(name):
            cmd += ["--json", str(js)]
        proc = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
        if proc.returncode != 0:
            tail = (proc.stderr.strip().splitlines() or ["no output"])[-1]
            raise RuntimeError(f"bench/{name}.py failed ({proc.returncode}): {tail}")
        doc = json.loads(js.read_text()) if js.exists() else {"stdout": proc.stdout}
    shown = ["python", f"bench/{name}.py", *args]
    return {"bench": name, "command": " ".join(shown), **doc,
            "date": datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC"),
            "commit": ran, "load": f"{os.getloadavg()[1]:.1f}"}


def _row(cells: list) -> str:
    """One markdown table row; a ``|`` inside a cell (``|err|/σ``) escaped."""
    return "| " + " | ".join(str(c).replace("|", "\\|") for c in cells) + " |"


def render(doc: dict) -> str:
    """One section's markdown, between its markers."""
    name = doc["bench"]
    lines = [f"<!-- bench {name} {WRITER}: do not edit by hand -->", f"### {name}", "",
             f"{doc.get('date', 'date unknown')}, commit `{doc.get('commit', 'unknown')}`, load "
             f"{doc.get('load', 'unknown')} (5-min average at the end, 2 cores): "
             f"`{doc.get('command', f'python bench/{name}.py')}`", ""]
    for table in doc.get("tables", []):
        if table.get("title"):
            lines += [f"{table['title']}:", ""]
        lines += [_row(table["columns"]), "|" + "---|" * len(table["columns"])]
        lines += [_row(row) for row in table["rows"]]
        lines.append("")
    notes = [f"- {note}" for note in doc.get("notes", [])]
    lines += notes
    if doc.get("before"):  # a paragraph of its own, not a continuation of the last note
        lines += [""] * bool(notes) + [f"Before: {doc['before']}"]
    if "stdout" in doc:
        lines += ["```", doc["stdout"].rstrip("\n"), "```"]
    return "\n".join(lines).rstrip("\n") + f"\n<!-- /bench {name} -->\n"


def sections(text: str) -> list[tuple[str | None, str]]:
    """The page cut into (name, text) pieces: a written section's name, None for the rest."""
    out, pos = [], 0
    for m in BEGIN.finditer(text):
        if m.start() < pos:
            continue
        end = text.find(f"<!-- /bench {m.group(1)} -->", m.end())
        if end < 0:
            raise SystemExit(f"{PAGE}: section {m.group(1)} has no end marker: fix the page")
        end = text.index("\n", end) + 1 if "\n" in text[end:] else len(text)
        out += [(None, text[pos:m.start()]), (m.group(1), text[m.start():end])]
        pos = end
    return [p for p in out + [(None, text[pos:])] if p[1]]


def write_page(text: str, docs: list[dict]) -> str:
    """``text`` with the sections of ``docs`` replaced or added; the rest left as it is."""
    pieces = sections(text)
    for doc in docs:
        new = render(doc)
        at = [i for i, (n, _) in enumerate(pieces) if n == doc["bench"]]
        if at:
            pieces[at[0]] = (doc["bench"], new)
            continue
        written = [i for i, (n, _) in enumerate(pieces) if n is not None]
        if written:
            pieces.insert(written[-1] + 1, (doc["bench"], "\n" + new))
            continue
        head = "".join(p for _, p in pieces)  # no section yet: at the anchor, else at the top
        cut = head.index(ANCHOR) + len(ANCHOR) + 1 if ANCHOR in head else 0
        pieces = [(None, head[:cut]), (doc["bench"], "\n" + new), (None, head[cut:])]
    return "".join(p for _, p in pieces)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("benches", nargs="*", help="bench names (bench/NAME.py) to run")
    ap.add_argument("--from-json", type=Path, help="write the sections of DIR/*.json, run none")
    ap.add_argument("--save", type=Path, help="keep each run's output as DIR/NAME.json")
    ap.add_argument("--args", default="", help="arguments for every bench run (e.g. --seconds 5)")
    ap.add_argument("--page", type=Path, default=PAGE, help="the page (default docs/benchmarks.md)")
    a = ap.parse_args(argv)
    if bool(a.from_json) == bool(a.benches):
        ap.error("name the benches to run, or give --from-json DIR")
    unknown = [b for b in a.benches if not (BENCH / f"{b}.py").is_file()]
    if unknown:
        ap.error(f"no bench/{unknown[0]}.py")
    try:
        if a.from_json:
            docs = [json.loads(p.read_text()) for p in sorted(a.from_json.glob("*.json"))]
            docs = [d for d in docs if "bench" in d]
        else:
            docs = [run(b, a.args.split()) for b in a.benches]
    except (RuntimeError, OSError, json.JSONDecodeError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    if a.save:
        a.save.mkdir(parents=True, exist_ok=True)
        for d in docs:
            (a.save / f"{d['bench']}.json").write_text(json.dumps(d, indent=1) + "\n")
    a.page.write_text(write_page(a.page.read_text(), docs))
    print(f"{a.page}: {len(docs)} section(s) written: {', '.join(d['bench'] for d in docs)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
