"""A local folder named like a bundled robot (``./ur5``, the README's own bag folder) never
shadows the bundled robot silently: the bundled one is taken and the choice is said."""
from __future__ import annotations

import logging

from orthoglide_ident.cli import main
from orthoglide_ident.model.registry import ROBOTS_DIR, resolve


def test_a_folder_named_ur5_does_not_shadow_the_bundled_ur5(tmp_path, monkeypatch, caplog):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "ur5").mkdir()  # `python -m orthoglide_sim.arm_or_chain.bags --robot ur5 --out ur5`
    with caplog.at_level(logging.WARNING, logger="orthoglide_ident"):
        assert resolve("ur5") == ROBOTS_DIR / "ur5.yaml"
    said = " ".join(r.getMessage() for r in caplog.records)
    assert "bundled" in said and str(tmp_path / "ur5") in said


def test_the_model_command_runs_beside_a_ur5_folder(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "ur5").mkdir()
    assert main(["model", "--robot", "ur5"]) == 0
    out, err = capsys.readouterr()
    assert "shoulder_pan" in out and "bundled robot" in err and "folder" in err


def test_an_explicit_path_is_taken_as_given(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "ur5").mkdir()
    assert resolve("./ur5") == (tmp_path / "ur5").resolve()
