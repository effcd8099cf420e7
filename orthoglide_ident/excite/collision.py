"""Self-collision and the environment: Pinocchio's geometry model with coal's distances.

The robot's bodies are the URDF's ``<collision>`` elements (``mode`` "mesh": meshes found through
``package_dirs``, as ``pin.buildGeomFromUrdf`` takes them) and the robot file's primitives
(``excitation.collision.primitives``: capsules, cylinders, spheres and boxes fixed to a link; a
URDF without collision geometry, such as the bundled UR5's, gets them there), or the primitives
alone (``mode`` "primitives", when the meshes cannot be had). The environment is a floor (the
half-space above ``floor``, m along the world's z) and boxes fixed to the world.

Pairs: every two bodies on different Pinocchio joints except adjacent ones (a joint and its
parent, or two joints a loop closure holds together) and the pairs the robot file disables
(``disabled_pairs`` of link names, or an SRDF's ``<disable_collisions link1 link2>``); without
either, the pairs within 3 cm at 95 % of random poses (MoveIt's "always in collision"); the
environment against every moving body not disabled. A distance is coal's: negative when the
bodies interpenetrate. Units: m.
"""
from __future__ import annotations

import math
import os
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.excite.limits import COLLISION_MODES as MODES
from orthoglide_ident.model.robot_file import excitation_section
from orthoglide_ident.model.tree import set_joint

COLLISION_KEYS = ("primitives", "disabled_pairs", "srdf", "floor", "boxes")
SHAPES = ("capsule", "cylinder", "sphere", "box")
# pairs left out when no SRDF says which (CollisionModel._drop_always_near)
EXACT_FACTOR = 3.0  # the 1 ms check: exact distances within 3 margins, a lower bound beyond
NEAR, NEAR_SHARE, NEAR_SAMPLES, NEAR_SEED = 0.03, 0.95, 100, 0  # 1.5 default margins


def _vec(x: Any, n: int, what: str) -> np.ndarray:
    try:
        v = np.array(x, float)
    except (TypeError, ValueError):
        v = np.zeros(0)
    if v.shape != (n,) or not np.isfinite(v).all():
        raise ConfigError(f"{what}: expected {n} numbers, got {x!r}")
    return v


def _segment_placement(a: np.ndarray, b: np.ndarray) -> pin.SE3:
    """The placement whose z axis runs from a to b, origin at their middle."""
    z = b - a
    z = z / np.linalg.norm(z)
    R = pin.Quaternion.FromTwoVectors(np.array([0.0, 0.0, 1.0]), z).matrix()
    return pin.SE3(R, 0.5 * (a + b))


def primitive(spec: Any, where: str) -> tuple[Any, pin.SE3]:
    """A coal shape and its placement in the link frame from one primitive of the robot file."""
    import coal

    kinds = [k for k in SHAPES if isinstance(spec, dict) and k in spec]
    if len(kinds) != 1:
        raise ConfigError(f"{where}: each primitive is {{link, one of {', '.join(SHAPES)}}}, "
                          f"got {spec!r}")
    kind, d = kinds[0], spec[kinds[0]]
    if not isinstance(d, dict):
        raise ConfigError(f"{where}: {kind} takes a mapping, got {d!r}")
    try:
        if kind in ("capsule", "cylinder"):
            a, b = _vec(d["from"], 3, f"{where}.from"), _vec(d["to"], 3, f"{where}.to")
            r, length = float(d["radius"]), float(np.linalg.norm(b - a))
            if not (r > 0 and length > 0):
                raise ValueError("radius and length must be positive")
            shape = coal.Capsule(r, length) if kind == "capsule" else coal.Cylinder(r, length)
            return shape, _segment_placement(a, b)
        c = _vec(d.get("centre", [0, 0, 0]), 3, f"{where}.centre")
        if kind == "sphere":
            r = float(d["radius"])
            if not r > 0:
                raise ValueError("radius must be positive")
            return coal.Sphere(r), pin.SE3(np.eye(3), c)
        size = _vec(d["size"], 3, f"{where}.size")
        if not (size > 0).all():
            raise ValueError("size must be positive")
        return coal.Box(*size), pin.SE3(np.eye(3), c)
    except KeyError as exc:
        raise ConfigError(f"{where}: {kind} lacks {exc.args[0]!r}") from None
    except (TypeError, ValueError) as exc:
        raise ConfigError(f"{where}: {kind}: {exc}") from None


def resolve_mesh(filename: str, urdf: Path, package_dirs: list[str]) -> Path | None:
    """Where a URDF mesh reference points (package://, file:// or relative), or None."""
    if filename.startswith("package://"):
        pkg, _, rel = filename[len("package://"):].partition("/")
        dirs = list(package_dirs) + os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep)
        for d in filter(None, dirs):
            for cand in (Path(d) / pkg / rel, Path(d) / rel if Path(d).name == pkg else None):
                if cand is not None and cand.is_file():
                    return cand
        return None
    path = Path(filename[len("file://"):] if filename.startswith("file://") else filename)
    path = path if path.is_absolute() else urdf.parent / path
    return path if path.is_file() else None


def check_meshes(robot_name: str, urdf: Path, package_dirs: list[str]) -> int:
    """The number of <collision> elements of the URDF; ConfigError for a mesh it cannot find."""
    root = ET.parse(urdf).getroot()
    count = 0
    for link in root.iter("link"):
        for col in link.iter("collision"):
            count += 1
            for mesh in col.iter("mesh"):
                name = mesh.get("filename", "")
                if resolve_mesh(name, urdf, package_dirs) is None:
                    where = ", ".join(package_dirs) or "no --package-dir"
                    raise ConfigError(
                        f"robot {robot_name}: collision mesh {name} of link {link.get('name')} "
                        f"cannot be found ({where}): give --package-dir DIR (the folder holding "
                        "the package), or --collision primitives (the robot file's "
                        "excitation.collision.primitives) or --collision skip")
    return count


def srdf_pairs(path: Path) -> list[tuple[str, str]]:
    """The <disable_collisions link1 link2> pairs of an SRDF (MoveIt's format)."""
    try:
        root = ET.parse(path).getroot()
    except (OSError, ET.ParseError) as exc:
        raise ConfigError(f"SRDF {path}: cannot read it ({exc})") from None
    return [(e.get("link1", ""), e.get("link2", "")) for e in root.iter("disable_collisions")]


class CollisionModel:
    """The robot's collision bodies, the environment and the pairs checked (module docstring)."""

    def __init__(self, robot, mode: str = "mesh", package_dirs: list[str] | None = None):
        import coal

        if mode not in MODES:
            raise ConfigError(f"--collision must be one of {', '.join(MODES)}, not {mode!r}")
        section, folder = excitation_section(robot)
        cfg = section.get("collision") or {}
        where = f"robot {robot.name}: excitation.collision"
        if not isinstance(cfg, dict) or set(cfg) - set(COLLISION_KEYS):
            raise ConfigError(f"{where}: expected a mapping of {', '.join(COLLISION_KEYS)}")
        self.mode, self.robot = mode, robot
        self.model = robot.model
        self.geom = pin.GeometryModel()
        self.pair_names: list[str] = []
        self.floor: float | None = None
        self.n_robot = 0
        self.meshes = False
        if mode == "skip":
            self.data = None
            return
        dirs = [str(Path(d).expanduser()) for d in (package_dirs or [])]
        urdf = robot.description.path
        if (
            mode == "mesh"
            and urdf.suffix.lower() == ".urdf"
            and check_meshes(robot.name, urdf, dirs)
        ):
            self.geom = pin.buildGeomFromUrdf(self.model, str(urdf), pin.GeometryType.COLLISION,
                                              package_dirs=dirs or None)
        self._add_primitives(cfg.get("primitives") or [], f"{where}.primitives")
        if self.geom.ngeoms == 0:
            raise ConfigError(f"robot {robot.name}: no collision geometry (the description has no "
                              "<collision> element and the robot file no excitation.collision."
                              "primitives): add them, or --collision skip")
        self.n_robot = self.geom.ngeoms  # robot bodies first, then the environment
        self._add_environment(cfg, where)
        disabled = self._disabled(cfg, folder, where)
        self._pairs(self.n_robot, disabled)
        self.data = pin.GeometryData(self.geom)
        self._pin_data = self.model.createData()
        self.always_near: list[str] = []
        self.meshes = any(isinstance(g.geometry, coal.BVHModelBase)
                          for g in self.geom.geometryObjects)
        if not disabled and robot.closure is None:
            self._drop_always_near()

    def _random_configurations(self) -> np.ndarray:
        """NEAR_SAMPLES seeded tree configurations, the actuated joints uniform in their
        ranges (±π where a joint has none), mimic joints following their leader."""
        rng = np.random.default_rng(NEAR_SEED)
        Q = np.tile(pin.neutral(self.model), (NEAR_SAMPLES, 1))
        values = {}
        for j in self.robot.actuated:
            lo, hi = (j.lower, j.upper) if math.isfinite(j.lower) and math.isfinite(j.upper) \
                else (-math.pi, math.pi)
            values[j.name] = rng.uniform(lo, hi, NEAR_SAMPLES)
            set_joint(Q, j, values[j.name])
        for j, a, r, o in getattr(self.robot, "mimic_rows", ()):
            set_joint(Q, j, r * values[self.robot.actuated[a].name] + o)
        return Q

    def _drop_always_near(self) -> None:
        """Without an SRDF or disabled_pairs, the pairs within NEAR m of each other at
        ≥ NEAR_SHARE of random poses are left out, as MoveIt's setup assistant leaves out the
        pairs "always in collision": bodies drawn overlapping or touching (the
        UR10's base and upper arm at 17-21 mm whatever the joints), which no motion can part."""
        D = self.distances(self._random_configurations())
        near = (D < NEAR).mean(axis=0) >= NEAR_SHARE
        if not near.any():
            return
        pairs = list(self.geom.collisionPairs)
        self.always_near = [n for n, x in zip(self.pair_names, near) if x]
        self.geom.removeAllCollisionPairs()
        for cp, x in zip(pairs, near):
            if not x:
                self.geom.addCollisionPair(cp)
        self.pair_names = [n for n, x in zip(self.pair_names, near) if not x]
        self.data = pin.GeometryData(self.geom)

    def _link(self, name: str, where: str) -> int:
        if not self.model.existFrame(name):
            raise ConfigError(f"{where}: {name!r} is not a link of the description")
        return self.model.getFrameId(name)

    def _add_primitives(self, items: Any, where: str) -> None:
        if not isinstance(items, list):
            raise ConfigError(f"{where}: expected a list of {{link, capsule|cylinder|sphere|box}}")
        for k, spec in enumerate(items):
            if not isinstance(spec, dict) or "link" not in spec:
                raise ConfigError(f"{where}[{k}]: needs a link, got {spec!r}")
            fid = self._link(str(spec["link"]), f"{where}[{k}]")
            frame = self.model.frames[fid]
            shape, local = primitive(spec, f"{where}[{k}]")
            self.geom.addGeometryObject(pin.GeometryObject(
                f"{spec['link']}_p{k}", frame.parentJoint, fid, frame.placement * local, shape))

    def _add_environment(self, cfg: dict, where: str) -> None:
        import coal

        if cfg.get("floor") is not None:
            self.floor = float(_vec([cfg["floor"]], 1, f"{where}.floor")[0])
            self.geom.addGeometryObject(pin.GeometryObject(
                "floor", 0, 0, pin.SE3.Identity(),
                coal.Halfspace(np.array([0.0, 0.0, 1.0]), self.floor)))
        for k, box in enumerate(cfg.get("boxes") or []):
            if not isinstance(box, dict):
                raise ConfigError(f"{where}.boxes[{k}]: expected {{name, centre, size}}")
            shape, place = primitive({"box": box}, f"{where}.boxes[{k}]")
            self.geom.addGeometryObject(pin.GeometryObject(
                str(box.get("name", f"box_{k}")), 0, 0, place, shape))

    def link_of(self, g: int) -> str:
        """The link (or environment object) body ``g`` belongs to."""
        obj = self.geom.geometryObjects[g]
        return obj.name if g >= self.n_robot else self.model.frames[obj.parentFrame].name

    def _disabled(self, cfg: dict, folder: Path, where: str) -> set[frozenset[str]]:
        pairs = cfg.get("disabled_pairs") or []
        if not isinstance(pairs, list) or not all(
            isinstance(p, list) and len(p) == 2 for p in pairs
        ):
            raise ConfigError(f"{where}.disabled_pairs: expected a list of [link, link] pairs")
        out = {frozenset(map(str, p)) for p in pairs}
        if cfg.get("srdf"):
            out |= {frozenset(p) for p in srdf_pairs(folder / str(cfg["srdf"]))}
        return out

    def _adjacent_joints(self) -> set[frozenset[int]]:
        """Joints next to each other: a joint and its parent, and those a loop holds together."""
        adj = {frozenset((j, self.model.parents[j])) for j in range(1, self.model.njoints)}
        for loop in getattr(self.robot.description, "loops", ()):
            ja, jb = (self.model.frames[self.model.getFrameId(f)].parentJoint
                      for f in (loop.frame_a, loop.frame_b))
            adj.add(frozenset((ja, jb)))
        return adj

    def _pairs(self, n_robot: int, disabled: set[frozenset[str]]) -> None:
        adjacent = self._adjacent_joints()
        objs = self.geom.geometryObjects
        for a in range(self.geom.ngeoms):
            for b in range(a + 1, self.geom.ngeoms):
                ja, jb = objs[a].parentJoint, objs[b].parentJoint
                la, lb = self.link_of(a), self.link_of(b)
                env = a >= n_robot or b >= n_robot
                if (a >= n_robot and b >= n_robot) or ja == jb or frozenset((la, lb)) in disabled:
                    continue
                if not env and frozenset((ja, jb)) in adjacent:
                    continue
                self.geom.addCollisionPair(pin.CollisionPair(a, b))
                self.pair_names.append(f"{la}/{lb}")

    @property
    def n_pairs(self) -> int:
        return len(self.pair_names)

    def distances(self, Q: np.ndarray) -> np.ndarray:
        """(m, n_pairs) m: the distance of every checked pair at tree configurations Q (m, nq)."""
        out = np.full((Q.shape[0], self.n_pairs), math.inf)
        if self.data is None or not self.n_pairs:
            return out
        for k, q in enumerate(Q):
            pin.computeDistances(self.model, self._pin_data, self.geom, self.data, q)
            out[k] = [r.min_distance for r in self.data.distanceResults]
        return out

    def _spheres(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Each body's bounding sphere (centre in its frame, radius; inf for a half-space) and
        the pairs' body indices (n_pairs, 2)."""
        import coal

        if not hasattr(self, "_sphere_cache"):
            centre, radius = [], []
            for g in self.geom.geometryObjects:
                geo = g.geometry
                if isinstance(geo, coal.Halfspace):
                    centre.append(np.zeros(3))
                    radius.append(math.inf)
                    continue
                geo.computeLocalAABB()
                centre.append(np.array(geo.aabb_center))
                radius.append(float(geo.aabb_radius))
            pairs = np.array([(p.first, p.second) for p in self.geom.collisionPairs], int)
            self._sphere_cache = (np.array(centre), np.array(radius), pairs.reshape(-1, 2))
        return self._sphere_cache

    def distances_above(self, Q: np.ndarray, above: float) -> np.ndarray:
        """(m, n_pairs) like ``distances``, but a pair whose bounding spheres are ``above`` m
        apart or more gets that lower bound instead of its exact distance (coal's mesh
        distances cost ~0.3 ms a pair): what the search needs, the margin's penalty being 0
        there; the 1 ms check computes them."""
        out = np.full((Q.shape[0], self.n_pairs), math.inf)
        if self.data is None or not self.n_pairs:
            return out
        centre, radius, pairs = self._spheres()
        for i, q in enumerate(Q):
            pin.updateGeometryPlacements(self.model, self._pin_data, self.geom, self.data, q)
            world = np.array([M.rotation @ c + M.translation
                              for M, c in zip(self.data.oMg, centre)])
            lb = np.linalg.norm(world[pairs[:, 0]] - world[pairs[:, 1]], axis=1) \
                - radius[pairs[:, 0]] - radius[pairs[:, 1]]
            out[i] = lb
            for p in np.flatnonzero(~(lb >= above)):
                out[i, p] = pin.computeDistance(self.geom, self.data, int(p)).min_distance
        return out

    def _pair_speeds(self) -> np.ndarray:
        """(n_pairs, n) per pair, the bound on how fast its distance can change per unit of
        each actuated joint's speed: in body a's frame only the joints on the tree path
        between a and b move b, each point p of b at |q̇_j| |p − o_j| ≤ |q̇_j| R, R the path's
        joint offsets summed plus b's extent (mimic joints through |r|; a prismatic joint's
        unit speed counted as 1 m/s per m/s at least)."""
        import coal

        model, objs = self.model, self.geom.geometryObjects

        def support(j: int) -> set[int]:
            out = set()
            while j > 0:
                out.add(j)
                j = model.parents[j]
            return out

        def extent(g) -> float:
            if isinstance(g.geometry, coal.Halfspace) or g.parentJoint == 0:
                return 0.0  # the environment does not move
            g.geometry.computeLocalAABB()
            return float(np.linalg.norm(g.placement.translation)
                         + np.linalg.norm(g.geometry.aabb_center) + g.geometry.aabb_radius)

        weight = {j.id: (a, 1.0, j.kind == "prismatic")
                  for a, j in enumerate(self.robot.actuated)}
        for j, a, r, _ in getattr(self.robot, "mimic_rows", ()):
            weight[j.id] = (a, abs(r), j.kind == "prismatic")
        out = np.zeros((self.n_pairs, len(self.robot.actuated)))
        for k, cp in enumerate(self.geom.collisionPairs):
            ga, gb = objs[cp.first], objs[cp.second]
            path = support(ga.parentJoint) ^ support(gb.parentJoint)
            R = sum(float(np.linalg.norm(model.jointPlacements[j].translation)) for j in path) \
                + max(extent(ga), extent(gb))
            for j in path:
                a, w, prismatic = weight.get(j, (None, 0.0, False))
                if a is not None:
                    out[k, a] += w * (max(R, 1.0) if prismatic else R)
        return out

    def distances_along(self, Q: np.ndarray, qd: np.ndarray, dt: float,
                        margin: float) -> np.ndarray:
        """(m, n_pairs) m like ``distances`` for a serial robot's samples Q every ``dt`` s with
        actuated speeds qd (m, n), skipping (inf) the samples at which a pair cannot have come
        within ``margin``: a pair's distance changes at most at v = Σ_j c_j |q̇_j| over the
        joints between its bodies (``_pair_speeds``), so a pair at distance d is next computed
        (d − margin) / max v later; a pair whose bounding spheres are
        EXACT_FACTOR margins apart gets that lower bound. Exact wherever a pair nears the
        margin."""
        out = np.full((Q.shape[0], self.n_pairs), math.inf)
        if self.data is None or not self.n_pairs:
            return out
        speed = (self._pair_speeds() @ np.abs(qd).T).max(axis=1)  # (n_pairs,) m/s
        due = np.zeros(self.n_pairs, dtype=int)
        centre, radius, pairs = self._spheres()
        for i, q in enumerate(Q):
            now = np.flatnonzero(due <= i)
            if not now.size:
                continue
            pin.updateGeometryPlacements(self.model, self._pin_data, self.geom, self.data, q)
            for p in now:
                a, b = pairs[p]
                Ma, Mb = self.data.oMg[int(a)], self.data.oMg[int(b)]
                d = float(np.linalg.norm(Ma.rotation @ centre[a] + Ma.translation
                                         - Mb.rotation @ centre[b] - Mb.translation)
                          - radius[a] - radius[b])  # ≤ the distance (bounding spheres)
                if not d >= EXACT_FACTOR * margin:
                    d = pin.computeDistance(self.geom, self.data, int(p)).min_distance
                out[i, p] = d
                skip = (d - margin) / (speed[p] * dt) if speed[p] > 0 else math.inf
                due[p] = i + max(1, int(min(skip, Q.shape[0])))
        return out

    def describe(self) -> dict[str, Any]:
        """What the trajectory file records of the collision check."""
        if self.mode == "skip":
            return {"mode": "skip"}
        return {"mode": self.mode, "bodies": self.geom.ngeoms, "pairs": self.n_pairs,
                "floor_z": self.floor, "always_near_left_out": list(self.always_near)}
