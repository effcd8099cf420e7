"""Live = offline at any rate and layout, with and without a CPU hog beside (issue 47).

    PYTHONPATH=. .venv/bin/python bench/live_vs_offline_hog.py [--seconds 10] [--hogs 2]

An unloaded and a loaded run of --seconds s of a 1 kHz controller, logged at 1 kHz, 500 Hz and
~93 Hz on the logger's own 10/12/14 ms clock (untagged: current_sampling auto on both sides, no
pin), in three layouts: the UR5 stand-in's /joint_states alone (the current as effort), the
stand-in's /dynamic_joint_states current beside it, and the coupled-wrist arm behind its
transmission (joint-side positions on /joint_states, motor currents on /dynamic_joint_states).
Each is written to bags as the recorder writes them and identified offline (`identify`), and fed
to the identification node's LiveFeed with its own worker thread running, the messages handed
over as its intake hands them (10x real time), the recorder's status around them. Printed per
rate, layout and hog: JointState samples in the bag, received live, paired and used (live /
offline), the largest relative difference on the gains and on the base parameters (above 1e-3
of the largest), and the seconds from the stop until the feed ended the recording. Options:
config/identification.yaml with lag_model off (the same equations on both sides) and the
excitation checks off (equality, not accuracy). Hog: --hogs busy processes (busy_machine.py).
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

import numpy as np  # noqa: E402
from busy_machine import cpu_hog  # noqa: E402  (bench/: the busy processes)
from coupled_topics import coupled_topics  # noqa: E402  (tests/: the coupled-wrist arm's topics)
from nodes_at_any_rate import rel  # noqa: E402  (bench/: live vs offline, relative)

from orthoglide_ident import bags  # noqa: E402
from orthoglide_ident.identify import IdentifyOptions, LiveIdentification, identify  # noqa: E402
from orthoglide_ident.model.registry import load_robot  # noqa: E402

RATES = ("1kHz", "500Hz", "uneven_93Hz")
LAYOUTS = ("effort", "dynamic", "transmission")
LOST = (200, 201, 650)  # samples of each logged record lost
SPEED = 10.0  # x real time: the intake hands over 0.1 s of data every 10 ms
DONE_BOUND_S = 60.0


def at_rate(messages: list, rate: str, seed: int) -> list:
    """(stamp, js, djs) messages of a 1 kHz run logged at ``rate`` with LOST taken out."""
    rng = np.random.default_rng(seed)
    k, keep = 0, []
    while k < len(messages):
        keep.append(k)
        k += {"1kHz": 1, "500Hz": 2}.get(rate) or int(rng.choice([10, 12, 14], p=[.8, .1, .1]))
    return [messages[i] for n, i in enumerate(keep) if n not in LOST]


def standin_runs(seconds: float) -> tuple[str, dict]:
    from ros2_control_records import ROBOT, standin_records

    recs = standin_records(seconds=seconds, drop_rate=0.0)
    return ROBOT, {n: (r.condition, r.payload_mass, r.messages) for n, r in recs.items()}


def coupled_runs(seconds: float, out: Path) -> tuple[str, dict]:
    """The coupled-wrist arm (tests/coupled_topics.py: the node test's plant and topics)."""
    path, _, runs = coupled_topics(out, seconds)
    return str(path), {n: (n, r.payload_mass, [(int(s), a, b) for s, a, b in zip(
        r.stamps_ns, r.joint_states, r.dynamic_joint_states)]) for n, r in runs.items()}


def write_bag(path: Path, condition: str, mass: float, messages: list, dynamic: bool) -> str:
    with bags.BagWriter(path, bags.BagTags.checked(condition, mass)) as w:
        js = w.add_topic("/joint_states", bags.topics.JOINT_STATE_TYPE)
        djs = w.add_topic("/dynamic_joint_states", bags.topics.DYNAMIC_JOINT_STATE_TYPE) \
            if dynamic else None
        for stamp, a, b in messages:
            w.write(js, a, stamp)
            if djs is not None:
                w.write(djs, b, stamp)
    return str(path)


def _status(name: str, condition: str, mass: float, messages: list, recording: bool):
    from orthoglide_msgs.msg import RecorderStatus

    m = RecorderStatus(recording=recording, condition=condition, payload_mass=mass,
                       bag_path=name)
    for f, ns in (("first_tick", messages[0][0]), ("last_tick", messages[-1][0])):
        getattr(m, f).sec, getattr(m, f).nanosec = divmod(ns, 10**9)
    return m


def _wait(what, bound: float = DONE_BOUND_S) -> float:
    t0 = time.monotonic()
    while not what():
        if time.monotonic() - t0 > bound:
            raise TimeoutError("the live feed did not end the recording")
        time.sleep(0.005)  # a bench polls; tests wait on events
    return time.monotonic() - t0


def live_answer(node, robot: str, runs: dict, dynamic: bool, opts: IdentifyOptions):
    """The runs through LiveFeed with its worker; (result, seconds from stop to done)."""
    from orthoglide_ident.nodes.live_feed import LiveFeed
    from orthoglide_ident.nodes.live_sources import LiveTopics

    model = load_robot(robot)
    lock = threading.Lock()
    live = LiveIdentification(opts, model=model)
    topics = LiveTopics("joint_states", "", "dynamic_joint_states" if dynamic else "")
    feed = LiveFeed(node, live, lock, topics, robot=model)
    waits = []
    try:
        for name, (cond, mass, msgs) in runs.items():
            feed.on_status(_status(name, cond, mass, msgs, True))
            _wait(lambda: feed.bag == name)  # noqa: B023 - called within this iteration
            k = 0
            while k < len(msgs):
                horizon = msgs[k][0] + 100_000_000  # 0.1 s of data
                part = [m for m in msgs[k:] if m[0] < horizon]
                feed.buffers["q"].extend(m[1] for m in part)
                if dynamic:
                    feed.buffers["d"].extend(m[2] for m in part)
                k += len(part)
                time.sleep(0.1 / SPEED)
            feed.on_status(_status(name, cond, mass, msgs, False))
            waits.append(_wait(lambda: feed.bag is None and feed._jobs.empty()))
        with lock:
            return live.result(), max(waits)
    finally:
        feed.close()


def one(node, robot, runs, rate, layout, opts, tmp: Path) -> str:
    recs = {n: (c, m, at_rate(msgs, rate, i)) for i, (n, (c, m, msgs)) in enumerate(runs.items())}
    dynamic = layout != "effort"
    tmp.mkdir(parents=True, exist_ok=True)
    paths = [write_bag(tmp / f"{rate}_{layout}_{n}", c, m, msgs, dynamic)
             for n, (c, m, msgs) in recs.items()]
    off = identify(paths, model=load_robot(robot), options=opts)
    res, wait = live_answer(node, robot, recs, dynamic, opts)
    dg, dp = rel(res, off)
    dl, do = res.record_reports, off.record_reports
    n_bag = sum(len(msgs) for _, _, msgs in recs.values())
    return (f"{n_bag:>7} {sum(d.n_joint_states for d in dl):>7} "
            f"{sum(d.n_paired for d in dl):>6}/{sum(d.n_paired for d in do):<6} "
            f"{sum(d.n_used for d in dl):>6}/{sum(d.n_used for d in do):<6} "
            f"{dg:>9.1e} {dp:>9.1e} {wait:>6.2f}  {dl[0].current_sampling}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--hogs", type=int, default=2)
    args = ap.parse_args()
    import rclpy

    opts = IdentifyOptions.from_yaml(str(ROOT / "config/identification.yaml")).replace(
        check_excitation=False, partial_answers=False, lag_model="off")
    commit = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"],
                            capture_output=True, text=True).stdout.strip()
    print(f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, commit {commit}: "
          f"{args.seconds:g} s unloaded + {args.seconds:g} s loaded per layout, {len(LOST)} "
          f"samples lost per record, fed at {SPEED:g}x real time")
    print(f"{'rate':<12} {'layout':<13} {'hog':<4} {'in bag':>7} {'in live':>7} "
          f"{'paired l/o':>13} {'used l/o':>13} {'gains':>9} {'params':>9} {'stop s':>6}  read")
    rclpy.init()
    node = rclpy.create_node("bench_live_vs_offline_hog")
    try:
        with tempfile.TemporaryDirectory() as tmp:
            tmp = Path(tmp)
            sources = {"effort": standin_runs(args.seconds)}
            sources["dynamic"] = sources["effort"]
            sources["transmission"] = coupled_runs(args.seconds, tmp)
            for hogs in (0, args.hogs):
                with cpu_hog(hogs):
                    for rate in RATES:
                        for layout in LAYOUTS:
                            robot, runs = sources[layout]
                            try:
                                line = one(node, robot, runs, rate, layout, opts,
                                           tmp / str(hogs))
                            except Exception as exc:  # noqa: BLE001 - a figure, not a crash
                                line = f"{type(exc).__name__}: {str(exc)[:100]}"
                            print(f"{rate:<12} {layout:<13} {hogs:<4} {line}", flush=True)
    finally:
        node.destroy_node()
        rclpy.shutdown()


if __name__ == "__main__":
    main()
