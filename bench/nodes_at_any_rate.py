"""The node set at a real robot's rate (issue 47): recorder's missing count, live = offline.

    PYTHONPATH=. .venv/bin/python bench/nodes_at_any_rate.py [--seconds 30]

The UR5 stand-in's /joint_states (position, the motor current as effort, as UR's driver
publishes it), an unloaded and a loaded run of --seconds s at 1 kHz, logged at 1 kHz, 500 Hz and
~93 Hz on the logger's own 10/12/14 ms clock, with a few samples lost (known). Per rate it prints
the recorder's missing-sample count (bags.info.TickCounter, what the recorder's writer thread
runs, expected_rate 1000) against the truth; the samples in the bag against those the live
identification paired and used; and the largest relative difference between the live answer
(the identification node's LiveFeed, fed as the topic delivers it; stamps given) and
`identify` on the bags written as the recorder writes them, on the gains and on the base
parameters above 1e-3 of the largest. Options: config/identification.yaml with the excitation
checks off (30 s at ~93 Hz do not determine a UR5: equality, not accuracy, is measured).
Run it with PYTHONPATH of an older tree to get that tree's figures (the API is the same).
"""
from __future__ import annotations

import argparse
import dataclasses
import os
import sys
import tempfile
import threading
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

import numpy as np  # noqa: E402

from orthoglide_ident.bags.info import TickCounter  # noqa: E402
from orthoglide_ident.identify import IdentifyOptions, LiveIdentification, identify  # noqa: E402
from orthoglide_ident.model.registry import load_robot  # noqa: E402

LOST = (200, 201, 650, 1400, 1401, 1402)  # samples of each logged record lost: 6 per record
RATES = ("1kHz", "500Hz", "uneven_93Hz")


def at_rate(rec, rate: str, seed: int):
    """The 1 kHz stand-in logged at ``rate`` (JointState only) with LOST taken out."""
    rng = np.random.default_rng(seed)
    k, keep = 0, []
    while k < len(rec.messages):
        keep.append(k)
        k += {"1kHz": 1, "500Hz": 2}.get(rate) or int(rng.choice([10, 12, 14], p=[.8, .1, .1]))
    keep = [i for n, i in enumerate(keep) if n not in LOST]
    return dataclasses.replace(rec, messages=[(rec.messages[i][0], rec.messages[i][1], None)
                                              for i in keep])


def missing(rec) -> int:
    c = TickCounter(1000.0)
    for stamp, _, _ in rec.messages:
        c.add(stamp)
    if hasattr(c, "finish"):
        c.finish()
    return c.missing


def live_answer(node, recs: dict, opts: IdentifyOptions):
    from orthoglide_ident.nodes.live_feed import LiveFeed
    from orthoglide_ident.nodes.live_sources import LiveTopics
    from orthoglide_msgs.msg import RecorderStatus

    model = load_robot("ur5_mount")
    live = LiveIdentification(opts, model=model)
    feed = LiveFeed(node, live, threading.Lock(), LiveTopics("joint_states", "", ""),
                    robot=model, worker=False)
    try:
        for name, rec in recs.items():
            for recording in (True, False):
                m = RecorderStatus(recording=recording, condition=rec.condition,
                                   payload_mass=rec.payload_mass, bag_path=name)
                for f, ns in (("first_tick", rec.messages[0][0]),
                              ("last_tick", rec.messages[-1][0])):
                    getattr(m, f).sec, getattr(m, f).nanosec = divmod(ns, 10**9)
                feed.on_status(m)
                feed.turn()
                if recording:
                    for k in range(0, len(rec.messages), 97):
                        feed.buffers["q"].extend(js for _, js, _ in rec.messages[k:k + 97])
                        feed.turn()
            feed.turn()
        return live.result(), live.estimate()
    finally:
        feed.close()


def rel(a, b) -> tuple[float, float]:
    ga, gb = (np.array([g.value for g in r.drive_gains]) for r in (a, b))
    pa, pb = (np.array([p.value for p in r.parameters]) for r in (a, b))
    big = np.abs(pb) > 1e-3 * np.abs(pb).max()
    return float(np.max(np.abs(ga / gb - 1))), float(np.max(np.abs(pa[big] / pb[big] - 1)))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=30.0)
    args = ap.parse_args()
    import rclpy
    from ros2_control_records import standin_records, write_record_bag

    opts = IdentifyOptions.from_yaml(str(ROOT / "config/identification.yaml")).replace(
        check_excitation=False, partial_answers=False)
    records = standin_records(seconds=args.seconds, drop_rate=0.0)
    rclpy.init()
    node = rclpy.create_node("bench_nodes_at_any_rate")
    print(f"UR5 stand-in /joint_states (effort = current), {args.seconds:g} s unloaded + "
          f"{args.seconds:g} s loaded, {len(LOST)} samples lost per record")
    print(f"{'rate':<12} {'missing (truth)':>16} {'in bag':>8} {'paired':>8} {'used live':>10} "
          f"{'used off':>9} {'s live/off':>12} {'gains':>9} {'params':>9}")
    try:
        for rate in RATES:
            recs = {n: at_rate(r, rate, i) for i, (n, r) in enumerate(records.items())}
            with tempfile.TemporaryDirectory() as tmp:
                bags = [str(write_record_bag(Path(tmp) / n, r, dynamic=False))
                        for n, r in recs.items()]
                off = identify(bags, model=load_robot("ur5_mount"), options=opts)
            res, est = live_answer(node, recs, opts)
            dl, do = res.record_reports, off.record_reports
            seconds_off = sum(o.n_samples * o.row_period_s for o in off.observations
                              if o.condition == "unloaded")
            dg, dp = rel(res, off)
            print(f"{rate:<12} {missing(recs['unloaded']):>9} ({len(LOST)})    "
                  f"{len(recs['unloaded'].messages):>8} {dl[0].n_paired:>8} "
                  f"{dl[0].n_used:>10} {do[0].n_used:>9} "
                  f"{est.seconds_unloaded:>5.1f}/{seconds_off:<5.1f} {dg:>9.1e} {dp:>9.1e}")
    finally:
        node.destroy_node()
        rclpy.shutdown()


if __name__ == "__main__":
    main()
