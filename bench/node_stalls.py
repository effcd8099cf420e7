"""Each node of the graph stalled while recording: what the user sees, and what is lost.

    .venv/bin/python bench/node_stalls.py [--stall 1.0]

Starts the node set as `make demo` does (driver in real time under the CTC fed by the sample
bags' identification, recorder, live identification, ctc), then, in one recording per node,
stops that node (SIGSTOP) for ``--stall`` seconds 1 s into the recording, lets it run 2 s more and
stops the recording. Prints, per node: what the recorder's status said meanwhile, the driver's
late ticks and feed-forwards held (its /diagnostics counters), the live identification's lag
(seconds of received data not yet in the estimate, its largest value) and warnings, and the bag's
ticks written and missing (from the stamps). The figures of tests/test_live_graph.py's stall test.
"""
from __future__ import annotations

import argparse
import os
import signal
import sys
import tempfile
import time
from pathlib import Path

from _figures import Figures, add_json_option

EMITS_JSON = True  # --json PATH: the figures for bench/write_benchmarks.py

NODES = ("orthoglide_driver", "orthoglide_recorder", "orthoglide_identification", "orthoglide_ctc")


def start(g, out: Path) -> None:
    from orthoglide_ident._install_ament import ROOT
    from orthoglide_sim.demos.node_set import identify

    g.start("orthoglide_driver", "driver", {"trajectory": "exciting", "controller": "pid"})
    g.start("orthoglide_recorder", "recorder", {"output_dir": str(out / "bags")},
            params_file=ROOT / "config/recorder.yaml")
    g.start(
        "orthoglide_identification",
        "identification",
        {"bag_dir": str(out / "bags"), "lag_model": "off"},
    )
    g.wait_for_ticks()
    # latched for the ctc
    identify(g, [str(ROOT / "bags" / "unloaded"), str(ROOT / "bags" / "loaded")])
    g.start("orthoglide_ctc", "ctc", params_file=ROOT / "config/ctc.yaml")
    g.wait_for_feedforward()
    g.wait_for_subscriber("orthoglide/joint_states", "orthoglide_identification")
    g.set_params("orthoglide_driver", controller="ctc")


def stalled_recording(g, node: str, stall: float, statuses: list) -> dict:
    """One recording with ``node`` stopped for ``stall`` s; the figures of the table."""
    from std_srvs.srv import Trigger

    from orthoglide_ident import bags
    from orthoglide_msgs.srv import StartRecording

    before, n_live, n_status = g.driver_counters(), len(g.live), len(statuses)
    res = g.call(
        StartRecording,
        "orthoglide/recorder/start",
        condition="unloaded",
        payload_mass=0.0,
        name=f"stall_{node}",
    )
    time.sleep(1.0)
    g.procs[node].send_signal(signal.SIGSTOP)
    time.sleep(stall)
    g.procs[node].send_signal(signal.SIGCONT)
    time.sleep(2.0)
    stop = g.call(Trigger, "orthoglide/recorder/stop")
    after = g.driver_counters()
    time.sleep(1.5)  # the live estimate of the recording's end
    js = bags.read_bag(res.bag_path).joint_states.stamps_ns
    said = sorted(
        {
            m.message.split("; ", 1)[1]
            for m in statuses[n_status:]
            if m.recording and "; " in m.message
        }
    )
    live = g.live[n_live:]
    return {
        "node": node.removeprefix("orthoglide_"),
        "status": " | ".join(s.split(" (source")[0] for s in said) or "-",
        "late": int(after["late"]) - int(before["late"]),
        "held": int(after["feedforward_missing"]) - int(before["feedforward_missing"]),
        "live_lag": max((m.lag for m in live), default=float("nan")),
        "live_warnings": sum(len(m.warnings) for m in live),
        "written": len(js),
        "missing": bags.info.find_gaps(js).missing if len(js) else -1,
        "ok": stop.success,
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--stall", type=float, default=1.0, help="s each node is stopped (SIGSTOP)")
    add_json_option(ap)
    a = ap.parse_args(argv)
    os.environ.update(
        ROS_DOMAIN_ID=str(215 + os.getpid() % 18), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST"
    )
    os.environ.pop("ROS_LOCALHOST_ONLY", None)
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

    from orthoglide_ident.ros.processes import Interrupted, interrupt_on_signals
    from orthoglide_msgs.msg import RecorderStatus
    from orthoglide_sim.demos.graph import Graph

    interrupt_on_signals()
    rows = []
    try:
        with tempfile.TemporaryDirectory() as tmp, Graph(Path(tmp) / "logs") as g:
            statuses: list = []
            g.node.create_subscription(
                RecorderStatus,
                "orthoglide/recorder/status",
                statuses.append,
                QoSProfile(
                    depth=10,
                    durability=DurabilityPolicy.TRANSIENT_LOCAL,
                    reliability=ReliabilityPolicy.RELIABLE,
                ),
            )
            start(g, Path(tmp))
            for node in NODES:
                rows.append(stalled_recording(g, node, a.stall, statuses))
            g.check_alive()
    except Interrupted as e:
        print(f"node_stalls: interrupted by {e}: the nodes were stopped", file=sys.stderr)
        return e.exit_code
    print(
        f"each node stopped (SIGSTOP) {a.stall:g} s while recording, under the CTC, one recording "
        "each"
    )
    print(f"{'node':<15} {'ticks':>6} {'missing':>7} {'late':>5} {'ff held':>7} {'live lag s':>10} "
          f"{'live warn':>9}  recorder status said")
    figs = Figures()
    table = figs.table(f"each node stopped (SIGSTOP) {a.stall:g} s while recording, under the "
                       "CTC, one recording each", ["node", "ticks", "missing", "late", "ff held",
                                                   ("live lag", "s"), "live warn",
                                                   "recorder status said"])
    for r in rows:
        print(f"{r['node']:<15} {r['written']:>6} {r['missing']:>7} {r['late']:>5} {r['held']:>7} "
              f"{r['live_lag']:>10.1f} {r['live_warnings']:>9}  {r['status']}")
        table.row(r["node"], r["written"], r["missing"], r["late"], r["held"],
                  f"{r['live_lag']:.1f}", r["live_warnings"], r["status"])
    figs.write(a.json)
    return 0 if all(r["ok"] and r["missing"] == 0 for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
