"""Collision bodies (Pinocchio + coal): the pairs checked, meshes found or refused."""
from __future__ import annotations

import numpy as np
import pytest

from excite_robots import cube_stl, two_link_urdf
from orthoglide_ident.errors import ConfigError
from orthoglide_ident.excite.collision import CollisionModel
from orthoglide_ident.model.robots import load_robot


def test_ur5_pairs_leave_out_adjacent_and_disabled_links():
    c = CollisionModel(load_robot("ur5"), "mesh")
    pairs = {frozenset(p.split("/")) for p in c.pair_names}
    for adjacent in (("base_link", "shoulder_link"), ("upper_arm_link", "forearm_link"),
                     ("wrist_2_link", "wrist_3_link")):
        assert frozenset(adjacent) not in pairs
    assert frozenset(("wrist_1_link", "wrist_3_link")) not in pairs  # disabled in ur5.yaml
    assert frozenset(("floor", "shoulder_link")) not in pairs
    assert frozenset(("shoulder_link", "wrist_2_link")) in pairs
    assert frozenset(("forearm_link", "floor")) in pairs
    home = np.array([[0.0, -2.0, 1.2, -1.5708, -1.5708, 0.0]])
    assert c.distances(home).min() > 0.02


def test_five_bar_links_held_by_the_loop_are_adjacent():
    c = CollisionModel(load_robot("five_bar"), "mesh")
    assert "distal_1/distal_2" not in c.pair_names
    assert "proximal_1/distal_2" in c.pair_names


def test_unresolvable_package_meshes_get_a_reason_and_the_ways_out(tmp_path):
    urdf = two_link_urdf(tmp_path, mesh="package://arm_description/meshes/cube.stl")
    robot = load_robot(str(urdf))
    with pytest.raises(ConfigError, match="cube.stl of link l1 cannot be found.*--package-dir.*"
                                          "--collision primitives.*--collision skip"):
        CollisionModel(robot, "mesh")
    with pytest.raises(ConfigError, match="no collision geometry"):
        CollisionModel(robot, "primitives")
    assert CollisionModel(robot, "skip").n_pairs == 0


def test_package_meshes_found_through_package_dir(tmp_path):
    cube_stl(tmp_path / "share" / "arm_description" / "meshes" / "cube.stl")
    urdf = two_link_urdf(tmp_path, mesh="package://arm_description/meshes/cube.stl")
    c = CollisionModel(load_robot(str(urdf)), "mesh", [str(tmp_path / "share")])
    assert c.geom.ngeoms == 2 and c.n_pairs == 0  # l1 and l2 are adjacent
