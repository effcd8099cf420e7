"""``excite design`` with its defaults on arms it never saw (example-robot-data) and on the
bundled UR5 and five-bar.

    PYTHONPATH=. .venv/bin/python bench/excite_unseen.py [--robots ur10,panda,...] [--restarts R]
                                                         [--steps S] [--collision mesh|skip]
                                                         [--search walk|gradient]

Times: the design's wall time and this process's CPU time (the machine is shared: the CPU
time compares runs made under different loads). Each unseen arm is used as its URDF comes, with
no hand edit: where the URDF alone cannot be used, a three-line robot file a user would write
(FILE_KEYS) fixes a gripper by the product's ``locked_joints`` key (the Panda's fingers, the
Z1's and the SO-101's grippers) or gives a continuous joint a range (the Kinova's), with
a 1 kg payload on its last link and nothing else: no acceleration limits (the derived default;
``--acceleration`` gives every joint one, as a joint_limits file would), no start pose (the
file's, else mid-range out of self-collision). Per robot: design time, the predicted worst
gain σ and κ of the design against the median of the random feasible shapes, the smallest
slack to the margins on the 1 ms grid, or the refusal.

``--achieved ur10 --seeds 3 --payload-kg 2 [--payload-com X,Y,Z]``: predicted vs achieved σ on
the arm's simulated runs. The design (defaults, a ``--payload-kg`` point mass on the last link,
or the simulator's offset body with its CoM and inertia given, the design's default current
noise) is tracked by the MuJoCo plant built from the URDF alone
(orthoglide_sim.arms: its own inertials perturbed by the seeded rule, gains 2-6 % off nominal,
friction, rotor inertia, 0.5 % white current noise, encoders; the same payload welded to the
last link) and identified by ``identify_records``. The prediction (eq. 39 at the nominal model)
is given with three noise assumptions: the design's default (DEFAULT_CURRENT_NOISE), the
simulation's white current noise, and the equation error of a pilot identification of the
same runs under other noise seeds (what ``excite design --noise-from`` takes).
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from identify.test_on_arm import as_record  # noqa: E402

from orthoglide_ident.errors import OrthoglideError  # noqa: E402
from orthoglide_ident.excite.collision import CollisionModel  # noqa: E402
from orthoglide_ident.excite.design import DesignOptions, design  # noqa: E402
from orthoglide_ident.excite.limits import read_limits  # noqa: E402
from orthoglide_ident.excite.prediction import (  # noqa: E402
    DEFAULT_CURRENT_NOISE,
    RunSamples,
    noise_from_result,
    predict,
)
from orthoglide_ident.excite.summary import with_extras  # noqa: E402
from orthoglide_ident.excite.trajectory import save_trajectory  # noqa: E402
from orthoglide_ident.identify import identify_records  # noqa: E402
from orthoglide_ident.model.registry import load_robot  # noqa: E402
from orthoglide_ident.model.robot import Payload  # noqa: E402
from orthoglide_sim.arm_or_chain.session import resolve_payload, robot_truth  # noqa: E402
from orthoglide_sim.arms.plant import MujocoPlant  # noqa: E402
from orthoglide_sim.arms.record import simulate_arm  # noqa: E402
from orthoglide_sim.arms.simulator import joint_inertia  # noqa: E402
from orthoglide_sim.arms.truth import with_offset_payload  # noqa: E402
from orthoglide_sim.demos.designed_runs import (  # noqa: E402
    simulate_designed,
    stop_limits,
)

SHARE = Path(sys.prefix) / "lib/python3.11/site-packages/cmeel.prefix/share"
ERD = SHARE / "example-robot-data/robots"
UNSEEN = {"ur10": "ur_description/urdf/ur10_robot.urdf",
          "ur3": "ur_description/urdf/ur3_robot.urdf",
          "panda": "panda_description/urdf/panda.urdf",
          "xarm7": "xarm_description/urdf/xarm7.urdf",
          "z1": "z1_description/urdf/z1.urdf",
          "kinova": "kinova_description/robots/kinova.urdf",
          "so101": "so_arm_description/urdf/so101.urdf"}
# The robot-file keys a user adds when the URDF alone cannot be used (docs/guide/robot_files.md):
# a gripper's joints locked (model/locked_joints.py), continuous joints given a range.
CONTINUOUS = "[-3.1416, 3.1416]"  # rad: one turn for a continuous joint (the URDF gives none)
FILE_KEYS = {"panda": "locked_joints: {panda_finger_joint1: 0.0}",  # finger 2 mimics 1; closed
             "z1": "locked_joints: {jointGripper: 0.0}",  # the gripper's jaw, closed
             "so101": "locked_joints: {gripper: 0.0}",
             "kinova": "excitation: {position_limits: {" + ", ".join(
                 f"j2s6s200_joint_{k}: {CONTINUOUS}" for k in (1, 4, 6)) + "}}"}
BUNDLED = {"ur5": Payload(2.0, "tool0", (0.035, -0.025, 0.06), (4e-3, 0, 0, 4e-3, 0, 2.5e-3)),
           "five_bar": Payload(1.0, "tip", (0.01, 0.0, 0.02), (1e-4, 0, 0, 1e-4, 0, 1e-4))}
UNSEEN_PAYLOAD_KG = 1.0


def unseen_spec(name: str, folder: Path) -> Path:
    """The arm's URDF, or a robot file in ``folder`` with its FILE_KEYS."""
    if name not in FILE_KEYS:
        return ERD / UNSEEN[name]
    out = folder / f"{name}.yaml"
    out.write_text(f"name: {name}\ndescription: {ERD / UNSEEN[name]}\n{FILE_KEYS[name]}\n")
    return out


def _limits_file(robot, acceleration: float | None, folder: Path) -> Path | None:
    """A ros2_control joint_limits file giving every joint ``acceleration`` (as a user would
    write before this work), or None (the derived default)."""
    if acceleration is None:
        return None
    path = folder / f"{robot.name}_limits.yaml"
    path.write_text("joint_limits:\n" + "".join(
        f"  {j}:\n    has_acceleration_limits: true\n    max_acceleration: {acceleration}\n"
        for j in robot.joint_names))
    return path


def _kappa(p) -> float:
    """κ of the directions a design excites (the code before: κ of all)."""
    return p.condition_kept if hasattr(p, "condition_kept") else p.condition


def _worst(p) -> float:
    """The worst determined gain's σ (the code before this bench had only ``worst_gain``)."""
    return p.worst_determined_gain() if hasattr(p, "worst_determined_gain") else p.worst_gain


def run(name: str, args, folder: Path) -> None:
    if name in BUNDLED:
        robot, payload = load_robot(name), BUNDLED[name]
    else:
        robot = load_robot(str(unseen_spec(name, folder)))
        payload = Payload(UNSEEN_PAYLOAD_KG)
    t0, c0 = time.perf_counter(), time.process_time()
    try:
        limits = read_limits(robot, _limits_file(robot, args.acceleration, folder)
                             if name not in BUNDLED else None)
        collision = CollisionModel(robot, args.collision, [str(SHARE)])
        extra = {"time_limit_s": args.time_limit} if args.time_limit else {}
        opt = DesignOptions(payload, np.full(robot.n_joints, DEFAULT_CURRENT_NOISE),
                            restarts=args.restarts, steps=args.steps, search=args.search, **extra)
        d = design(robot, limits, collision, opt,
                   progress=lambda s: print(f"  {name}: {s}", file=sys.stderr))
    except OrthoglideError as exc:
        print(f"{name:<9} refused after {time.perf_counter() - t0:.1f} s: {exc}")
        return
    rand = [e.prediction for e in d.random if e.prediction is not None]
    med_s = np.median([_worst(p) for p in rand]) if rand else np.nan
    med_k = np.median([_kappa(p) for p in rand]) if rand else np.nan
    slack = min(s.value - s.required for k, s in d.check.by_kind().items() if k != "at_rest")
    gone = [u.to_text().split(" (")[0] for u in getattr(d.prediction, "unexcited", ())]
    coll = d.check.by_kind().get("collision")
    cpu = time.process_time() - c0  # the load of the shared machine aside
    print(f"{name:<9} {robot.n_joints} joints  {d.seconds:6.1f} s (cpu {cpu:5.1f} s)  worst gain σ "
          f"{100 * _worst(d.prediction):.3g} % (random median {100 * med_s:.3g} %)  κ "
          f"{_kappa(d.prediction):.3g} (median {med_k:.3g})  min slack {slack:.3g}  "
          f"collision {coll.value if coll else float('nan'):.3g} m  "
          f"{len(rand)} random feasible"
          + (f"  not excited: {'; '.join(gone)}" if gone else ""))


def softest_pose(traj, run: str, truth) -> np.ndarray:
    """The pose of ``run`` (sampled every 50 ms) where the unloaded plant's joint inertias are
    smallest (least Σ log M_jj): a PID tuned there is not too stiff anywhere on the run."""
    q = traj.evaluate(run, np.arange(0.0, traj.period_s, 0.05))[0]
    plant = MujocoPlant(truth)
    return q[int(np.argmin([np.log(joint_inertia(plant, x)).sum() for x in q]))]


def simulated(traj, truth, robot, load: str, seed: int, tune: str = "start"):
    """The unloaded and loaded runs of ``traj`` on the plant (noise seeds 2·seed, 2·seed + 1),
    their identification, the simulation's white current noise (n,) A of each run and its
    saturated ticks. ``tune``: the PID tuned at the run's start pose (simulate_designed), or at
    its softest pose (softest_pose)."""
    recs = []
    for k, (run, pl) in enumerate((("unloaded", None), ("loaded", load))):
        if tune == "start":
            recs.append(simulate_designed(traj, run, truth, pl, seed=2 * seed + k))
            continue
        limits = replace(stop_limits(traj, run), centre=softest_pose(traj, run, truth))
        recs.append(simulate_arm(traj.duration, payload=pl, trajectory=traj.series(run),
                                 seed=2 * seed + k, truth=truth, limits=limits))
    u, lo = recs
    res = identify_records([as_record(u, f"u{seed}"), as_record(lo, f"l{seed}")], model=robot)
    print(f"  seed {seed}: saturated ticks {u.saturated_ticks} + {lo.saturated_ticks} of "
          f"{2 * len(u.q)}", file=sys.stderr)
    return res, (u.current_noise_std, lo.current_noise_std)


def plant_and_payload(spec: str, mass: float, com: str | None):
    """The plant's truth from the URDF with a payload named "load", and the design's Payload:
    a point mass at the last link's origin, or (``com`` "x,y,z" m) the simulator's offset body
    there (with_offset_payload), its CoM and inertia given to the design (--payload-com)."""
    truth = robot_truth(spec)
    if com is None:
        point = resolve_payload(truth, f"{mass:g}")
        return replace(truth, payloads={**truth.payloads, "load": point}), Payload(mass)
    truth = with_offset_payload(truth, mass, tuple(float(c) for c in com.split(",")),
                                name="load")
    body = truth.payloads["load"].body
    I = body.inertia
    return truth, Payload(mass, "", tuple(map(float, body.com)), tuple(
        float(I[a, b]) for a, b in ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))))


def pilot_noise(pilot, robot) -> np.ndarray:
    """--noise-from of the pilot identification; NaN where it leaves a gain undetermined."""
    try:
        return noise_from_result(pilot.to_json(), robot.joint_names, "pilot")
    except OrthoglideError as exc:
        print(f"  pilot residual: {exc}", file=sys.stderr)
        return np.full(robot.n_joints, np.nan)


def achieved(name: str, args, folder: Path) -> None:
    """Predicted vs achieved σ of the gains of arm ``name`` (module docstring)."""
    spec = str(unseen_spec(name, folder))
    robot = load_robot(spec)
    truth, load = plant_and_payload(spec, args.payload_kg, args.payload_com)
    limits = read_limits(robot)
    collision = CollisionModel(robot, args.collision, [str(SHARE)])
    opt = DesignOptions(load, np.full(robot.n_joints, DEFAULT_CURRENT_NOISE),
                        restarts=args.restarts, steps=args.steps, search=args.search)
    d = design(robot, limits, collision, opt, progress=lambda s: print("  " + s, file=sys.stderr))
    traj = with_extras(d, limits, collision, "default")
    if args.out:
        save_trajectory(traj, args.out)
    t = np.linspace(0.0, traj.period_s, 400, endpoint=False)
    pilot, white = simulated(traj, truth, robot, "load", 100, args.tune)
    noises = {"design default": np.full(robot.n_joints, DEFAULT_CURRENT_NOISE),
              "sim white": list(white), "pilot residual": pilot_noise(pilot, robot)}
    pred = {}
    for label, noise in noises.items():
        per_run = noise if isinstance(noise, list) else [noise, noise]
        runs = [RunSamples(*traj.evaluate(rn, t), traj.duration, pl, nz) for rn, pl, nz in
                zip(("unloaded", "loaded"), (None, load), per_run)]
        pred[label] = predict(robot, runs, per_run[0], lag=True,
                              period_s=traj.period_s).gain_rel_std
    g_true, errs, paper, honest = truth.drive_array("g_tau"), [], [], []
    num = lambda v: np.nan if v is None else v  # noqa: E731  (an undetermined gain)
    for seed in range(args.seeds):
        res, _ = simulated(traj, truth, robot, "load", seed, args.tune)
        errs.append(np.array([num(x.value) for x in res.drive_gains]) / g_true - 1)
        paper.append([num(x.rel_std_paper) for x in res.drive_gains])
        honest.append([num(x.rel_std) for x in res.drive_gains])
    errs, paper, honest = (np.array(x, float) for x in (errs, paper, honest))
    print_achieved(name, d, robot, pred, noises, errs, paper, honest)


def print_achieved(name, d, robot, pred, noises, errs, paper, honest) -> None:
    sd = errs.std(axis=0, ddof=1) if len(errs) > 1 else np.full(errs.shape[1], np.nan)
    print(f"\n{name}: designed in {d.seconds:.1f} s, {d.trajectory.duration:g} s per run; "
          f"predicted vs achieved σ of the gains (%), {len(errs)} seeds")
    for k, v in noises.items():  # the simulation's: unloaded and loaded runs, else one for both
        print(f"  noise {k} (A at 1 kHz): {np.round(v, 4).tolist()}")
    heads = [f"pred {k}" for k in pred] + ["eq. 39", "honest", "sd(err)", "mean err",
                                           "max|err|/hon"]
    print(f"  {'joint':<20}" + "".join(f"{h:>17}" for h in heads))
    for j, jn in enumerate(robot.joint_names):
        cells = [100 * p[j] for p in pred.values()] + [
            100 * paper[:, j].mean(), 100 * honest[:, j].mean(), 100 * sd[j],
            100 * errs[:, j].mean()]
        ratio = np.abs(errs[:, j]).max() / honest[:, j].mean()
        print(f"  {jn:<20}" + "".join(f"{c:>17.4f}" for c in cells) + f"{ratio:>17.2f}")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--robots", default="ur5,five_bar," + ",".join(UNSEEN))
    ap.add_argument("--achieved", default=None, help="predicted vs achieved σ on this arm")
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--payload-kg", type=float, default=2.0, help="with --achieved")
    ap.add_argument("--payload-com", default=None, metavar="X,Y,Z",
                    help="with --achieved: an offset payload (m), else a point mass")
    ap.add_argument("--tune", default="start", help="with --achieved: start | softest, the "
                    "pose the simulated joint PID is tuned at (simulated; an arm where it would "
                    "be too stiff gets the mass-matrix PID: simulator.MAX_STIFFNESS)")
    ap.add_argument("--out", default=None, help="with --achieved: the trajectory file written")
    ap.add_argument("--restarts", type=int, default=20)
    ap.add_argument("--steps", type=int, default=None)
    ap.add_argument("--time-limit", type=float, default=None)
    ap.add_argument("--collision", default="mesh")
    ap.add_argument("--search", default="gradient", help="gradient | walk (excite/gradient.py)")
    ap.add_argument("--acceleration", type=float, default=None,
                    help="rad/s² for every joint of an unseen arm (default: derived)")
    args = ap.parse_args()
    print(f"restarts {args.restarts}, steps {args.steps}, search {args.search}, "
          f"collision {args.collision}, "
          f"time limit {args.time_limit}, acceleration {args.acceleration or 'derived'}")
    with tempfile.TemporaryDirectory() as tmp:
        if args.achieved:
            achieved(args.achieved, args, Path(tmp))
            return
        for name in args.robots.split(","):
            run(name, args, Path(tmp))


if __name__ == "__main__":
    main()
