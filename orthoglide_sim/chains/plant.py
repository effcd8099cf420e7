"""A closed chain's plant on MuJoCo: the URDF's open tree loaded by MuJoCo's own compiler with
the truth's inertials, drives and friction on every tree joint, and each loop closed by a MuJoCo
equality constraint (``connect`` for a point loop, ``weld`` for a frame loop) between two sites
at the origins of the loop's links.

Why it is independent of what identifies it: MuJoCo parses the URDF, builds its tree and
integrates its own constrained forward dynamics (its mass matrix, RNE bias, the loop as a
soft equality constraint solved with the friction loss by its Newton solver), and the plant
closes the loops with MuJoCo's own kinematics (``assemble``). The identification's model
(Pinocchio's regressors projected through the loops' null space, model/closure.py) shares none
of that; the one fact shared is the truth's numbers (tests/sim/chains/test_chain_plant.py checks
both,
and MuJoCo against Pinocchio's constraintDynamics).

The loop: sites, not anchors (MuJoCo computes a ``connect`` anchor from the model's q = 0 pose,
where the five-bar's two tips are 0.2 m apart; site semantics hold the sites' positions
together in every pose). MuJoCo fuses links on fixed joints into their parent unless told not
to (``fusestatic="false"``, mujoco_plant): the tips stay bodies the sites sit on. The constraint
is as stiff as MuJoCo allows: solimp at MuJoCo's maximum impedance d = 0.9999 and solref time
constant 2 steps (the stiffest its refsafe rule keeps stable). Its softness (1 - d = 1e-4)
leaves the constrained accelerations at a closed state off the rigid loop's by a torque of
~1e-4 (unloaded) to ~1e-3 (1 kg at the tip) of the applied one, tenfold more at d = 0.999:
the softness is all of it. Along a record the loop stays closed to ~5e-9 m, and the currents
the controller needs differ from those of a rigid loop (Pinocchio, same PID and reference) by
< 2e-4 of the current noise's σ rms, 5e-3 σ at most: negligible
(tests/sim/chains/test_chain_plant.py,
bench/closed_chain.py). Why so much smaller: the soft solution still meets the equation of
motion along the loop, Gᵀ(M q̈ + h - τ) = 0, exactly (its constraint force is J_cᵀ f and
J_c G = 0); only its part across the loop is off, and the loop's stiffness pulls that back.

Joint order: ``truth.arm.joint_names`` for the actuated joints (q, torques); the tree state
``q_tree`` in ``truth.arm.tree_joints`` order. Units as mujoco_plant.
"""
from __future__ import annotations

import math

import mujoco
import numpy as np

from orthoglide_ident.errors import ConfigError, WorkspaceError
from orthoglide_sim.arms.plant import (
    FRICTION_TIMECONST,
    INERTIAL_TOLERANCE,
    TIMESTEP,
    MujocoPlant,
    build_spec,
    route_warnings,
)
from orthoglide_sim.arms.truth import ArmPayload
from orthoglide_sim.chains.truth import ChainTruth

LOOP_TIMECONST = 2.0 * TIMESTEP  # s, solref of the loops: the stiffest MuJoCo keeps stable
LOOP_SOLIMP = (0.9999, 0.9999, 0.001, 0.5, 2.0)  # impedance d at MuJoCo's maximum (mjMAXIMP)
LOOP_BREAK = 1.0e-4  # m (or rad): a loop error beyond this is a broken loop (WorkspaceError)
# m: assemble() closes the loops to this (times the loop's stiffness, 4e6 s⁻², an error of
# 4e-8 m/s² in the constrained accelerations), and gives up beyond ASSEMBLY_FAIL
ASSEMBLY_TOL = 1.0e-14
ASSEMBLY_FAIL = 1.0e-10
MAX_NEWTON = 20
ASSEMBLY_STEP = 0.05  # rad (m/10): continuation step of the actuated joints in assemble()
SOLVER_TOLERANCE = 1.0e-12  # MuJoCo's Newton solver: the friction loss and loops to round-off
SITE = "loop{k}_{side}"


def _loop_sites(spec: mujoco.MjSpec, truth: ChainTruth) -> None:
    """A site at the origin of each loop link and the equality that holds them together."""
    kinds = {"point": mujoco.mjtEq.mjEQ_CONNECT, "frame": mujoco.mjtEq.mjEQ_WELD}
    for k, loop in enumerate(truth.arm.loops):
        names = []
        for side, link in (("a", loop.frame_a), ("b", loop.frame_b)):
            body = spec.body(link)
            if body is None:
                raise ConfigError(
                    f"loop {loop.frame_a}-{loop.frame_b}: {link!r} is not a MuJoCo body"
                )
            names.append(SITE.format(k=k, side=side))
            body.add_site(name=names[-1])
        eq = spec.add_equality(type=kinds[loop.kind], objtype=mujoco.mjtObj.mjOBJ_SITE,
                               name1=names[0], name2=names[1])
        eq.solref = [LOOP_TIMECONST, 1.0]
        eq.solimp = list(LOOP_SOLIMP)


def build_chain_spec(truth: ChainTruth, payload: ArmPayload | None = None) -> mujoco.MjSpec:
    """The MuJoCo specification of the chain: the arm's (inertials, actuated drives, payload),
    the passive joints' friction, the loops, the description's gravity vector."""
    spec = build_spec(truth, payload)
    spec.option.gravity = list(truth.arm.gravity)
    spec.option.tolerance = SOLVER_TOLERANCE
    spec.option.jacobian = mujoco.mjtJacobian.mjJAC_DENSE
    for name, fr in truth.passive.items():
        joint = spec.joint(name)
        joint.limited = mujoco.mjtLimited.mjLIMITED_FALSE
        joint.armature = 0.0
        joint.damping = [fr.damping] + [0.0] * (len(joint.damping) - 1)
        joint.frictionloss = fr.frictionloss
        joint.solref_friction = [FRICTION_TIMECONST, 1.0]
    _loop_sites(spec, truth)
    return spec


class ChainPlant(MujocoPlant):
    """One MuJoCo model and data of the closed chain: a MujocoPlant whose ``q``, ``qd`` and
    ``step`` are the actuated joints', the passive ones following through the loops. ``step``
    raises WorkspaceError when the loops break or a passive joint leaves its limits."""

    def __init__(self, truth: ChainTruth, payload: ArmPayload | None = None):
        self.truth, self.payload = truth, payload
        route_warnings()
        self.model = build_chain_spec(truth, payload).compile()
        self.data = mujoco.MjData(self.model)
        self._work = mujoco.MjData(self.model)  # assemble() and inverse_dynamics()
        m, arm = self.model, truth.arm
        if m.nv != len(arm.tree_joints) or m.nq != m.nv:
            raise ConfigError(f"{arm.name}: MuJoCo model has nq={m.nq}, nv={m.nv} for the "
                              f"{len(arm.tree_joints)} 1-DOF joints of the tree")
        jid = {j: mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, j) for j in arm.tree_joints}
        self.dof = np.array([m.jnt_dofadr[jid[j]] for j in arm.joint_names])
        self.passive_dof = np.array([m.jnt_dofadr[jid[j]] for j in arm.passive_names], dtype=int)
        self.tree_dof = np.array([m.jnt_dofadr[jid[j]] for j in arm.tree_joints])
        self.offset = truth.drive_array("offset")
        self.tree_offset = np.zeros(m.nv)  # every joint's offset, by dof
        self.tree_offset[self.dof] = self.offset
        self.tree_offset[self.passive_dof] = truth.passive_array("offset")
        lo = [j.lower for j in arm.passive]
        hi = [j.upper for j in arm.passive]
        self.passive_limits = (np.array(lo, float), np.array(hi, float))
        self.loop_errors: list[float] = []  # per step() call: the loops' error after it, m
        self.tree_log: list[np.ndarray] = []  # per step() call: q_tree before it
        worst = max(self.inertial_errors().items(), key=lambda kv: kv[1])
        if worst[1] > INERTIAL_TOLERANCE:
            raise ConfigError(f"MuJoCo changed the inertial of body {worst[0]} by {worst[1]:.1e} "
                              "(relative) while loading it")
        ref = np.zeros(m.nv)
        ref[self.tree_dof] = arm.reference_vector()
        self.reference = self.assemble(ref[self.dof], ref)  # closed, in the working mode
        self._last = self.reference.copy()

    # --- the loops, with MuJoCo's own kinematics -----------------------------------------
    def _loops(self, d: mujoco.MjData) -> tuple[np.ndarray, np.ndarray]:
        """(e, J_c) of the equality rows at d.qpos: residual (n_c,) and Jacobian (n_c, nv)."""
        mujoco.mj_fwdPosition(self.model, d)
        rows = d.efc_type[:d.nefc] == mujoco.mjtConstraint.mjCNSTR_EQUALITY
        J = d.efc_J[:d.nefc * self.model.nv].reshape(d.nefc, self.model.nv)
        return d.efc_pos[:d.nefc][rows].copy(), J[rows].copy()

    def loop_error(self) -> float:
        """max |e| of the loops at the plant's current state, m (or rad)."""
        self._work.qpos[:] = self.data.qpos
        return float(np.abs(self._loops(self._work)[0]).max())

    def _newton(self, q: np.ndarray) -> float:
        d, P = self._work, self.passive_dof
        res = math.inf
        for _ in range(MAX_NEWTON):
            d.qpos[:] = q
            e, J = self._loops(d)
            res = float(np.abs(e).max())
            if res < ASSEMBLY_TOL:
                return res
            q[P] -= np.linalg.lstsq(J[:, P], e, rcond=None)[0]  # a planar loop has a zero row
        return res

    def assemble(self, q_a: np.ndarray, start: np.ndarray | None = None) -> np.ndarray:
        """qpos (nq,) with the actuated joints at q_a and the loops closed, by continuation from
        ``start`` (a closed qpos; default the last one assembled). WorkspaceError if none."""
        q = (self._last if start is None else start).copy()
        q_a0 = q[self.dof].copy()
        n = max(1, int(math.ceil(np.max(np.abs(q_a - q_a0)) / ASSEMBLY_STEP)))
        for k in range(1, n + 1):
            q[self.dof] = q_a0 + (q_a - q_a0) * (k / n)
            res = self._newton(q)
            if not res < ASSEMBLY_FAIL:
                raise WorkspaceError(f"the loops of {self.truth.arm.name} do not close at "
                                     f"{np.round(q_a, 4).tolist()} (residual {res:.2g})")
        self._last = q.copy()
        return q

    def rate_map(self, qpos: np.ndarray) -> np.ndarray:
        """G (nv, n_a): tree velocities of unit actuated rates at a closed qpos (J_c G = 0)."""
        self._work.qpos[:] = qpos
        _, J = self._loops(self._work)
        G = np.zeros((self.model.nv, len(self.dof)))
        G[self.dof] = np.eye(len(self.dof))
        P = self.passive_dof
        G[P] = -np.linalg.lstsq(J[:, P], J[:, self.dof], rcond=None)[0]
        return G

    # --- state ---------------------------------------------------------------------------
    def reset(self, q: np.ndarray, qd: np.ndarray) -> None:
        """The chain assembled at actuated q with actuated rates qd (passive ones by the loops)."""
        qpos = self.assemble(np.asarray(q, float), self.reference)
        mujoco.mj_resetData(self.model, self.data)
        self.data.qpos[:] = qpos
        self.data.qvel[:] = self.rate_map(qpos) @ np.asarray(qd, float)
        mujoco.mj_forward(self.model, self.data)
        self.loop_errors, self.tree_log = [], []

    @property
    def q_tree(self) -> np.ndarray:
        """Every tree joint's position, ``truth.arm.tree_joints`` order."""
        return self.data.qpos[self.tree_dof].copy()

    def step(self, tau: np.ndarray, nstep: int) -> None:
        """``nstep`` steps under the actuated torques ``tau`` held constant, every joint's offset
        against it; then WorkspaceError if a loop broke or a passive joint left its limits."""
        self.tree_log.append(self.q_tree)
        self.data.qfrc_applied[:] = -self.tree_offset
        self.data.qfrc_applied[self.dof] += np.asarray(tau, float)
        mujoco.mj_step(self.model, self.data, nstep)
        self._check_loops()

    def _check_loops(self) -> None:
        err = self.loop_error()
        self.loop_errors.append(err)
        q_p = self.data.qpos[self.passive_dof]
        lo, hi = self.passive_limits
        out = (q_p < lo) | (q_p > hi)
        if not err < LOOP_BREAK:
            raise WorkspaceError(f"the loops of {self.truth.arm.name} broke (error {err:.2g} m) at "
                                 f"t = {self.time:.3f} s: the simulated robot stopped")
        if np.any(out):
            j = int(np.argmax(out))
            raise WorkspaceError(
                f"passive joint {self.truth.arm.passive_names[j]} = {q_p[j]:.3f} left "
                f"its limits [{lo[j]:.3f}, {hi[j]:.3f}] at t = {self.time:.3f} s: "
                "the simulated robot stopped"
            )

    # --- dynamics ------------------------------------------------------------------------
    def inverse_dynamics(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray,
                         friction: bool = False) -> np.ndarray:
        """(m, n_a) actuated torques for actuated samples (m, n_a): MuJoCo's constrained forward
        dynamics (friction loss off) inverted — q̈_a is affine in the actuated torques, its
        map read from n_a + 1 mj_forward calls per sample; ``friction``: + Gᵀ fs sign(q̇_t),
        the friction loss of every tree joint away from zero velocity."""
        q, qd, qdd = (np.atleast_2d(np.asarray(x, float)) for x in (q, qd, qdd))
        m, d, n = self.model, mujoco.MjData(self.model), len(self.dof)
        fs, flags = m.dof_frictionloss.copy(), int(m.opt.disableflags)
        m.opt.disableflags = flags | int(mujoco.mjtDisableBit.mjDSBL_FRICTIONLOSS)
        out = np.empty_like(q)
        try:
            start = self.reference
            for k in range(q.shape[0]):
                start = self.assemble(q[k], start)
                G = self.rate_map(start)
                d.qpos[:], d.qvel[:] = start, G @ qd[k]
                acc = np.empty((n + 1, n))
                for i in range(n + 1):
                    d.qfrc_applied[:] = -self.tree_offset
                    if i < n:
                        d.qfrc_applied[self.dof[i]] += 1.0
                    mujoco.mj_forward(m, d)
                    acc[i] = d.qacc[self.dof]
                out[k] = np.linalg.solve((acc[:n] - acc[n]).T, qdd[k] - acc[n])
                if friction:
                    out[k] += G.T @ (fs * np.sign(d.qvel))
        finally:
            m.opt.disableflags = flags
        return out

    def actuated_inertia(self, q: np.ndarray) -> np.ndarray:
        """(n_a,) diagonal of the reduced mass matrix Gᵀ M G (armature included) at actuated q,
        kg·m²: what a commissioning engineer tunes each joint's PID on."""
        qpos = self.assemble(np.asarray(q, float), self.reference)
        d = self._work
        d.qpos[:] = qpos
        mujoco.mj_forward(self.model, d)
        M = np.zeros((self.model.nv, self.model.nv))
        mujoco.mj_fullM(self.model, d, M)
        G = self.rate_map(qpos)
        return np.diag(G.T @ M @ G).copy()
