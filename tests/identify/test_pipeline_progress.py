"""Progress of a long ``identify`` (issue 45): on a terminal, a line per stage with the time left
(progress.Stages, passed from the CLI's edge to the numerical core, which never prints): the
records read and observed (by their size), the solve, the IV cross-check, the consistency fits,
the partial answer's subset search; piped, nothing of it (stdout and stderr as before)."""
from __future__ import annotations

import io
import re
import subprocess
import sys
from itertools import combinations
from pathlib import Path

import pytest

from orthoglide_ident import cli, progress
from orthoglide_ident.identify.solve import partial

ROOT = Path(__file__).resolve().parents[2]
BAGS = [str(ROOT / "bags" / "unloaded"), str(ROOT / "bags" / "loaded")]
STAGES = ("reading and observing the records", "solving (IDIM-TLS)", "cross-checking by IDIM-IV",
          "physical consistency (LMI fits)")


class Tty(io.StringIO):
    def isatty(self) -> bool:
        return True


@pytest.fixture(autouse=True)
def _not_quiet():
    progress.set_quiet(False)
    yield
    progress.set_quiet(False)


def test_identify_shows_its_stages_on_a_terminal(tmp_path, monkeypatch, capsys):
    tty = Tty()
    monkeypatch.setattr(sys, "stderr", tty)
    assert cli.main(["identify", *BAGS, "--consistent", "--json", str(tmp_path / "r.json")]) == 0
    err = tty.getvalue()
    drawn = [s for s in STAGES if f"\r{s}" in err]
    assert drawn == list(STAGES), err[-2000:]
    assert "\rreading and observing the records: 0 % (0/1.91 MB)" in err  # by the bags' size
    assert "\rphysical consistency (LMI fits): 0 % (0/4 steps)" in err
    for name in ("unloaded", "loaded"):  # within a record: its chunks read, its samples observed
        assert re.search(rf"\rreading {name}_0\.mcap: \d+ % \(\d+/\d+ chunks\)", err), err[:3000]
        assert re.search(rf"\robserving {name}: \d+ % \(\d+/10000 samples\)", err)
    assert "orthoglide-ident: reading" in err
    assert not re.search(r"\r[^\r\n]+orthoglide-ident: ", err)  # a log line erases it first
    tail = err.rsplit("\n", 1)[-1]  # after the last log line: a progress line erased, or none
    assert tail == "" or tail.endswith("\r")
    out = capsys.readouterr().out
    assert "drive gains" in out and "\r" not in out  # results on stdout, untouched


def test_piped_identify_prints_no_progress():
    p = subprocess.run([sys.executable, "-m", "orthoglide_ident.cli", "identify", *BAGS,
                        "--consistent"], capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    assert "\r" not in p.stderr + p.stdout
    assert not any(s in p.stderr for s in STAGES)


def test_the_subset_search_tells_its_trials():
    """Every subset of 4 free gains tried (none answers): 14 proper subsets, told one by one."""
    heard = []

    def trial(kept):
        return partial.Trial(kept, 2.0, "not separated")

    best, tried = partial.search_subsets([0, 1, 2, 3], trial, ["a", "b", "c", "d"],
                                         progress=lambda *a: heard.append(a))
    every = sum(1 for k in range(1, 4) for _ in combinations(range(4), k))
    assert best is None and len(tried) == every == 14
    assert heard == [("searching the gains the data fix", k, 14, "subsets")
                     for k in range(1, 15)]


def test_a_stage_taken_up_again_keeps_its_start():
    """Between two records' own stages the records' stage comes back with its own start: its
    time left is over all its work (8 s for 2 of 10 MB: 32 s left), not since it came back."""
    out, t = Tty(), [0.0]
    stages = progress.Stages(stream=out, clock=lambda: t[0])
    stages("records", 0, 10, "MB")
    t[0] = 3.0
    stages("reading r0.mcap", 5, 10, "chunks")
    t[0] = 8.0
    stages("records", 2, 10, "MB")
    stages.close()
    assert "\rrecords: 20 % (2/10 MB), 32 s left" in out.getvalue()
    assert "\rreading r0.mcap: 50 % (5/10 chunks), 0 s left" in out.getvalue()
