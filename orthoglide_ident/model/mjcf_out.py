"""The identified robot as an MJCF for MuJoCo 4 (``identify … --mjcf-out FILE``).

Built from the identified URDF (``RobotModel.identified_urdf``: the physically consistent
inertials per body, the description's geometry) loaded by MuJoCo's own URDF compiler with
``inertiafromgeom="false"`` (the inertials kept exactly), then per actuated joint:

- ``armature`` = ia, the rotor inertia reflected to the joint (n² ia_m through a simple
  transmission of ratio n), ``damping`` = fv (viscous), ``frictionloss`` = fs (Coulomb);
- one ``motor`` actuator per actuator, control = the current reference (A), ``gear`` = its drive
  gain g_τ (times n through a simple transmission: τ_j = n g_τ u), ``ctrlrange`` = ± the
  robot file's ``excitation.current_limits`` where given.

A coupled transmission (q̇_m = N q̇_j, a block of N with several joints) becomes one fixed tendon
per motor (length N[a]·q): the motor's armature, damping and frictionloss on the tendon (MuJoCo
adds them as Nᵀ diag(ia) N q̈ and Nᵀ diag(fv) N q̇ to the joints, what eq. 20's reflected terms
are) and its actuator on the tendon with gear g_τ. Joints keep the URDF's names; the constant
offset tauoff has no MJCF element and is said in a comment. A robot described by an MJCF comes
back as its own file, every body's inertial replaced (and its actuators).
"""
from __future__ import annotations

import contextlib
import logging
import math
import re
from collections.abc import Iterator, Sequence
from pathlib import Path

import numpy as np

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.model.robot_file import excitation_section, per_joint
from orthoglide_ident.model.xacro_files import with_absolute_meshes

# s, the friction-loss constraint's time constant: the identified Coulomb law fs·sign(q̇) turns
# within ~0.01 rad/s (MuJoCo's default 0.02 s spreads it over ~0.15 rad/s on an exciting motion;
# MuJoCo keeps it at least two time steps)
FRICTION_TIMECONST = 2.0e-3
MESH_FORMATS = (".stl", ".obj", ".msh")  # what MuJoCo reads (not .dae)
MJCF_COMPILER = ('<mujoco><compiler balanceinertia="false" inertiafromgeom="false" '
                 'fusestatic="false" discardvisual="false" autolimits="true"/></mujoco>')


def _urdf_for_mujoco(text: str, source: Path, notes: list[str]) -> str:
    """The identified URDF with MuJoCo's compiler options and only the meshes it can read
    (absolute paths; others dropped, said in ``notes``)."""
    import xml.etree.ElementTree as ET

    root = ET.fromstring(with_absolute_meshes(text, source, ()))
    for mj in root.findall("mujoco"):
        root.remove(mj)
    dropped = []
    for link in root.findall("link"):
        for kind in ("visual", "collision"):
            for el in link.findall(kind):
                mesh = el.find("geometry/mesh")
                name = mesh.get("filename", "") if mesh is not None else ""
                if mesh is not None and not (Path(name).is_absolute() and Path(name).is_file()
                                             and Path(name).suffix.lower() in MESH_FORMATS):
                    link.remove(el)
                    dropped.append(Path(name).name)
    if dropped:
        shown = sorted(set(dropped))
        notes.append(f"{len(dropped)} mesh(es) MuJoCo cannot read or find left out "
                     f"({', '.join(shown[:4])}{', ...' if len(shown) > 4 else ''})")
    text = ET.tostring(root, encoding="unicode")
    start = text.find(">", text.find("<robot")) + 1
    return text[:start] + MJCF_COMPILER + text[start:]


def _current_limits(robot) -> dict[str, float]:
    """Actuator name -> its current limit (A) from the robot file's excitation section."""
    try:
        section, _ = excitation_section(robot)
    except ConfigError:
        return {}
    if "current_limits" not in section:
        return {}
    return per_joint(section["current_limits"], tuple(robot.joint_names),
                     f"robot {robot.name}: excitation.current_limits")


def _motor(spec, name: str, trntype, target: str, gear: float, limit: float | None) -> None:
    act = spec.add_actuator(name=name, target=target, trntype=trntype)
    act.set_to_motor()
    act.gear = [gear, 0, 0, 0, 0, 0]
    if limit is not None and math.isfinite(limit) and limit > 0:
        act.ctrlrange = [-limit, limit]


def _set_joint(joint, ia: float, fv: float, fs: float) -> None:
    joint.armature = ia
    joint.damping = [fv] + [0.0] * (len(joint.damping) - 1)
    joint.frictionloss = fs
    joint.solref_friction = [FRICTION_TIMECONST, 1.0]


def _drives(robot, chi_st: np.ndarray) -> list[dict[str, float]]:
    """Per actuator (motor side for a transmission) its ia, fv, fs, tauoff."""
    values = np.asarray(chi_st, float)
    t = robot.transmission
    if t is None:
        return [{k: float(values[i]) for k, i in robot.drive_columns(a).items()}
                for a in range(robot.n_joints)]
    named = dict(zip(robot.standard_names, values))
    return [{k: float(named.get(f"{k}_{m}", 0.0)) for k in ("ia", "fv", "fs", "tauoff")}
            for m in t.actuators]


@contextlib.contextmanager
def _quiet_urdf_out() -> Iterator[None]:
    """The identified URDF's own warnings (about its ros2_control block) are not this file's."""
    log = logging.getLogger("orthoglide_ident")
    drop = logging.Filter()
    drop.filter = lambda record: not record.getMessage().startswith("--urdf-out")
    log.addFilter(drop)
    try:
        yield
    finally:
        log.removeFilter(drop)


def _from_identified_urdf(robot, jm, chi_st, gains, notes: list[str]):
    """MuJoCo's specification of the identified URDF (consistent inertials, geometry)."""
    import mujoco

    with _quiet_urdf_out():
        urdf = robot.identified_urdf(chi_st, gains)
    text = re.sub(r"<!--.*?-->", "", _urdf_for_mujoco(urdf, jm.description.path, notes),
                  flags=re.S)
    try:
        return mujoco.MjSpec.from_string(text)
    except ValueError as exc:
        raise ConfigError(f"--mjcf-out: MuJoCo cannot load the identified URDF of {robot.name}: "
                          f"{' '.join(str(exc).split())}") from None


def _mjcf_with_inertials(robot, jm, chi_st):
    """An MJCF robot's own file with every body's identified inertial (at the body frame, as
    Pinocchio reads it) and the bodies welded to one (merged into its parameters) emptied."""
    import mujoco

    from orthoglide_ident.model.inertia import at_com

    spec = mujoco.MjSpec.from_file(str(jm.description.path))
    for a in list(spec.actuators):  # the file's own actuators: replaced by the identified ones
        spec.delete(a)
    named = {(b.frame or b.name): b for b in robot.bodies}
    chi = np.asarray(chi_st, float)[:len(jm.standard_names)] if robot is jm else \
        _joint_side(robot, chi_st)
    for body in spec.bodies:
        if body.name in named:
            m, c, inertia = at_com(chi[list(named[body.name].inertial)])
            _set_inertial(body, m, c, inertia)
        elif body.name != "world" and not body.joints and _moving(body, named):
            _set_inertial(body, 0.0, np.zeros(3), np.zeros(6))  # merged into its parent's
    return spec


def _joint_side(robot, chi_st):
    from orthoglide_ident.model.urdf_transmission import joint_side_values

    return joint_side_values(robot, chi_st)


def _moving(body, named: dict) -> bool:
    """Whether a body without joints is welded to an identified body (above it)."""
    parent = body.parent
    while parent is not None and parent.name != "world":
        if parent.name in named:
            return True
        if parent.joints:
            return False
        parent = parent.parent
    return False


def _set_inertial(body, mass: float, com: np.ndarray, inertia: np.ndarray) -> None:
    """``inertia``: about the centre of mass, (xx, xy, xz, yy, yz, zz) as at_com gives it."""
    xx, xy, xz, yy, yz, zz = (float(v) for v in inertia)
    body.explicitinertial = True
    body.mass, body.ipos, body.iquat = mass, com, [1, 0, 0, 0]
    body.inertia = [0.0, 0.0, 0.0]  # unset: the full tensor below is the one
    body.fullinertia = [xx, yy, zz, xy, xz, yz]  # MuJoCo's order


def identified_spec(robot, chi_st: np.ndarray, gains: Sequence[float]):
    """(MjSpec of the identified robot, notes for the user); module docstring."""
    import mujoco

    if robot.closure is not None:
        raise ConfigError(f"--mjcf-out: robot {robot.name} is a closed chain; its MJCF (loops as "
                          "equality constraints) is not written yet: use --urdf-out or the JSON")
    notes: list[str] = []
    jm = robot if robot.joint_model is None else robot.joint_model
    if jm.description is None:  # the closed-form Orthoglide: no bodies to write
        raise ConfigError(f"--mjcf-out: robot {robot.name} has no URDF or MJCF description to "
                          "write the identified bodies into: give --robot a described one")
    if jm.description.path.suffix.lower() == ".xml":
        spec = _mjcf_with_inertials(robot, jm, chi_st)
    else:
        spec = _from_identified_urdf(robot, jm, chi_st, gains, notes)
    spec.modelname = robot.name
    spec.option.gravity = list(robot.gravity)
    drives, limits = _drives(robot, chi_st), _current_limits(robot)
    t = robot.transmission
    N = np.eye(robot.n_joints) if t is None else np.asarray(t.N, float)
    joints = list(robot.joint_names) if t is None else list(t.joints)
    names = list(robot.joint_names) if t is None else list(t.actuators)
    for a, (d, g) in enumerate(zip(drives, gains)):
        cols = np.nonzero(N[a])[0]
        coupled = len(cols) > 1 or np.count_nonzero(N[:, cols[0]]) > 1
        limit = limits.get(robot.joint_names[a])
        if not coupled:  # a joint of its own: terms reflected by n² (ia, fv), |n| (fs)
            n, j = float(N[a, cols[0]]), joints[cols[0]]
            _set_joint(spec.joint(j), n * n * d["ia"], n * n * d["fv"], abs(n) * d["fs"])
            _motor(spec, names[a], mujoco.mjtTrn.mjTRN_JOINT, j, n * g, limit)
            continue
        tendon = spec.add_tendon(name=f"{names[a]}_drive")
        tendon.armature, tendon.frictionloss = d["ia"], d["fs"]
        tendon.solref_friction = [FRICTION_TIMECONST, 1.0]
        tendon.damping = [d["fv"]] + [0.0] * (len(tendon.damping) - 1)
        for c in cols:
            tendon.wrap_joint(joints[c], float(N[a, c]))
        _motor(spec, names[a], mujoco.mjtTrn.mjTRN_TENDON, tendon.name, float(g), limit)
    offsets = [f"{m} {d['tauoff']:.6g}" for m, d in zip(names, drives) if d.get("tauoff")]
    if offsets:
        notes.append("the identified torque offsets tauoff have no MJCF element (drive the "
                     "file with u = current - tauoff/g to move as the robot): "
                     + ", ".join(offsets))
    return spec, notes


def identified_mjcf(robot, chi_st: np.ndarray, gains: Sequence[float]) -> tuple[str, list[str]]:
    """(MJCF text, notes) of the identified robot; ConfigError if MuJoCo cannot compile it."""
    spec, notes = identified_spec(robot, chi_st, gains)
    try:
        spec.compile()
    except ValueError as exc:
        raise ConfigError(f"--mjcf-out: MuJoCo cannot compile the identified {robot.name}: "
                          f"{' '.join(str(exc).split())}") from None
    xml = re.sub(r"<general (?![^>]*\b(?:gainprm|biasprm|biastype|dyntype|gaintype)=)",
                 "<motor ", spec.to_xml())  # MuJoCo writes its motors as <general> defaults
    header = (f"<!-- Identified by orthoglide-ident (IDIM-TLS, Briot & Gautier 2013): consistent "
              f"inertials; joint armature = reflected rotor inertia, damping = viscous, "
              f"frictionloss = Coulomb friction; motor actuators: control in A, gear = drive "
              f"gain. {' '.join(notes)} -->\n")
    return header + xml, notes


def write_mjcf(path: str | Path, robot, chi_st: np.ndarray, gains: Sequence[float]) -> list[str]:
    """Write ``path``; the notes for the user."""
    text, notes = identified_mjcf(robot, chi_st, gains)
    try:
        Path(path).write_text(text)
    except OSError as exc:
        raise ConfigError(f"cannot write {path}: {exc.strerror or exc}") from None
    return notes


def answer_of_json(doc: dict, robot, where: str) -> tuple[np.ndarray, list[float]]:
    """(χ_st in ``robot.standard_names`` order, drive gains) of an ``identify --json`` document
    (the identification node's ``orthoglide/identify/json`` result) for ``robot``; ConfigError
    naming ``where`` when it holds no consistent set or is another robot's."""
    joints = list(doc.get("joint_names") or [])
    if joints != list(robot.joint_names):
        raise ConfigError(f"{where}: the answer is robot {doc.get('robot')!r}'s (joints "
                          f"{', '.join(joints)}), not {robot.name}'s "
                          f"({', '.join(robot.joint_names)}): give the robot the node identifies")
    standard = (doc.get("consistency") or {}).get("standard")
    if not isinstance(standard, dict):
        why = "a partial answer" if doc.get("complete") is False else "no consistent set"
        raise ConfigError(f"{where}: the answer holds {why}; MuJoCo needs physically consistent "
                          "inertials (the node's parameter consistent: true, every gain "
                          "determined)")
    missing = [n for n in robot.standard_names if n not in standard]
    if missing:
        raise ConfigError(f"{where}: the answer has no {', '.join(missing[:3])}"
                          f"{' ...' if len(missing) > 3 else ''} of robot {robot.name}: give the "
                          "robot the node identifies")
    chi = np.array([float(standard[n]) for n in robot.standard_names])
    return chi, [float(g["value"]) for g in doc["drive_gains"]]
