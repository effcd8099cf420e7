"""`make demo-ros2-control`: the product next to a ros2_control robot, over its real topics.

1. start the ros2_control stand-in (the simulated UR5 publishing joint_states and
   dynamic_joint_states as joint_state_broadcaster does: hardware order, a gripper joint, the
   broadcaster's QoS, a dropped tick now and then), the recorder and the identification, as
   `ros2 launch orthoglide_ident ros2_control.launch.py` would (config/ros2_control.yaml);
2. record an unloaded run through the recorder's services, mount a weighed 2.5 kg point mass at the
   payload mount while the arm runs (a stand-in parameter), record a loaded run;
3. identify: live (orthoglide/identify with no bag) and from the bags (the service, then the
   offline CLI `orthoglide-ident identify --robot ur5_mount`): the drive gains next to the plant's
   truth, live against offline, the ticks the stand-in dropped against the gaps the bags hold.

    python -m orthoglide_sim.demos.ros2_control [--record-seconds 30] [--out demo_out/ros2_control]
"""
from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from orthoglide_sim.demos.graph import Graph
from orthoglide_sim.demos.node_set import identify, live_vs_bags, record, run_demo, say
from orthoglide_sim.demos.verdict import gain_causes, verdict_line

ROOT = Path(__file__).resolve().parents[2]  # the project: config/ (installed beside the product)
ROBOT = "ur5_mount"  # the UR5 with a payload mount off the last axis (orthoglide_ident/robots)
PAYLOAD_KG = 2.5  # a point mass at the mount: what the recorder's mass-only tag describes
TOPICS = ("joint_states", "dynamic_joint_states")
STANDIN = "ros2_control_standin"


def start_graph(g: Graph, out: Path) -> None:
    from sensor_msgs.msg import JointState

    config = ROOT / "config"
    g.start(STANDIN, "driver", {"robot": ROBOT, "payload": "none", "trajectory": "exciting1"},
            params_file=config / "ros2_control.yaml")
    g.start("orthoglide_recorder", "recorder", {"output_dir": str(out / "bags")},
            params_file=config / "ros2_control.yaml")
    g.start("orthoglide_identification", "identification", {"bag_dir": str(out / "bags")},
            params_file=config / "ros2_control.yaml")
    t = g.wait_for_messages(JointState, "joint_states", 1, timeout=60.0)
    for topic in TOPICS:  # live from tick one
        g.wait_for_subscriber(topic, "orthoglide_identification")
        g.wait_for_subscriber(topic, "orthoglide_recorder")
    say(
        f"   stand-in publishing {t:.1f} s after start; recorder and identification up (logs in "
        f"{g.log_dir}/)"
    )


def truth_gains() -> np.ndarray:
    from orthoglide_sim.arms.description import load_arm
    from orthoglide_sim.arms.truth import load_truth

    return load_truth(load_arm(ROBOT)).drive_array("g_tau")


def print_gains(live, bags, g_true: np.ndarray) -> None:
    say(
        f"   {'joint':<20} {'truth':>8} {'live':>9} {'bags':>9} {'%sigma':>7} {'error':>8}  "
        f"{'nominal':>8}"
    )
    nominal = (13.0, 13.0, 13.0, 9.3, 9.3, 9.3)
    for j, name in enumerate(bags.joint_names):
        g_l, g_b, rel = live.drive_gains[j], bags.drive_gains[j], bags.drive_gains_rel_std[j]
        say(
            f"   {name:<20} {g_true[j]:8.3f} {g_l:9.3f} {g_b:9.3f} {100 * rel:6.3f}% "
            f"{100 * (g_b / g_true[j] - 1):+7.3f}%  {nominal[j]:8.1f} "
            f"({100 * (nominal[j] / g_true[j] - 1):+.1f}%)"
        )


def offline_cli(bag_paths: list[str]) -> str:
    """`orthoglide-ident identify --robot ur5_mount BAG...`: its exit code and gains line."""
    cli = Path(sys.prefix) / "bin" / "orthoglide-ident"
    run = subprocess.run([str(cli), "identify", "--robot", ROBOT, *bag_paths], capture_output=True,
                         text=True, timeout=600)
    lines = [x for x in run.stdout.splitlines() if "gain" in x.lower() or "_joint" in x][:8]
    return f"exit {run.returncode}\n" + "\n".join(f"      {x}" for x in lines)


def run(out: Path, seconds: float) -> int:
    if out.exists():
        shutil.rmtree(out)
    say(f"1. ros2_control stand-in ({ROBOT}), recorder and identification as processes")
    with Graph(out / "logs") as g:
        start_graph(g, out)
        say(
            f"2. record {seconds:.0f} s unloaded, mount {PAYLOAD_KG} kg, record {seconds:.0f} s "
            "loaded"
        )
        bag_paths = [record(g, "unloaded", "unloaded", 0.0, seconds)]
        g.set_params(STANDIN, payload=PAYLOAD_KG, trajectory="exciting2")
        time.sleep(3.0)  # the new trajectory blends in over 2 s
        bag_paths.append(record(g, "loaded", "loaded", PAYLOAD_KG, seconds))
        time.sleep(1.5)
        say("3. identify (IDIM-TLS): live data and bags, against the plant's truth")
        live = identify(g, []).parameters
        offline = identify(g, bag_paths).parameters
        print_gains(live, offline, truth_gains())
        causes = gain_causes(offline.joint_names, offline.drive_gains, offline.drive_gains_rel_std,
                             truth_gains())
        say(f"   live vs bags: {live_vs_bags(live, offline)}")
        c = g.driver_counters()  # the stand-in's /diagnostics
        say(
            f"   stand-in so far: {c['ticks']} updates, dropped {c['dropped_joint_states']} "
            "joint_states and "
            f"{c['dropped_dynamic_joint_states']} dynamic_joint_states over the whole run, "
            f"{c['late']} late"
        )
    cli = offline_cli(bag_paths)
    say(f"   offline CLI on the same bags: {cli}")
    if not cli.startswith("exit 0"):
        causes.append(f"the offline CLI on the recorded bags: {cli.splitlines()[0]}")
    say(f"bags, logs in {out}/")
    line, code = verdict_line(causes, "the offline CLI answers on the recorded bags")
    say(line)
    return code


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m orthoglide_sim.demos.ros2_control",
                                 description=__doc__.splitlines()[0])
    ap.add_argument(
        "--record-seconds", type=float, default=30.0, help="s per recording (default 30)"
    )
    ap.add_argument("--out", type=Path, default=Path("demo_out/ros2_control"), help="output folder")
    args = ap.parse_args(argv)
    return run_demo(run, args.out, args.record_seconds)


if __name__ == "__main__":
    sys.exit(main())
