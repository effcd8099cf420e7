"""`make demo-excite`: from a URDF to a designed trajectory and the identified model feeding
forward,
through the robot's joint_trajectory_controller action, as a user would on a ros2_control robot.

1. `orthoglide-ident excite design --robot ur5_mount --joint-limits cell_joint_limits.yaml
   --payload-mass 2.5 --periods N --seed 0`: the trajectory file, designed for this robot, the
   range its cell allows (the simulated arm's box, inside its protective stop: a ros2_control
   joint_limits YAML) and the payload the user will mount;
2. start the ros2_control stand-in (the simulated UR5 with its payload mount, at rest: its
   joint_trajectory_controller's follow_joint_trajectory action moves it), the recorder and the
   identification (its live estimate shows during the runs), as ros2_control.launch.py would;
3. `orthoglide-ident excite run FILE --condition unloaded`; mount the weighed payload
   (`ros2 param set` of the stand-in's payload); `excite run FILE --condition loaded`;
4. `orthoglide-ident identify --robot ur5_mount` on the two bags: the gains against the plant's;
5. feed the identified model forward: the loaded run again, once with the points' effort = the
   identified model's (the JTC's effort feed-forward) and once without: the tracking errors.

    python -m orthoglide_sim.demos.excite [--periods 6] [--out demo_out/excite]
"""
from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from orthoglide_ident.errors import OrthoglideError
from orthoglide_sim.demos.graph import Graph
from orthoglide_sim.demos.node_set import ROOT, run_demo, say
from orthoglide_sim.demos.verdict import gain_causes, verdict_line

ROBOT = "ur5_mount"  # the UR5 with a payload mount off the last axis (orthoglide_ident/robots)
PAYLOAD_KG = 2.5  # a point mass at the mount, weighed: the file's loaded payload
STANDIN = "ros2_control_standin"
ACTION = "joint_trajectory_controller/follow_joint_trajectory"
PERIOD_S = 5.0  # s, the designed trajectory's period (excite design's default)
SEED = 0  # excite design's seed: the same file on every run
CLI = Path(sys.prefix) / "bin" / "orthoglide-ident"


def start_graph(g: Graph, out: Path) -> None:
    from sensor_msgs.msg import JointState

    config = ROOT / "config" / "ros2_control.yaml"
    g.start(
        STANDIN,
        "driver",
        {"robot": ROBOT, "payload": "none", "trajectory": "hold"},
        params_file=config,
    )
    g.start(
        "orthoglide_recorder", "recorder", {"output_dir": str(out / "bags")}, params_file=config
    )
    g.start(
        "orthoglide_identification",
        "identification",
        {"bag_dir": str(out / "bags")},
        params_file=config,
    )
    g.wait_for_messages(JointState, "joint_states", 1, timeout=60.0)
    for node in ("orthoglide_identification", "orthoglide_recorder"):
        g.wait_for_subscriber("/joint_states", node)


def cell_limits(path: Path) -> Path:
    """The simulated cell's joint_limits YAML: the arm's box (arm_limits), STOP_MARGIN inside the
    stand-in's protective stop; the URDF's and the robot file's limits for the rest."""
    import yaml

    from orthoglide_sim.arm_or_chain.session import robot_truth
    from orthoglide_sim.arms.limits import motion_limits, ros2_joint_limits

    arm = robot_truth(ROBOT).arm
    path.write_text(
        yaml.safe_dump(ros2_joint_limits(motion_limits(arm), arm.joint_names), sort_keys=False)
    )
    return path


def excite_design(traj: Path, limits: Path, periods: int) -> None:
    """`orthoglide-ident excite design` for the demo's robot, cell and payload (seeded:
    repeatable)."""
    run = subprocess.run(
        [
            str(CLI),
            "excite",
            "design",
            "--robot",
            ROBOT,
            "--joint-limits",
            str(limits),
            "--payload-mass",
            str(PAYLOAD_KG),
            "--periods",
            str(periods),
            "--period",
            str(PERIOD_S),
            "--seed",
            str(SEED),
            "--out",
            str(traj),
        ],
        capture_output=True,
        text=True,
        timeout=900,
    )
    if run.returncode != 0:
        raise OrthoglideError(f"excite design failed: {run.stderr.strip()}")
    for line in run.stdout.splitlines():
        say(f"   | {line}")


def excite_run(traj: Path, condition: str, name: str) -> int:
    """`orthoglide-ident excite run`, its progress passed through."""
    run = subprocess.run(
        [
            str(CLI),
            "excite",
            "run",
            str(traj),
            "--condition",
            condition,
            "--robot",
            ROBOT,
            "--name",
            name,
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        timeout=1800,
    )
    for line in run.stdout.splitlines():
        say(f"   | {line}")
    return run.returncode


def identify(bags: list[Path], out: Path) -> dict:
    path = out / "identified.json"
    run = subprocess.run(
        [str(CLI), "identify", "--robot", ROBOT, "--json", str(path), *map(str, bags)],
        capture_output=True,
        text=True,
        timeout=900,
    )
    if run.returncode != 0:
        raise OrthoglideError(f"identify failed: {run.stderr.strip()}")
    return json.loads(path.read_text())


def truth_gains():
    from orthoglide_sim.arm_or_chain.session import robot_truth

    return robot_truth(ROBOT).drive_array("g_tau")


def gains_table(doc: dict) -> tuple[float, float]:
    """Print identified vs true gains; (largest |error| %, largest |error| / σ)."""
    truth = truth_gains()
    worst_pct, worst_sigma = 0.0, 0.0
    say(f"   {'joint':<20} {'truth':>8} {'identified':>11} {'σ':>7} {'error':>8}")
    for g_true, g in zip(truth, doc["drive_gains"]):
        err = g["value"] / g_true - 1
        worst_pct, worst_sigma = (
            max(worst_pct, abs(100 * err)),
            max(worst_sigma, abs(err) / g["rel_std"]),
        )
        say(
            f"   {g['joint']:<20} {g_true:8.3f} {g['value']:11.3f} {100 * g['rel_std']:6.3f}% "
            f"{100 * err:+7.3f}%"
        )
    return worst_pct, worst_sigma


def feedforward_effort(doc: dict, points) -> np.ndarray:
    """The identified model's effort along ``points`` as the JTC's nominal-unit feed-forward:
    v_ff = tau / g_identified (eq. 17), times the nominal gains the hardware divides by."""
    from orthoglide_ident.control import CTCParameters, feedforward
    from orthoglide_ident.model.registry import load_robot

    model = load_robot(ROBOT)
    params = CTCParameters.from_values(
        [p["name"] for p in doc["parameters"]],
        [p["value"] for p in doc["parameters"]],
        [g["value"] for g in doc["drive_gains"]],
        PAYLOAD_KG,
        model,
    )
    return (
        feedforward(points.q, points.qd, points.qdd, params)
        / params.drive_gains
        * model.nominal_gains
    )


def tracking_rms(g: Graph, points, effort: np.ndarray | None) -> float:
    """rms of the position error over the goal's feedback (rad), the goal sent without recording."""
    from orthoglide_ident.excite.action_client import goal_message, send_goal

    errors: list = []
    out = send_goal(
        g.node,
        ACTION,
        goal_message(points, goal_time=1.0, effort=effort),
        points.duration,
        on_feedback=lambda fb: errors.append(fb.error.positions),
        spin=time.sleep,
    )  # g spins it
    if not out.ok:
        raise OrthoglideError(f"feed-forward run {out.status}: {out.reason}")
    return float(np.sqrt(np.mean(np.square(errors))))


def run(out: Path, periods: int) -> int:
    from orthoglide_ident.excite import plan
    from orthoglide_ident.excite.trajectory import load_trajectory

    t_start = time.monotonic()
    if out.exists():
        shutil.rmtree(out)
    out.mkdir(parents=True)
    traj = out / "ur5_excitation.yaml"
    limits = cell_limits(out / "cell_joint_limits.yaml")
    say(
        f"1. excite design --robot {ROBOT} --joint-limits {limits.name} --payload-mass "
        f"{PAYLOAD_KG} "
        ""
        ""
        ""
        ""
        f"--periods {periods} --seed {SEED}: {traj} ({periods} periods of {PERIOD_S:g} s per run)"
    )
    excite_design(traj, limits, periods)
    say(f"2. ros2_control stand-in ({ROBOT}, at rest), recorder and identification as processes")
    with Graph(out / "logs") as g:
        start_graph(g, out)
        say("3. excite run unloaded; mount the payload; excite run loaded")
        codes = [excite_run(traj, "unloaded", "unloaded")]
        g.set_params(STANDIN, payload=PAYLOAD_KG)
        say(f"   mounted {PAYLOAD_KG} kg (ros2 param set /{STANDIN} payload {PAYLOAD_KG})")
        codes.append(excite_run(traj, "loaded", "loaded"))
        if any(codes):
            raise OrthoglideError(f"excite run exited {codes}")
        say(f"4. identify --robot {ROBOT} on the two bags")
        doc = identify([out / "bags" / "unloaded", out / "bags" / "loaded"], out)
        worst_pct, worst_sigma = gains_table(doc)
        causes = gain_causes([g["joint"] for g in doc["drive_gains"]],
                             [g["value"] for g in doc["drive_gains"]],
                             [g["rel_std"] for g in doc["drive_gains"]], truth_gains())
        say(
            "5. the loaded run again through the action, without and with the identified model's "
            "feed-forward"
        )
        points = plan.excitation_points(load_trajectory(traj), "loaded")
        rms_pid = tracking_rms(g, points, None)
        rms_ff = tracking_rms(g, points, feedforward_effort(doc, points))
        c = g.driver_counters()
    wall = time.monotonic() - t_start
    say(
        f"   tracking error rms: PID alone {1e3 * rms_pid:.3f} mrad, with the feed-forward "
        f"{1e3 * rms_ff:.3f} mrad"
    )
    say(
        f"gains within {worst_pct:.3f} % and {worst_sigma:.2f} σ of the plant's; stand-in fault: "
        f"{c.get('fault') or 'none'}, {c.get('current_limited')} current-limited updates; wall "
        "time "
        ""
        ""
        ""
        f"{wall:.0f} s"
    )
    say(f"bags, logs in {out}/")
    if not rms_ff < rms_pid:
        causes.append(
            f"the identified feed-forward did not lower the tracking error ({1e3 * rms_ff:.3f} "
            f"vs {1e3 * rms_pid:.3f} mrad rms)"
        )
    if c.get("fault"):
        causes.append(f"the stand-in stopped on a fault: {c['fault']}")
    line, code = verdict_line(causes, "the feed-forward lowers the tracking error, no fault")
    say(line)
    return code


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m orthoglide_sim.demos.excite", description=__doc__.splitlines()[0]
    )
    ap.add_argument(
        "--periods",
        type=int,
        default=6,
        help=f"periods of {PERIOD_S:g} s per run (default 6: 30 s)",
    )
    ap.add_argument("--out", type=Path, default=Path("demo_out/excite"), help="output folder")
    args = ap.parse_args(argv)
    return run_demo(run, args.out, args.periods)


if __name__ == "__main__":
    sys.exit(main())
