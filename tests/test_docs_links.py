"""Every relative link `](path#anchor)` in README.md, CHANGELOG.md and docs/ names a file that
exists and, for a Markdown file, one of its headings (GitHub's anchors: lowercase, punctuation
dropped, spaces to '-', a repeated heading suffixed -1, -2, ...)."""
from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
LINK = re.compile(r"\]\(([^)\s]+)\)")
HEADING = re.compile(r"^#{1,6}\s+(.*?)\s*#*\s*$")


def slug(heading: str) -> str:
    """GitHub's anchor of a heading: letters, digits, '_', '-' and spaces kept, spaces to '-'."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def _lines_outside_code(path: Path):
    fenced = False
    for number, line in enumerate(path.read_text().splitlines(), 1):
        if line.startswith("```"):
            fenced = not fenced
        elif not fenced:
            yield number, line


def anchors(path: Path) -> set[str]:
    found: set[str] = set()
    count: dict[str, int] = {}
    for _, line in _lines_outside_code(path):
        m = HEADING.match(line)
        if m:
            s = slug(m.group(1))
            found.add(f"{s}-{count[s]}" if s in count else s)
            count[s] = count.get(s, 0) + 1
    return found


def broken_links(files: list[Path]) -> list[str]:
    bad = []
    for f in files:
        for number, line in _lines_outside_code(f):
            for m in LINK.finditer(line):
                target = m.group(1)
                if re.match(r"^[a-z][a-z0-9+.-]*:", target):  # http:, https:, mailto:, ...
                    continue
                path, _, anchor = target.partition("#")
                dest = (f.parent / path).resolve() if path else f
                where = f"{f.relative_to(ROOT)}:{number}: {target}"
                if not dest.exists():
                    bad.append(f"{where} (no such file)")
                elif anchor and dest.suffix == ".md" and anchor not in anchors(dest):
                    bad.append(f"{where} (no such heading)")
    return bad


def test_github_anchors():
    assert slug("Excitation search with gradients (issue 46; 2026-12-06)") == \
        "excitation-search-with-gradients-issue-46-2026-12-06"
    assert slug("`identify --service --json FILE`") == "identify---service---json-file"
    assert slug("Live = offline at any rate") == "live--offline-at-any-rate"
    assert slug("Predicted vs achieved σ on simulated unseen arms") == \
        "predicted-vs-achieved-σ-on-simulated-unseen-arms"


def test_every_relative_link_in_the_docs_resolves():
    files = [ROOT / "README.md", ROOT / "CHANGELOG.md", *sorted((ROOT / "docs").rglob("*.md"))]
    assert broken_links([f for f in files if f.exists()]) == []
