"""Simulated five-bar (closed chain, MuJoCo plant with its loop, 1 kHz PID): speed, tracking,
the loop's softness, excitation, and the identification's gain errors over a few seeds.

    .venv/bin/python bench/closed_chain.py [--seconds 20] [--seeds 3]

Prints the simulation speed (x real time) with the tracking, loop error and currents of the
unloaded and the 1 kg record; what the loop's softness (MuJoCo's equality constraint at its
maximum impedance) is worth against Pinocchio's rigid loop, at random closed states and over a
controller tick, as a torque relative to the applied one and to the current noise; cond(W) of
the designed trajectories against random Fourier series in the same box; then, per seed, the
identification (``identify_records``, the product's pipeline with its defaults, as
``orthoglide-ident identify --robot five_bar`` runs it) of ``--seconds`` unloaded + ``--seconds``
with the 1 kg payload: each gain's error, σ and error/σ, the TLS's singular-value ratio, and the
0.5 kg payload by WLS with the identified and with the nominal gains.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import mujoco
import numpy as np
from _figures import Figures, add_json_option

from orthoglide_ident.identify import identify_records
from orthoglide_ident.model.registry import load_robot
from orthoglide_sim.arms import excitation as ax
from orthoglide_sim.arms import simulator as asim
from orthoglide_sim.arms.limits import motion_limits
from orthoglide_sim.arms.plant import TIMESTEP
from orthoglide_sim.chains.description import load_chain
from orthoglide_sim.chains.pinocchio_truth import ChainDynamics, rigid_loop_currents
from orthoglide_sim.chains.plant import ChainPlant
from orthoglide_sim.chains.record import simulate_chain
from orthoglide_sim.chains.truth import apply_chain_overrides, default_chain_truth

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
from live_helpers import as_record  # noqa: E402  (the record a bag of the run holds)

EMITS_JSON = True  # --json PATH: the figures for bench/write_benchmarks.py
BEFORE = ("the last hand-written run, 60 s + 60 s (1 kg at the tip), 3 seeds: gains within "
          "0.0006–0.0074 % (bar 1 %); WLS 0.5 kg 0.49996–0.50005 kg")


def _row(label: str, values, fmt: str = "{:9.3f}") -> str:
    return f"  {label:<30}" + " ".join(fmt.format(v) for v in values)


def speed_and_tracking(truth, seconds: float) -> dict:
    """Simulate the unloaded and 1 kg records; print their figures; return the noise σ (A)."""
    noise = {}
    for payload, traj in ((None, "exciting1"), ("1.0", "exciting2")):
        t0 = time.perf_counter()
        rec = simulate_chain(seconds, payload=payload, trajectory=traj, seed=0, truth=truth)
        wall = time.perf_counter() - t0
        print(f"{traj}, {rec.payload_mass:g} kg: {seconds:g} s simulated in {wall:.2f} s = "
              f"{seconds / wall:.1f}x real time, {rec.saturated_ticks} saturated ticks")
        print(_row("tracking rms / max (mrad)", [*(1e3 * rec.tracking_rms),
                                                 *(1e3 * np.abs(rec.q_true - rec.q_ref).max(0))]))
        print(_row("loop error rms / max (nm)", [1e9 * np.sqrt(np.mean(rec.loop_error**2)),
                                                 1e9 * rec.loop_error.max()]))
        print(_row("v_tau rms (A)", np.sqrt(np.mean(rec.v_tau**2, axis=0))))
        print(_row("current noise σ (mA)", 1e3 * rec.current_noise_std))
        noise[payload] = rec.current_noise_std
    return noise


def softness(truth, robot, noise: dict, n: int = 40) -> None:
    """MuJoCo's loop against Pinocchio's rigid one: at closed states (torque Gᵀ M G Δq̈_a over
    the applied torque) and over a tick (Gᵀ M G Δq̇_a / T over the current noise's torque)."""
    print(
        "loop softness (MuJoCo equality, d = 0.9999) against Pinocchio's rigid loop, friction loss "
        "off:"
    )
    g = truth.drive_array("g_tau")
    for payload in (None, "1.0"):
        load = truth.payload(payload)
        plant, dyn = ChainPlant(truth, load), ChainDynamics(truth, load)
        plant.model.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_FRICTIONLOSS)
        q, qd, _ = robot.random_states(n, 5)
        tau = np.random.default_rng(6).normal(0.0, 3.0, q.shape)
        state, tick = [], []
        for k in range(n):
            plant.reset(q[k], qd[k])
            d = plant.data
            q0, v0 = d.qpos.copy(), d.qvel.copy()
            d.qfrc_applied[:] = -plant.tree_offset
            d.qfrc_applied[plant.dof] += tau[k]
            mujoco.mj_forward(plant.model, d)
            M = np.zeros((plant.model.nv, plant.model.nv))
            mujoco.mj_fullM(plant.model, d, M)
            G = plant.rate_map(q0)
            Mr = G.T @ M @ G
            da = (d.qacc - dyn.forward(q0, v0, tau[k]))[plant.dof]
            state.append(np.abs(Mr @ da).max() / np.abs(tau[k]).max())
            plant.step(tau[k], asim.SUBSTEPS)
            _, v1 = dyn.rk4(q0, v0, tau[k], TIMESTEP, asim.SUBSTEPS)
            dtau = Mr @ (plant.data.qvel - v1)[plant.dof] / asim.TICK
            tick.append(np.abs(dtau / (g * noise[payload])).max())
        name = "unloaded" if payload is None else f"{load.mass:g} kg"
        print(
            f"  {name:<9} at a state: median {np.median(state):.1e}, max {np.max(state):.1e} of "
            "the "
            ""
            ""
            ""
            ""
            f"torque; over a tick: median {np.median(tick):.3f}, max {np.max(tick):.3f} of the "
            "noise σ"
        )


def closed_loop_softness(truth, seconds: float) -> None:
    """The loop's softness where the identification sees it: the currents the PID needs to drive
    MuJoCo's five-bar (soft loop) and the rigid one along the same 1 kg reference, noise,
    friction loss and quantisation off (sign() and MuJoCo's smooth friction would differ by
    themselves, and one encoder count more or less moves the PID's current by ~2 noise σ)."""
    off = {"joints": {j: {"frictionloss": 0.0} for j in truth.arm.joint_names},
           "passive_joints": {j: {"frictionloss": 0.0} for j in truth.arm.passive_names},
           "encoder_counts": 2**48}  # a count changes the PID's current by ~2 σ: both exact
    t = apply_chain_overrides(truth, off)
    rec = simulate_chain(seconds, payload="1.0", trajectory="exciting2", truth=t, noise=False)
    ref = ax.designed_trajectory(t.arm, "exciting2").evaluate(np.arange(len(rec.q)) * asim.TICK)
    rigid = rigid_loop_currents(t, rec.payload, *ref)
    noisy = simulate_chain(
        1.0, payload="1.0", trajectory="exciting2", truth=truth
    ).current_noise_std
    diff = rec.v_tau - rigid
    print(
        f"soft (MuJoCo) vs rigid (Pinocchio) loop under the same PID, {seconds:g} s with 1 kg, no "
        "noise:"
    )
    print(_row("Δv_tau rms / noise σ", np.sqrt(np.mean(diff**2, axis=0)) / noisy, "{:9.1e}"))
    print(_row("Δv_tau max / noise σ", np.abs(diff).max(0) / noisy, "{:9.1e}"))


def excitation(figs: Figures, chain, robot) -> None:
    lim = motion_limits(chain)
    random = np.array([ax.condition_number(ax.random_trajectory(lim, s), robot.regressor)
                       for s in range(20)])
    print(f"cond(W), {robot.n_b} base columns, {ax.SAMPLES} samples per period:")
    designed = []
    for name in ("exciting1", "exciting2"):
        cond = ax.condition_number(ax.designed_trajectory(chain, name), robot.regressor)
        designed.append(cond)
        print(f"  {name:<30}{cond:9.1f}")
    print(
        f"  {'random Fourier (20 seeds)':<30}median {np.median(random):.1f}, best "
        f"{random.min():.1f}, "
        f"worst {random.max():.1f}"
    )
    figs.note(f"cond(W) of the designed trajectories {', '.join(f'{c:.1f}' for c in designed)} "
              f"vs random Fourier median {np.median(random):.1f} (20 seeds)")


def identification(figs: Figures, truth, robot, seconds: float, seeds: int) -> None:
    g_true = truth.drive_array("g_tau")
    table = figs.table(
        f"identification, {seconds:g} s unloaded + {seconds:g} s with 1 kg (TLS), 0.5 kg by WLS",
        ["seed", ("gain errors", "%"), ("σ", "%"), ("max |error|/σ", "σ"), "s_c/s_c-1",
         ("WLS 0.5 kg, identified / nominal gains", "kg"), ("identify", "s")])
    print(f"identification, {seconds:g} s unloaded + {seconds:g} s with 1 kg (TLS), 0.5 kg by WLS:")
    print(f"  {'seed':<5}{'error (%)':>20}{'σ (%)':>20}{'error/σ':>16}{'s_c/s_c-1':>11}"
          f"{'WLS 0.5 kg (identified / nominal gains)':>42}{'time (s)':>10}")
    for seed in range(seeds):
        plan = ((None, "exciting1"), ("1.0", "exciting2"), ("0.5", "exciting1"))
        runs = [simulate_chain(seconds, payload=p, trajectory=t, seed=3 * seed + k, truth=truth)
                for k, (p, t) in enumerate(plan)]
        recs = [as_record(r, str(k)) for k, r in enumerate(runs)]
        t0 = time.perf_counter()
        tls = identify_records(recs[:2], model=robot)
        wall = time.perf_counter() - t0
        g = np.array([x.value for x in tls.drive_gains])
        sigma = np.array([x.rel_std for x in tls.drive_gains])
        err = g / g_true - 1
        wls = identify_records([recs[0], recs[2]], method="wls", gains=list(g), model=robot)
        nominal = identify_records([recs[0], recs[2]], method="wls", model=robot)
        ratio = tls.diagnostics.solver.singular_ratio
        print(
            f"  {seed:<5}"
            + "".join(f"{100 * e:10.4f}" for e in err)
            + "".join(f"{100 * s:10.4f}" for s in sigma)
            + "".join(f"{z:8.2f}" for z in err / sigma)
            + f"{ratio:11.3f}{wls.payload_mass.value:21.5f} / {nominal.payload_mass.value:.5f} kg"
            + f"{wall:10.1f}"
        )
        table.row(seed, ", ".join(f"{100 * e:+.4f}" for e in err),
                  ", ".join(f"{100 * x:.4f}" for x in sigma), f"{np.abs(err / sigma).max():.2f}",
                  f"{ratio:.3f}", f"{wls.payload_mass.value:.5f} / "
                  f"{nominal.payload_mass.value:.5f}", f"{wall:.1f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=20.0, help="simulated seconds per record")
    ap.add_argument("--seeds", type=int, default=3, help="identifications (noise seeds)")
    add_json_option(ap)
    args = ap.parse_args()
    chain = load_chain("five_bar")
    truth, robot = default_chain_truth(chain), load_robot("five_bar")
    print(
        "five-bar on MuJoCo, RK4 4 x 0.25 ms per 1 kHz tick; actuated "
        f"{', '.join(chain.joint_names)}, "
        f"passive {', '.join(chain.passive_names)}; true gains "
        f"{np.round(truth.drive_array('g_tau'), 4)} "
        f"(nominal {chain.nominal_gains[0]:g}) N·m/A"
    )
    noise = speed_and_tracking(truth, args.seconds)
    softness(truth, robot, noise)
    closed_loop_softness(truth, min(args.seconds, 5.0))
    figs = Figures(before=BEFORE)
    excitation(figs, chain, robot)
    identification(figs, truth, robot, args.seconds, args.seeds)
    figs.write(args.json)


if __name__ == "__main__":
    main()
