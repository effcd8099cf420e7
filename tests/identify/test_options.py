"""The options in groups by concern (issue 44): each flat key (YAML key, ROS parameter, CLI
option) in exactly one group, read and replaced by its flat name, and every node parameter kept."""
from __future__ import annotations

from dataclasses import fields
from pathlib import Path

import pytest

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.identify.options import (
    GROUPS,
    KEY_GROUP,
    ConsistencyOptions,
    IdentifyOptions,
    InputOptions,
    LiveOptions,
    ObserveOptions,
    SolveOptions,
)
from orthoglide_ident.yaml_files import load_yaml

CONFIG = Path(__file__).resolve().parents[2] / "config" / "identification.yaml"


def config_keys() -> dict:
    """The keys of config/identification.yaml's ros__parameters, with their values."""
    return load_yaml(CONFIG, "config")["/**"]["ros__parameters"]


def test_each_flat_key_is_in_exactly_one_group():
    seen: dict[str, list[str]] = {}
    for f in fields(IdentifyOptions):  # the composite holds the groups and nothing else
        assert f.name in GROUPS
        for g in fields(GROUPS[f.name]):
            seen.setdefault(g.name, []).append(f.name)
    assert {k: v for k, v in seen.items() if len(v) != 1} == {}
    assert KEY_GROUP == {k: v[0] for k, v in seen.items()}
    assert [(k, g) for k, _, g in IdentifyOptions.flat_fields()] == list(KEY_GROUP.items())
    # a group's fields are read through it only: no flat attribute on the composite
    assert not any(hasattr(IdentifyOptions(), k) for k in KEY_GROUP)


def test_flat_keys_build_the_same_options_as_the_groups():
    flat = {"current_sampling": "held", "filter_cutoff_hz": 50.0, "decimation_cutoff_hz": 20.0,
            "r_sigma": 5.0, "lag_model": "off", "live_block_s": 2.0, "consistent": True}
    by_groups = IdentifyOptions(
        input=InputOptions(current_sampling="held"),
        observe=ObserveOptions(filter_cutoff_hz=50.0, decimation_cutoff_hz=20.0),
        solve=SolveOptions(r_sigma=5.0, lag_model="off"),
        live=LiveOptions(live_block_s=2.0),
        consistency=ConsistencyOptions(consistent=True))
    assert IdentifyOptions.from_mapping(flat) == by_groups
    assert IdentifyOptions.of(**flat) == by_groups
    assert IdentifyOptions().replace(**flat, gain_min=None) == by_groups  # None: left as is
    assert by_groups.flat() == {**IdentifyOptions().flat(), **flat}
    # the YAML file documents the defaults, under its groups' headers
    assert IdentifyOptions.from_yaml(CONFIG) == IdentifyOptions()


def test_an_unknown_key_is_refused_with_every_known_one():
    with pytest.raises(ConfigError) as e:
        IdentifyOptions.from_mapping({"filter_cutof_hz": 50.0}, "f.yaml")
    msg = str(e.value)
    assert msg.startswith("f.yaml: unknown option 'filter_cutof_hz'; known: ")
    assert msg.split("known: ")[1].split(", ") == list(KEY_GROUP)
    with pytest.raises(TypeError, match="filter_cutof_hz"):
        IdentifyOptions().replace(filter_cutof_hz=50.0)
    with pytest.raises(ConfigError, match="r_sigma must be > 1"):  # a group's own check
        IdentifyOptions.from_mapping({"r_sigma": 1.0})


def test_every_node_parameter_keeps_its_name_and_type():
    """The node declares one parameter per key of config/identification.yaml (the options, and
    the node's own: robot, topics), each of the type of its value there."""
    from orthoglide_ident.nodes.identification import (
        NODE_PARAMETERS,
        OPTION_NAMES,
        OPTION_PARAMETERS,
        PARAMETERS,
    )

    keys = config_keys()
    node_own = {p.name for p in NODE_PARAMETERS}
    assert OPTION_NAMES == set(keys) - node_own == set(KEY_GROUP)
    declared = {p.name: p for p in PARAMETERS}
    assert set(keys) <= set(declared) and len(declared) == len(PARAMETERS)
    for p in OPTION_PARAMETERS:
        assert type(p.default) is type(IdentifyOptions().flat()[p.name]), p.name
        assert isinstance(keys[p.name], type(p.default)) or type(p.default) is float, p.name
