"""The one YAML reader: a missing file, broken YAML and a named section, each a one-line reason."""
from __future__ import annotations

import pytest

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.yaml_files import load_yaml, unwrap_section


def test_a_missing_file_and_broken_yaml_are_one_line_reasons(tmp_path):
    with pytest.raises(ConfigError, match=r"^cannot read robot file .*nope.yaml: No such file"):
        load_yaml(tmp_path / "nope.yaml", "robot file")
    bad = tmp_path / "bad.yaml"
    bad.write_text("a: [1, 2\n")
    with pytest.raises(ConfigError) as err:
        load_yaml(bad, "config")
    assert str(err.value).startswith(f"config {bad} is not valid YAML: ")
    assert "\n" not in str(err.value)


def test_an_empty_file_is_none_and_a_named_section_unwraps(tmp_path):
    empty = tmp_path / "empty.yaml"
    empty.write_text("")
    assert load_yaml(empty, "config") is None
    assert unwrap_section({"arm_plant": {"seed": 3}}, "arm_plant") == {"seed": 3}
    both = {"arm_plant": {}, "seed": 3}  # another key beside it: the content itself
    assert unwrap_section(both, "arm_plant") is both
    assert unwrap_section(None, "plant") is None
