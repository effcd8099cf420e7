"""Expected feed-forward computed without the code under test (issue 48), for the CTC's tests.

A serial arm: a physically consistent random standard parameter set χ_st (each body's mass > 0,
rotational inertia about its centre of mass positive definite with the triangle inequality), its
base parameters χ_b = K χ_st (eq. 21), and the expected effort from Pinocchio's RNEA on the
robot's URDF with those inertias plus the drive terms written out by hand (eq. 8):
τ = RNEA(q, q̇, q̈) + ia q̈ + fv q̇ + fs sign(q̇) + τ_off, a payload a point mass at the payload
frame's origin; the current v = τ / g (eq. 17). The Orthoglide: the simulator's own plant
(orthoglide_sim/orthoglide/plant.py: the tree of its legs closed by Pinocchio's constraint
dynamics, sign() friction), a model independent of the identification's closed form.
"""
from __future__ import annotations

import numpy as np
import pinocchio as pin

INERTIAL = ("xx", "xy", "xz", "yy", "yz", "zz", "mx", "my", "mz", "m")  # the standard order
DRIVE = ("ia", "fv", "fs", "tauoff")


def random_inertia(rng: np.random.Generator) -> pin.Inertia:
    """A physically consistent body: mass 0.5..5 kg, centre of mass within 0.1 m of the link
    frame, principal moments (b + c, a + c, a + b) (the triangle inequality) in random axes."""
    m = rng.uniform(0.5, 5.0)
    com = rng.uniform(-0.1, 0.1, 3)
    a, b, c = rng.uniform(1e-3, 2e-2, 3)
    axes, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    return pin.Inertia(m, com, axes @ np.diag([b + c, a + c, a + b]) @ axes.T)


def standard_of(inertia: pin.Inertia) -> np.ndarray:
    """The ten standard parameters (INERTIAL order) of a body: the inertia matrix about the
    link frame's origin (Huygens-Steiner), the first moments m c, the mass."""
    m, c = inertia.mass, np.asarray(inertia.lever)
    J = np.asarray(inertia.inertia) + m * (c @ c * np.eye(3) - np.outer(c, c))
    return np.array([J[0, 0], J[0, 1], J[0, 2], J[1, 1], J[1, 2], J[2, 2], *(m * c), m])


def random_standard_set(robot, seed: int) -> tuple[np.ndarray, dict[str, pin.Inertia]]:
    """χ_st in ``robot.standard_names`` order (random bodies, drive terms of a real arm's size)
    and each body's inertia by link name."""
    rng = np.random.default_rng(seed)
    chi = np.zeros(len(robot.standard_names))
    bodies = {}
    for body in robot.bodies:
        bodies[body.frame] = random_inertia(rng)
        chi[list(body.inertial)] = standard_of(bodies[body.frame])
    for kind, (lo, hi) in zip(DRIVE, ((0.1, 0.5), (1.0, 5.0), (1.0, 4.0), (-0.5, 0.5))):
        chi[drive_indices(robot, kind)] = rng.uniform(lo, hi, robot.n_joints)
    return chi, bodies


def drive_indices(robot, kind: str) -> list[int]:
    """Where the joints' ``kind`` drive terms (ia, fv, ...) sit in χ_st, in joint order (named
    by joint number or motor: ia_1 .. or ia_m1 ..)."""
    found = [k for k, n in enumerate(robot.standard_names) if n.startswith(f"{kind}_")]
    assert len(found) == robot.n_joints, (kind, found)
    return found


def rnea_model(urdf: str, gravity, bodies: dict[str, pin.Inertia] | None, payload_frame: str,
               payload_mass: float) -> tuple[pin.Model, pin.Data]:
    """The URDF's kinematics with only ``bodies`` (by link; None: the URDF's own inertias) and
    the point payload as inertias."""
    model = pin.buildModelFromUrdf(str(urdf))
    model.gravity = pin.Motion(np.asarray(gravity, float), np.zeros(3))
    placed = [(payload_frame, pin.Inertia(payload_mass, np.zeros(3), np.zeros((3, 3))))]
    if bodies is not None:
        for i in range(len(model.inertias)):
            model.inertias[i] = pin.Inertia.Zero()
        placed += list(bodies.items())
    for link, inertia in placed:
        frame = model.frames[model.getFrameId(link)]
        model.inertias[frame.parentJoint] += frame.placement.act(inertia)
    return model, model.createData()


def arm_currents(robot, urdf: str, chi_st: np.ndarray, bodies: dict[str, pin.Inertia] | None,
                 gains: np.ndarray, payload_mass: float, q, qd, qdd,
                 reduction: np.ndarray | None = None) -> np.ndarray:
    """v (N - 1, n) A for ticks 0..N-2 of a joint-side reference sampled at N ticks, taken in the
    middle of each hold (the mean of consecutive samples, as the CTC defines it): RNEA plus the
    drive terms of χ_st by hand, over the gains. With a ``reduction`` N (motors q_m = N q_j +
    offset) the motors' efforts N⁻ᵀ τ_j plus their drive terms at q̇_m = N q̇_j, q̈_m = N q̈_j."""
    model, data = rnea_model(urdf, robot.gravity, bodies, robot.payload_frame, payload_mass)
    ia, fv, fs, off = (chi_st[drive_indices(robot, kind)] for kind in DRIVE)
    mid = [0.5 * (np.asarray(a)[:-1] + np.asarray(a)[1:]) for a in (q, qd, qdd)]
    tau = np.array([pin.rnea(model, data, *s) for s in zip(*mid)])
    qd_m, qdd_m = mid[1], mid[2]
    if reduction is not None:
        tau = tau @ np.linalg.inv(reduction)
        qd_m, qdd_m = qd_m @ reduction.T, qdd_m @ reduction.T
    tau += ia * qdd_m + fv * qd_m + fs * np.sign(qd_m) + off
    return tau / gains


def orthoglide_currents(gains: np.ndarray, payload_mass: float, q, qd, qdd) -> np.ndarray:
    """The Orthoglide's v (N - 1, 3) A in the middle of each hold: the simulator's plant's inverse
    dynamics with the true parameters (sign() friction, as the model's), over the gains."""
    from orthoglide_sim.orthoglide.plant import Plant
    from orthoglide_sim.orthoglide.truth import load_parameters

    mid = [0.5 * (np.asarray(a)[:-1] + np.asarray(a)[1:]) for a in (q, qd, qdd)]
    plant = Plant(load_parameters(), float(payload_mass), coulomb="sign")
    return plant.inverse_dynamics(*mid) / gains
