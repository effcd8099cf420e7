"""Collision bodies (Pinocchio + coal): the pairs checked, meshes found or refused."""
from __future__ import annotations

import numpy as np
import pytest
from excite_robots import cube_stl, two_link_urdf

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.excite.collision import CollisionModel
from orthoglide_ident.model.registry import load_robot


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


def test_the_1ms_check_skips_only_samples_no_pair_can_reach():
    """The UR5 folding onto itself (test_excite_check): every distance the advancing check
    skips is above the margin when computed anyway, and the worst distance is the same."""
    from excite_robots import static_runs

    from orthoglide_ident.excite.constraints import TreeStates

    robot = load_robot("ur5")
    c = CollisionModel(robot, "mesh")
    a = np.zeros((6, 2))
    a[2] = [0.68, -0.68]
    traj = static_runs("ur5", robot.joint_names, [0.0, -1.57, 2.2, 0.0, 0.0, 0.0], a)
    t = np.arange(0.0, 5.0, 1e-3)
    q, qd, _ = traj.evaluate("unloaded", t)
    Q, _ = TreeStates(robot).configurations(q)
    full = c.distances(Q)
    fast = c.distances_along(Q, qd, 1e-3, 0.02)
    skipped = ~np.isfinite(fast)
    assert skipped.mean() > 0.5  # most samples of most pairs
    assert np.all(full[skipped] >= 0.02)
    done = fast[~skipped]  # exact within 3 margins, a lower bound beyond (bounding spheres)
    near = full[~skipped] < 0.06
    np.testing.assert_allclose(done[near], full[~skipped][near], atol=1e-5)  # GJK's tolerance
    assert np.all(done[~near] <= full[~skipped][~near] + 1e-5) and np.all(done >= -1)
    assert fast.min() == pytest.approx(full.min(), abs=1e-5) and full.min() < 0
    # the search's bound: exact within 6 cm, a lower bound (bounding spheres) beyond
    coarse = c.distances_above(Q[::40], 0.06)
    exact = np.isclose(coarse, full[::40], atol=1e-5)
    assert np.all(full[::40][~exact] >= coarse[~exact]) and np.all(coarse[~exact] >= 0.06)
    assert np.all(exact[full[::40] < 0.06]) and (~exact).mean() > 0.3


def test_pairs_always_near_are_left_out_without_an_srdf(tmp_path):
    """A ball on the base around j1 (r 0.38 m) and one on l2 at j2's origin, which stays 0.3 m
    from j1 whatever the joints: always interpenetrating, the pair is left out and named; with
    disabled_pairs given, nothing is left out on the robot's behalf."""
    urdf = two_link_urdf(tmp_path)
    balls = ("    primitives:\n"
             "      - {link: base, sphere: {centre: [0, 0, 0.1], radius: 0.38}}\n"
             "      - {link: l2, sphere: {centre: [0, 0, 0], radius: 0.02}}\n")
    y = tmp_path / "arm.yaml"
    y.write_text(f"name: two_link\ndescription: {urdf.name}\nexcitation:\n  collision:\n{balls}")
    c = CollisionModel(load_robot(str(y)), "primitives")
    assert c.always_near == ["base/l2"] and c.n_pairs == 0
    y2 = tmp_path / "arm_srdf.yaml"
    y2.write_text(f"name: two_link\ndescription: {urdf.name}\nexcitation:\n  collision:\n{balls}"
                  "    disabled_pairs: [[l1, l2]]\n")
    c = CollisionModel(load_robot(str(y2)), "primitives")
    assert c.always_near == [] and c.pair_names == ["base/l2"]
