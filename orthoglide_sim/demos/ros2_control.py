"""`make demo-ros2-control`: the product next to a ros2_control robot, over its real topics.

1. start the ros2_control stand-in (the simulated UR5 publishing joint_states and
   dynamic_joint_states as joint_state_broadcaster does: hardware order, a gripper joint, the
   broadcaster's QoS, a dropped tick now and then), the recorder and the identification, as
   `ros2 launch orthoglide_ident ros2_control.launch.py` would (config/ros2_control.yaml);
2. record an unloaded run through the recorder's services, mount a weighed 2.5 kg point mass at the
   payload mount while the arm runs (a stand-in parameter), record a loaded run;
3. identify: live (orthoglide/identify with no bag) and from the bags (the service, then the
   offline CLI `orthoglide-ident identify --robot ur5_mount`): the drive gains next to the plant's
   truth, live against offline, the ticks the stand-in dropped against the gaps the bags hold;
4. the identified robot for MuJoCo: the identification node writes ``identified.xml`` (its
   parameter mjcf_out); MuJoCo loads it and its inverse dynamics along the unloaded record is
   the node's identified (consistent) model's within 1 % rms per joint (model/mjcf_check.py).

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

from orthoglide_ident.errors import OrthoglideError
from orthoglide_ident.model.mjcf_check import RMS_BAR, inverse_dynamics_rms
from orthoglide_sim.demos.graph import Graph
from orthoglide_sim.demos.node_set import identify, live_vs_bags, record, run_demo, say
from orthoglide_sim.demos.verdict import gain_causes, verdict_line

ROOT = Path(__file__).resolve().parents[2]  # the project: config/ (installed beside the product)
ROBOT = "ur5_mount"  # the UR5 with a payload mount off the last axis (orthoglide_ident/robots)
PAYLOAD_KG = 2.5  # a point mass at the mount: what the recorder's mass-only tag describes
TOPICS = ("joint_states", "dynamic_joint_states")
STANDIN = "ros2_control_standin"
MJCF_NAME = "identified.xml"  # the node's mjcf_out, in the demo's output folder
STATE_STEP = 10  # every 10th sample of the record (100 Hz) for the MJCF's check


def start_graph(g: Graph, out: Path) -> None:
    from sensor_msgs.msg import JointState

    config = ROOT / "config"
    g.start(STANDIN, "driver", {"robot": ROBOT, "payload": "none", "trajectory": "exciting1"},
            params_file=config / "ros2_control.yaml")
    g.start("orthoglide_recorder", "recorder", {"output_dir": str(out / "bags")},
            params_file=config / "ros2_control.yaml")
    g.start("orthoglide_identification", "identification",
            {"bag_dir": str(out / "bags"), "mjcf_out": str(out / MJCF_NAME),
             # the consistent bodies MuJoCo needs take the payload whole: it is a point mass
             "payload_known": "point"},
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


def node_json(g: Graph, stamp) -> dict:
    """The node's answer of this ``stamp`` as ``identify --json`` writes it (its latched
    orthoglide/identify/json)."""
    import json

    from std_msgs.msg import String

    want = {"sec": stamp.sec, "nanosec": stamp.nanosec}
    msg = g.latched(String, "orthoglide/identify/json",
                    lambda m: json.loads(m.data).get("stamp") == want)
    return json.loads(msg.data)["result"]


def record_states(bag: str, robot) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(q, q̇, q̈) along a recorded run: its positions every STATE_STEP samples, the rates by
    central differences (any states serve: both models are evaluated at the same ones)."""
    from orthoglide_ident.identify.records.record import read_record

    rec = read_record(bag, robot)
    cols = [list(rec.names_q).index(j) for j in robot.joint_names]
    t = np.asarray(rec.stamps_q_ns, float)[::STATE_STEP] * 1e-9
    q = np.asarray(rec.q)[::STATE_STEP, cols]
    qd = np.gradient(q, t, axis=0)
    return q[2:-2], qd[2:-2], np.gradient(qd, t, axis=0)[2:-2]


def check_mjcf(path: Path, result: dict, bag: str) -> tuple[str, list[str]]:
    """MuJoCo loads the node's MJCF, and its inverse dynamics along ``bag``'s states is the
    identified model's (``result``: the node's JSON) within RMS_BAR per joint; (line, causes)."""
    import mujoco

    from orthoglide_ident.model.mjcf_out import answer_of_json
    from orthoglide_ident.model.registry import load_robot

    if not path.is_file():
        return f"{path} not written", [f"{path.name} not written by the node (mjcf_out)"]
    try:
        m = mujoco.MjModel.from_xml_path(str(path))
        robot = load_robot(ROBOT)
        chi, _ = answer_of_json(result, robot, str(path))
    except (ValueError, OrthoglideError) as e:
        return f"{path}: {e}", [f"{path.name}: {' '.join(str(e).split())}"]
    q, qd, qdd = record_states(bag, robot)
    rms = inverse_dynamics_rms(path.read_text(), robot, chi, q, qd, qdd)
    line = (f"{path}: MuJoCo loads it ({m.njnt} joints, {m.nu} motors); its inverse dynamics "
            f"along {len(q)} states of the unloaded run vs the identified model: "
            + ", ".join(f"{j} {100 * r:.1e} %" for j, r in zip(robot.joint_names, rms)) + " rms")
    bad = [f"{path.name}: {j} {100 * r:.2f} % rms from the identified model (bar "
           f"{100 * RMS_BAR:.0f} %)" for j, r in zip(robot.joint_names, rms) if not r <= RMS_BAR]
    return line, bad


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
        answer = identify(g, bag_paths)
        offline = answer.parameters
        result = node_json(g, offline.header.stamp)
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
    say(f"4. the identified robot for MuJoCo: {answer.message.rsplit('; ', 1)[-1]}")
    line, causes_mjcf = check_mjcf(out / MJCF_NAME, result, bag_paths[0])
    say(f"   {line}")
    causes += causes_mjcf
    cli = offline_cli(bag_paths)
    say(f"   offline CLI on the same bags: {cli}")
    if not cli.startswith("exit 0"):
        causes.append(f"the offline CLI on the recorded bags: {cli.splitlines()[0]}")
    say(f"bags, logs in {out}/")
    line, code = verdict_line(
        causes,
        f"{MJCF_NAME} loads in MuJoCo and moves as the identified model within "
        f"{100 * RMS_BAR:.0f} % rms per joint",
        "the offline CLI answers on the recorded bags",
    )
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
