"""The figures a bench hands to bench/write_benchmarks.py: tables (columns with their units, rows)
and notes, written as JSON when the bench is given ``--json PATH``; what it prints stays its own.

    from _figures import Figures, add_json_option   # bench/ is on sys.path for bench/NAME.py

    EMITS_JSON = True   # write_benchmarks.py runs the bench with --json PATH
    add_json_option(ap)
    figs = Figures(before="what the figures were before (issue N)")
    gains = figs.table("UR5, 5 seeds", ["seed", ("worst gain error", "%"), ("max |z|", "σ")])
    gains.row(0, f"{0.073:.3f}", f"{2.45:.2f}")     # cells as printed: strings, or str()-ed
    figs.note("every gain within 3 honest σ")
    figs.write(args.json)                           # nothing without --json

The format is the one documented at the top of write_benchmarks.py.
"""
from __future__ import annotations

import argparse
import json
from collections.abc import Sequence
from pathlib import Path

Column = str | tuple[str, str]  # a name, or (name, unit): shown "name [unit]"


def add_json_option(ap: argparse.ArgumentParser) -> None:
    """``--json PATH``: the figures also written as JSON (for bench/write_benchmarks.py)."""
    ap.add_argument("--json", type=Path, metavar="PATH",
                    help="also write the figures here as JSON (bench/write_benchmarks.py)")


class Table:
    """One table: its title, its columns (with units) and its rows of printed cells."""

    def __init__(self, title: str, columns: Sequence[Column]):
        self.title = title
        self.columns = [c if isinstance(c, str) else f"{c[0]} [{c[1]}]" for c in columns]
        self.rows: list[list[str]] = []

    def row(self, *cells: object) -> None:
        if len(cells) != len(self.columns):
            raise ValueError(f"{self.title!r}: {len(cells)} cells for {len(self.columns)} columns")
        self.rows.append([str(c) for c in cells])

    def as_dict(self) -> dict:
        return {"title": self.title, "columns": self.columns, "rows": self.rows}


class Figures:
    """A bench's tables and notes, and what its figures were before (``before``: a line)."""

    def __init__(self, before: str = ""):
        self.tables: list[Table] = []
        self.notes: list[str] = []
        self.before = before

    def table(self, title: str, columns: Sequence[Column]) -> Table:
        self.tables.append(Table(title, columns))
        return self.tables[-1]

    def note(self, text: str) -> None:
        self.notes.append(text)

    def as_dict(self) -> dict:
        doc: dict = {"tables": [t.as_dict() for t in self.tables], "notes": self.notes}
        return {**doc, "before": self.before} if self.before else doc

    def write(self, path: Path | None) -> None:
        """Write the figures to ``path`` as JSON; nothing when it is None (no ``--json``)."""
        if path is not None:
            Path(path).write_text(json.dumps(self.as_dict(), indent=1, ensure_ascii=False) + "\n")
