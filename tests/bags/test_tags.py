"""The bag tag (docs/design/interfaces.md): payload frame, centre of mass and inertia beside
condition and
mass, and the sources of q and the current; the same keys in metadata.yaml custom_data and in each
file's ``orthoglide`` metadata record; bad values refused with a one-line reason."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml
from mcap.reader import make_reader

from orthoglide_ident import bags
from orthoglide_ident.errors import BagError, ConfigError

T0 = 1_700_000_000_000_000_000
PAYLOAD = {"payload_frame": "tool0", "payload_com": (0.0, -0.0125, 0.0731),
           "payload_inertia": (2.1e-3, -1e-5, 3e-6, 1.9e-3, 0.0, 1.1e-3)}


def _write(path: Path, **payload) -> Path:
    n = 200
    stamps = T0 + np.arange(n, dtype=np.int64) * 1_000_000
    rng = np.random.default_rng(3)
    return bags.write_bag(path, stamps, rng.normal(size=(n, 2)), rng.normal(size=(n, 2)),
                          "loaded", 1.136, ("j1", "j2"), layout="dynamic_joint_states",
                          payload=payload)


def _file_record(f: Path) -> dict[str, str]:
    with f.open("rb") as fh:
        return next(m.metadata for m in make_reader(fh).iter_metadata() if m.name == "orthoglide")


def test_payload_tags_round_trip(tmp_path: Path) -> None:
    p = _write(tmp_path / "b", **PAYLOAD)
    custom = yaml.safe_load((p / "metadata.yaml").read_text())[
        "rosbag2_bagfile_information"]["custom_data"]
    expected = {
        "orthoglide.condition": "loaded", "orthoglide.payload_mass": "1.136",
        "orthoglide.payload_frame": "tool0", "orthoglide.payload_com": "0.0 -0.0125 0.0731",
        "orthoglide.payload_inertia": "0.0021 -1e-05 3e-06 0.0019 0.0 0.0011",
        "orthoglide.position_source": "/joint_states position",
        "orthoglide.current_source": "/dynamic_joint_states current",
    }
    assert custom == expected
    (f,) = p.glob("*.mcap")
    assert _file_record(f) == expected  # a lone .mcap file keeps the whole tag
    tags = bags.read_bag(p).tags
    assert tags == bags.read_bag(f).tags
    assert tags is not None and tags.payload_frame == "tool0"
    assert tags.payload_com == PAYLOAD["payload_com"]  # exact: shortest round-trip text
    assert tags.payload_inertia == PAYLOAD["payload_inertia"]
    info = bags.bag_info(p).to_text()
    assert "loaded, payload 1.136 kg at tool0, CoM 0 -0.0125 0.0731 m, inertia" in info


def test_absent_payload_keys_mean_the_mass_alone_is_known(tmp_path: Path) -> None:
    """Sect. 4.3: a loaded bag tagged with its mass only (and a frame) knows the mass, not the
    CoM and inertia; an unloaded tag keeps exactly its two keys."""
    tags = bags.read_bag(_write(tmp_path / "b")).tags
    assert tags is not None
    assert (tags.payload_frame, tags.payload_com, tags.payload_inertia) == (None, None, None)
    assert tags.payload_known is None and tags.knowledge == "mass"
    assert "(mass known, CoM and inertia not)" in tags.describe()
    assert bags.BagTags("unloaded", 0.0).to_dict() == {"orthoglide.condition": "unloaded",
                                                       "orthoglide.payload_mass": "0"}


@pytest.mark.parametrize("payload, known", [
    ({}, "mass"),
    ({"payload_frame": "tool0", "payload_com": (0.0, 0.0, 0.05)}, "com"),
    (PAYLOAD, "all"),
    ({"payload_frame": "tool0", "payload_known": "point"}, "point"),
    ({"payload_com": (0.0, 0.0, 0.05), "payload_known": "point"}, "point"),
    ({**PAYLOAD, "payload_known": "mass"}, "mass"),  # CAD values kept, only the mass trusted
    ({"payload_com": (0.0, 0.0, 0.05), "payload_known": "com"}, "com"),
])
def test_payload_knowledge_round_trips(tmp_path: Path, payload: dict, known: str) -> None:
    p = _write(tmp_path / "b", **payload)
    tags = bags.read_bag(p).tags
    assert tags is not None and tags.knowledge == known
    custom = yaml.safe_load((p / "metadata.yaml").read_text())[
        "rosbag2_bagfile_information"]["custom_data"]
    assert custom.get("orthoglide.payload_known") == payload.get("payload_known")
    (f,) = p.glob("*.mcap")
    assert _file_record(f).get("orthoglide.payload_known") == payload.get("payload_known")
    assert bags.read_bag(f).tags == tags
    assert bags.BagTags.from_dict(tags.to_dict(), "x") == tags


BAD = [
    ({"orthoglide.payload_com": "0 0"}, "payload_com .* is not 3 finite numbers 'x y z' \\(m\\)"),
    ({"orthoglide.payload_com": "0 0 nan"}, "payload_com .* is not 3 finite numbers"),
    ({"orthoglide.payload_com": "a b c"},
     "orthoglide.payload_com 'a b c' is not a list of numbers"),
    ({"orthoglide.payload_inertia": "1 0 0 1 0"}, "payload_inertia .* is not 6 finite numbers"),
    ({"orthoglide.payload_inertia": "1 0 0 1 0 -1"}, "is not positive semi-definite"),
    ({"orthoglide.payload_inertia": "1 0 0 1 0 3"}, "break I1 \\+ I2 >= I3"),
    ({"orthoglide.payload_frame": "tool 0"}, "payload_frame 'tool 0' is not a link name"),
    ({"orthoglide.payload_frame": ""}, "payload_frame '' is not a link name"),
    ({"orthoglide.current_source": "joint_states effort"},
     "current_source .* is not 'TOPIC FIELD'"),
    ({"orthoglide.position_source": "/joint_states"}, "position_source .* is not 'TOPIC FIELD'"),
    ({"orthoglide.condition": "unloaded", "orthoglide.payload_mass": "0",
      "orthoglide.payload_com": "0 0 0.1"}, "condition 'unloaded' takes no payload_com"),
    ({"orthoglide.payload_known": "cad"}, "payload_known 'cad' is not one of mass, com, all"),
    ({"orthoglide.payload_known": "point"}, "payload_known 'point' takes no payload_inertia"),
    ({"orthoglide.payload_inertia": None, "orthoglide.payload_known": "all"},
     "payload_known 'all' needs payload_com and payload_inertia"),
    ({"orthoglide.payload_com": None, "orthoglide.payload_inertia": None,
      "orthoglide.payload_known": "com"}, "payload_known 'com' needs payload_com"),
    ({"orthoglide.position_side": "motor"}, "position_side 'motor': use 'joint' or 'actuator'"),
    ({"orthoglide.effort_side": "Joint"}, "effort_side 'Joint': use 'joint' or 'actuator'"),
]


@pytest.mark.parametrize("change, reason", BAD)
def test_bad_tags_in_a_bag_are_a_one_line_reason(tmp_path: Path, change: dict[str, str],
                                                 reason: str) -> None:
    p = _write(tmp_path / "b", **PAYLOAD)
    meta = p / "metadata.yaml"
    doc = yaml.safe_load(meta.read_text())
    custom = doc["rosbag2_bagfile_information"]["custom_data"]
    custom.update(change)
    for key in [k for k, v in change.items() if v is None]:
        del custom[key]
    meta.write_text(yaml.safe_dump(doc))
    with pytest.raises(BagError, match=reason) as exc:
        bags.read_bag(p)
    assert str(exc.value).startswith(f"{meta} custom_data: invalid tag: ")
    assert "\n" not in str(exc.value)
    assert bags.bag_info(p).tags is None  # info still reads the bag and says why
    assert "invalid tag" in bags.bag_info(p).to_text()


def test_recorder_requests_are_checked() -> None:
    """What a recorder passes on: ConfigError with the reason; good values kept exactly."""
    tags = bags.BagTags.checked("loaded", 1.136, payload_frame="tool0",
                                payload_com=[0, 0, 0.05], payload_inertia=[1e-3, 0, 0, 1e-3, 0, 0])
    assert tags.payload_com == (0.0, 0.0, 0.05)  # a flat disc: I1 + I2 = I3, accepted
    assert bags.BagTags.from_dict(tags.to_dict(), "x") == tags
    with pytest.raises(ConfigError, match="payload_inertia .* is not 6 finite numbers"):
        bags.BagTags.checked("loaded", 1.0, payload_inertia=[1.0, 2.0])
    with pytest.raises(ConfigError, match="payload_com .* is not 3 numbers"):
        bags.BagTags.checked("loaded", 1.0, payload_com="0 0 1")  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match="unloaded' takes no payload_com or payload_inertia"):
        bags.BagTags.checked("unloaded", 0, payload_inertia=[0] * 6)
    with pytest.raises(ConfigError, match="unloaded' takes no payload_known"):
        bags.BagTags.checked("unloaded", 0, payload_known="point")
    # a frame alone is a fact about the robot: allowed unloaded
    assert bags.BagTags.checked("unloaded", 0, payload_frame="tool0").payload_frame == "tool0"


def test_effort_unit_tag_round_trips_and_is_checked() -> None:
    t = bags.BagTags.checked("unloaded", 0, effort_unit="torque")
    assert t.to_dict()[bags.tags.EFFORT_UNIT_KEY] == "torque"
    assert bags.BagTags.from_dict(t.to_dict(), "x") == t
    assert bags.tags.EFFORT_UNIT_KEY not in bags.BagTags.checked("unloaded", 0).to_dict()
    with pytest.raises(BagError, match="x: invalid tag: effort_unit 'Nm': use 'A'"):
        bags.BagTags.from_dict({**t.to_dict(), bags.tags.EFFORT_UNIT_KEY: "Nm"}, "x")


def test_signal_sides_round_trip_in_both_places(tmp_path: Path) -> None:
    """orthoglide.position_side / effort_side (whose signals a bag of a robot with a
    transmission holds): written by write_bag in metadata.yaml and each file's record, read
    back, said in describe(); absent when not given (an Orthoglide bag keeps its two keys)."""
    n = 50
    stamps = T0 + np.arange(n, dtype=np.int64) * 1_000_000
    p = bags.write_bag(tmp_path / "b", stamps, np.zeros((n, 2)), np.ones((n, 2)), "unloaded",
                       0.0, ("j1", "j2"), layout="joint_states", position_side="actuator",
                       effort_side="joint")
    custom = yaml.safe_load((p / "metadata.yaml").read_text())[
        "rosbag2_bagfile_information"]["custom_data"]
    record = _file_record(next(p.glob("*.mcap")))
    for where in (custom, record):
        assert where[bags.tags.POSITION_SIDE_KEY] == "actuator"
        assert where[bags.tags.EFFORT_SIDE_KEY] == "joint"
    tags = bags.read_bag(p).tags
    assert (tags.position_side, tags.effort_side) == ("actuator", "joint")
    assert "positions actuator-side, efforts joint-side" in tags.describe()
    plain = bags.BagTags.checked("unloaded", 0).to_dict()
    assert bags.tags.POSITION_SIDE_KEY not in plain and bags.tags.EFFORT_SIDE_KEY not in plain
    with pytest.raises(ConfigError, match="position_side 'motor': use 'joint' or 'actuator'"):
        bags.BagTags.checked("unloaded", 0, position_side="motor")


def test_sides_given_in_custom_data_only_agree_with_the_files(tmp_path: Path) -> None:
    """A bag written before the sides were part of the tag (the coupled-wrist bench put them in
    metadata.yaml's custom_data only): the files' records lack them, which is no contradiction;
    the sides are read. Two places that say different sides are one."""
    p = _write(tmp_path / "b", **PAYLOAD)
    meta = p / "metadata.yaml"
    doc = yaml.safe_load(meta.read_text())
    custom = doc["rosbag2_bagfile_information"]["custom_data"]
    custom[bags.tags.POSITION_SIDE_KEY] = "actuator"
    meta.write_text(yaml.safe_dump(doc))
    assert bags.read_bag(p).tags.position_side == "actuator"
    q = bags.write_bag(tmp_path / "c", T0 + np.arange(50, dtype=np.int64) * 1_000_000,
                       np.zeros((50, 2)), np.ones((50, 2)), "unloaded", 0.0, ("j1", "j2"),
                       position_side="joint")
    meta = q / "metadata.yaml"
    doc = yaml.safe_load(meta.read_text())
    doc["rosbag2_bagfile_information"]["custom_data"][bags.tags.POSITION_SIDE_KEY] = "actuator"
    meta.write_text(yaml.safe_dump(doc))
    with pytest.raises(BagError, match="contradictory tags: .* positions actuator-side, .* "
                                       "positions joint-side"):
        bags.read_bag(q)
