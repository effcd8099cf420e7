"""A closed-chain robot as the simulator reads it: the URDF's open tree (actuated and passive
joints, limits, inertials) and the robot YAML's loops, reference configuration, actuated
joints, nominal drive gains, payload frame and gravity.

    chain = load_chain("five_bar")     # a bundled robot name or a robot YAML with loops
    chain.joint_names                  # the actuated joints, in the YAML's order
    chain.passive, chain.loops, chain.reference

A :class:`ChainDescription` is an ArmDescription (``joints`` are the actuated joints, so the
arm's limits, trajectories, controller and truth take it as they are) with the passive joints
and the loops beside. The URDF is read by arm_description's XML parser, apart from both dynamics
engines; only the robot YAML's location rules come from the product (``model.registry``).

Units: m, rad, kg, kg·m², m/s²; gains N·m/A (revolute) or N/A (prismatic).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.model import registry
from orthoglide_sim.arms.description import MOVABLE, ArmDescription, ArmJoint, arm_joint, parse_urdf

LOOP_KINDS = ("point", "frame")  # point: the frames' origins held together; frame: welded
DEFAULT_GRAVITY = (0.0, 0.0, -9.80665)  # m/s², as the product's robot files


@dataclass(frozen=True)
class ChainLoop:
    """Two frames (links) of the tree held together: their origins (``point``, a pin or ball
    joint) or their placements (``frame``)."""

    frame_a: str
    frame_b: str
    kind: str = "point"


@dataclass(frozen=True)
class ChainDescription(ArmDescription):
    """A closed chain: ``joints`` the actuated ones (the YAML's order), ``passive`` the other
    movable joints (URDF order, nominal gain 0), ``tree_joints`` every movable joint in URDF
    order, the loops and the assembled reference configuration (joint -> m or rad)."""

    passive: tuple[ArmJoint, ...] = ()
    tree_joints: tuple[str, ...] = ()
    loops: tuple[ChainLoop, ...] = ()
    reference: tuple[tuple[str, float], ...] = ()
    gravity: tuple[float, float, float] = DEFAULT_GRAVITY

    @property
    def passive_names(self) -> tuple[str, ...]:
        return tuple(j.name for j in self.passive)

    def reference_vector(self) -> np.ndarray:
        """(n_tree,) the reference configuration over ``tree_joints`` (0 where not given)."""
        ref = dict(self.reference)
        return np.array([ref.get(j, 0.0) for j in self.tree_joints])


def _loops(data: dict, links: set[str], where: str) -> tuple[ChainLoop, ...]:
    loops = []
    for k, loop in enumerate(data.get("loops") or []):
        if not isinstance(loop, dict) or not {"frame_a", "frame_b"} <= set(loop):
            raise ConfigError(
                f"{where}: loops[{k}]: expected {{frame_a, frame_b, type}}, got {loop!r}"
            )
        kind = str(loop.get("type", "point"))
        if kind not in LOOP_KINDS:
            raise ConfigError(
                f"{where}: loops[{k}]: type {kind!r} is not {' or '.join(LOOP_KINDS)}"
            )
        for key in ("frame_a", "frame_b"):
            if loop[key] not in links:
                raise ConfigError(f"{where}: loops[{k}].{key}: {loop[key]!r} is not a link of the "
                                  "URDF (the simulator joins links: MuJoCo bodies)")
        loops.append(ChainLoop(str(loop["frame_a"]), str(loop["frame_b"]), kind))
    return tuple(loops)


def is_closed_chain(spec: str | Path) -> bool:
    """Whether ``spec`` (bundled name, robot YAML or URDF) is a robot YAML with loops."""
    path = registry.resolve(spec)
    if path is None or path.suffix.lower() not in (".yaml", ".yml"):
        return False
    return bool(registry.read_yaml(path).get("loops"))


def load_chain(spec: str | Path = "five_bar") -> ChainDescription:
    """The closed chain ``spec`` names (a bundled robot or a robot YAML with ``loops``).
    ConfigError with a one-line reason on a file that is not one."""
    path = registry.resolve(spec)
    if path is None or path.suffix.lower() not in (".yaml", ".yml"):
        raise ConfigError(
            f"robot {spec!r}: the closed-chain simulator takes a robot YAML with loops"
        )
    data = registry.read_yaml(path)
    urdf_path = (path.parent / str(data.get("description", ""))).resolve()
    if urdf_path.suffix.lower() != ".urdf" or not urdf_path.is_file():
        raise ConfigError(f"robot file {path}: description {data.get('description')!r} is not a "
                          "URDF file (the simulator loads URDFs in MuJoCo)")
    text = urdf_path.read_text()
    joints, inertials = parse_urdf(text, str(urdf_path))
    links = {j[3] for j in joints} | {j[2] for j in joints}
    loops = _loops(data, links, f"robot file {path}")
    if not loops:
        raise ConfigError(f"robot file {path}: no loops: a serial arm goes to the arm simulator")
    movable = [j for j in joints if j[1] in MOVABLE]
    by_name = {j[0]: j for j in movable}
    actuated = [str(a) for a in data.get("actuated_joints") or []]
    bad = [a for a in actuated if a not in by_name]
    if not actuated or bad:
        raise ConfigError(f"robot file {path}: actuated_joints {actuated} must name movable joints "
                          f"of the URDF ({', '.join(by_name)})")
    gains = data.get("nominal_gains", 1.0)
    gains = [float(g) for g in (gains if isinstance(gains, list) else [gains] * len(actuated))]
    if len(gains) != len(actuated):
        raise ConfigError(
            f"robot file {path}: {len(gains)} nominal gains for {len(actuated)} joints"
        )
    act = tuple(
        arm_joint(by_name[a][4], by_name[a][1], by_name[a][3], g) for a, g in zip(actuated, gains)
    )
    passive = tuple(arm_joint(el, kind, child, 0.0) for name, kind, _, child, el in movable
                    if name not in actuated)
    reference = tuple(
        (str(k), float(v)) for k, v in (data.get("reference_configuration") or {}).items()
    )
    gravity = tuple(float(g) for g in data.get("gravity", DEFAULT_GRAVITY))
    name = str(data.get("name") or urdf_path.stem)
    frame = str(data.get("payload_frame") or act[-1].child)
    return ChainDescription(name, urdf_path, text, act, inertials, frame, passive=passive,
                            tree_joints=tuple(j[0] for j in movable), loops=loops,
                            reference=reference, gravity=gravity)
