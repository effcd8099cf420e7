"""The identified robot in MuJoCo (``identify … --mjcf-out``): how closely the written MJCF is the
identified model, and how it moves under the recorded currents.

    PYTHONPATH=. .venv/bin/python bench/mjcf_out.py [--seconds 20] [--window 0.5]

Per robot (the simulated UR5; the UR5 behind the coupled-wrist transmission, issue 33), records
--seconds unloaded and with the 2 kg payload are written as bags and identified as
``orthoglide-ident identify --robot R BAGS --mjcf-out FILE`` does (IDIM-TLS, consistent step).
Prints per joint:

- inverse dynamics: MuJoCo's mj_inverse on the written file (friction loss, contacts and limits
  off) vs the identified model's torques (regressor × χ_st, Coulomb friction and offsets aside)
  along the unloaded record's true states, rms difference in % of the model's rms torque (the
  issue's bar: ≤ 1 %);
- forward: the file simulated (RK4, 1 ms, friction loss on) under the recorded current
  references plus the identified offsets, restarted from the recorded state every --window s,
  rms of q_sim − q_true over the windows (rad), beside the same for the true plant's own file.
"""
from __future__ import annotations

import argparse
import contextlib
import io
import tempfile
import time
from pathlib import Path

import mujoco
import numpy as np

from orthoglide_ident.cli import main as cli_main  # noqa: E402
from orthoglide_ident.model.registry import load_robot  # noqa: E402

TICK = 1e-3
SUB = 4  # MuJoCo steps per 1 ms tick, as the simulated robots'


def _records(kind: str, seconds: float, folder: Path):
    """(robot spec, bags, the unloaded record's joint-side states and current references)."""
    if kind == "ur5":
        from orthoglide_sim.arm_or_chain.bags import write_record
        from orthoglide_sim.arms.record import simulate_arm

        runs = [simulate_arm(seconds, "ur5", payload=p, trajectory=t, seed=s)
                for p, t, s in ((None, "exciting1", 0), ("2.0", "exciting2", 1))]
        bags = [str(write_record(folder / f"ur5_{i}", r)) for i, r in enumerate(runs)]
        _records.truth = runs[0].truth  # for the baseline on the true plant
        return "ur5", bags, runs[0].q_true, runs[0].qd_true, runs[0].v_tau
    from orthoglide_sim.coupled.record import simulate_coupled, write_coupled_bag, write_robot_files
    from orthoglide_sim.coupled.truth import default_coupled_truth

    truth = default_coupled_truth()
    spec = str(write_robot_files(folder, truth)[0])
    runs = [simulate_coupled(seconds, payload=p, trajectory=t, seed=s, truth=truth)
            for p, t, s in ((None, "exciting1", 0), ("2.0", "exciting2", 1))]
    bags = [str(write_coupled_bag(folder / f"cw_{i}", r)) for i, r in enumerate(runs)]
    return spec, bags, runs[0].q_true, runs[0].qd_true, runs[0].v_tau


def _identified(spec: str, bags: list[str], folder: Path):
    """Run the CLI; (robot, χ_st consistent, gains, the MJCF path)."""
    out, js = folder / "identified.xml", folder / "r.json"
    with contextlib.redirect_stdout(io.StringIO()):  # the CLI's table
        code = cli_main(["identify", "--robot", spec, *bags, "--mjcf-out", str(out), "--json",
                         str(js), "-q"])
    assert code == 0, code
    import json

    doc = json.loads(js.read_text())
    robot = load_robot(spec)
    named = doc["consistency"]["standard"]  # the consistent answer's χ_st, as written
    chi = np.array([named[n] for n in robot.standard_names])
    return robot, chi, np.array([g["value"] for g in doc["drive_gains"]]), out


def _joint_model(path: Path):
    m = mujoco.MjModel.from_xml_path(str(path))
    m.opt.timestep, m.opt.integrator = TICK / SUB, mujoco.mjtIntegrator.mjINT_RK4
    m.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT | mujoco.mjtDisableBit.mjDSBL_LIMIT
    return m


def inverse_rms_pct(robot, chi, path, q, qd, qdd) -> np.ndarray:
    """rms(mj_inverse − model) / rms(model) in %, per actuator (motor side)."""
    m = _joint_model(path)
    m.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_FRICTIONLOSS
    d = mujoco.MjData(m)
    t = robot.transmission
    joints = robot.joint_names if t is None else t.joints
    ids = [m.joint(j).id for j in joints]
    tau_j = np.empty_like(q)
    for k in range(q.shape[0]):
        d.qpos[m.jnt_qposadr[ids]], d.qvel[m.jnt_dofadr[ids]] = q[k], qd[k]
        d.qacc[m.jnt_dofadr[ids]] = qdd[k]
        mujoco.mj_inverse(m, d)
        tau_j[k] = d.qfrc_inverse[m.jnt_dofadr[ids]]
    rigid = chi.copy()
    rigid[[i for i, n in enumerate(robot.standard_names) if n.startswith(("fs_", "tauoff_"))]] = 0
    if t is None:
        states, tau = (q, qd, qdd), tau_j
    else:
        N = np.asarray(t.N, float)
        states = (t.to_actuator_position(q), qd @ N.T, qdd @ N.T)
        tau = np.linalg.solve(N.T, tau_j.T).T  # τ_j = Nᵀ τ_m
    model = (robot.standard_regressor(*states) @ rigid).reshape(robot.n_joints, -1).T
    return 100 * np.sqrt(np.mean((tau - model) ** 2, 0) / np.mean(model ** 2, 0))


def forward_rms(robot, chi, gains, path, q, qd, v, window_s: float) -> np.ndarray:
    """rms of q_sim − q_true (rad) per joint, the file driven by the recorded currents."""
    m = _joint_model(path)
    d = mujoco.MjData(m)
    t = robot.transmission
    joints = robot.joint_names if t is None else t.joints
    ids = [m.joint(j).id for j in joints]
    qa, va = m.jnt_qposadr[ids], m.jnt_dofadr[ids]
    named = dict(zip(robot.standard_names, chi))
    acts = robot.joint_names if t is None else t.actuators
    labels = [str(a + 1) for a in range(robot.n_joints)] if t is None else list(acts)
    off = np.array([named.get(f"tauoff_{lab}", 0.0) for lab in labels])
    n = int(round(window_s / TICK))
    err = []
    for s in range(0, q.shape[0] - n, n):
        mujoco.mj_resetData(m, d)
        d.qpos[qa], d.qvel[va] = q[s], qd[s]
        for k in range(s, s + n):
            d.ctrl[:] = v[k] - off / gains  # g v = model + tauoff (no MJCF element)
            mujoco.mj_step(m, d, SUB)
            err.append(d.qpos[qa] - q[k + 1])
    return np.sqrt(np.mean(np.square(err), axis=0))


def truth_forward_rms(truth, q, qd, v, window_s: float) -> np.ndarray:
    """The same windows on the simulated UR5's own plant (its true numbers) under the same
    current references: what open-loop drift alone gives (the record moved under v + noise)."""
    from orthoglide_sim.arms.plant import MujocoPlant
    from orthoglide_sim.arms.simulator import SUBSTEPS

    plant = MujocoPlant(truth)
    g = truth.drive_array("g_tau")
    n, err = int(round(window_s / TICK)), []
    for s in range(0, q.shape[0] - n, n):
        plant.reset(q[s], qd[s])
        for k in range(s, s + n):
            plant.step(g * v[k], SUBSTEPS)
            err.append(plant.q - q[k + 1])
    return np.sqrt(np.mean(np.square(err), axis=0))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=20.0)
    ap.add_argument("--window", type=float, default=0.5)
    ap.add_argument("--robots", default="ur5,coupled")
    a = ap.parse_args()
    for kind in a.robots.split(","):
        with tempfile.TemporaryDirectory() as tmp:
            t0 = time.time()
            spec, bags, q, qd, v = _records(kind, a.seconds, Path(tmp))
            robot, chi, gains, path = _identified(spec, bags, Path(tmp))
            qdd = np.gradient(qd, TICK, axis=0)
            k = slice(100, None, 10)
            inv = inverse_rms_pct(robot, chi, path, q[k], qd[k], qdd[k])
            fwd = forward_rms(robot, chi, gains, path, q, qd, v, a.window)
            print(f"{kind}: {robot.name}, {a.seconds:g} s per record ({time.time() - t0:.0f} s)")
            print("  mj_inverse vs identified model, rms % per actuator: "
                  + ", ".join(f"{x:.3g}" for x in inv))
            print(f"  forward under the recorded currents, {a.window:g} s windows, rms q error "
                  "(mrad) per joint: " + ", ".join(f"{1e3 * x:.3g}" for x in fwd))
            if kind == "ur5":
                base = truth_forward_rms(_records.truth, q, qd, v, a.window)
                print("  the same on the true plant (its own numbers): "
                      + ", ".join(f"{1e3 * x:.3g}" for x in base))


if __name__ == "__main__":
    main()
