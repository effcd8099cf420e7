"""Next to ros2_control, over the real topics: recorder loss and CPU, live = offline, (A) vs (B).

    python bench/ros2_control.py [--duration 60] [--drop-rate 1e-4] [--keep DIR]

Starts the ros2_control stand-in (the simulated UR5 with a payload mount, 6 joints + a gripper,
joint_states + dynamic_joint_states at 1 kHz with the broadcaster's QoS, seeded drops), the
recorder (config/ros2_control.yaml) and three identification nodes, each live on the same
recordings: lag_model off, lag_model auto (default), and the current from the JointState effort
(dynamic_joint_states_topic ""). Records ``--duration`` s unloaded, mounts a 2.5 kg point mass,
records ``--duration`` s loaded, and prints:

1. recorder: messages published (the stand-in's ticks in the recorded span minus its drops,
   replayed from its seed) against messages in the bag, per topic: lost = published but not in
   the bag; the drops the recorder counted against the stand-in's; recorder CPU % of one core while
   recording (the 2-topic Orthoglide figure: bench/recorder_soak.py, run after this);
2. live (each node's orthoglide/identify with no bag) against offline (the same service on the
   bags): the largest relative difference of the gains and of the base parameters, and in σ;
3. (A) JointState.effort vs (B) DynamicJointState on the same ticks (a copy of the bags with
   /joint_states only, at the ticks both topics hold): offline, gains and parameters.
"""
from __future__ import annotations

import argparse
import shutil
import struct
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

from orthoglide_ident import bags  # noqa: E402
from orthoglide_sim.demos.graph import Graph  # noqa: E402
from orthoglide_sim.demos.node_set import record  # noqa: E402

STANDIN = "ros2_control_standin"
SEED = 5
NODES = {  # identification node -> (its service, parameters)
    "orthoglide_identification": ("orthoglide/identify", {"lag_model": "off"}),
    "identification_lag": ("orthoglide/identify_lag", {"lag_model": "auto"}),
    # dynamic_joint_states_topic "": that topic not read
    "identification_effort": ("orthoglide/identify_effort",
                              {"lag_model": "off", "dynamic_joint_states_topic": '""'}),
}


def call_identify(g: Graph, service: str, paths: list[str]):
    from orthoglide_msgs.srv import Identify

    res = g.call(Identify, service, timeout=600.0, bags=paths, method="tls")
    if not res.success:
        raise SystemExit(f"{service}: {res.message}")
    return res.parameters


def start(g: Graph, out: Path, drop_rate: float) -> None:
    from sensor_msgs.msg import JointState

    from orthoglide_ident._install_ament import ROOT

    config = ROOT / "config" / "ros2_control.yaml"
    g.start(
        STANDIN,
        "driver",
        {"robot": "ur5_mount", "drop_rate": drop_rate, "seed": SEED},
        params_file=config,
    )
    g.start("orthoglide_recorder", "recorder", {"output_dir": str(out)}, params_file=config)
    for name, (service, params) in NODES.items():
        g.start(
            name,
            "identification",
            {
                "bag_dir": str(out),
                "robot": "ur5_mount",
                "joint_states_topic": "joint_states",
                **params,
            },
            remap={"orthoglide/identify": service},
        )
    g.wait_for_messages(JointState, "joint_states", 1, timeout=120)
    for topic in ("joint_states", "dynamic_joint_states"):
        g.wait_for_subscriber(topic, "orthoglide_recorder")
        for name in NODES:
            if name != "identification_effort" or topic == "joint_states":
                g.wait_for_subscriber(topic, name)


def replayed_drops(start_ns: int, last_ns: int, rate: float) -> dict[str, set[int]]:
    from orthoglide_sim.common.broadcaster import TICK_NS, TOPICS, TickDropper

    d, out = TickDropper(rate, SEED), {t: set() for t in TOPICS}
    for k in range((last_ns - start_ns) // TICK_NS + 1):
        for topic, keep in zip(TOPICS, d.keep()):
            if not keep:
                out[topic].add(start_ns + k * TICK_NS)
    return out


def recorder_figures(path: str, start_ns: int, rate: float, stop_message: str, cpu: float) -> None:
    data = bags.read_bag(path)
    stamps = {
        "joint_states": data.positions.stamps_ns,
        "dynamic_joint_states": data.current.stamps_ns,
    }
    first = min(int(s[0]) for s in stamps.values())
    last = max(int(s[-1]) for s in stamps.values())
    dropped = replayed_drops(start_ns, last, rate)
    span = set(range(first, last + 1, 1_000_000))
    print(
        f"recorded {(last - first) / 1e9:.1f} s at 1 kHz, 6 joints + 1 extra; recorder: "
        f"{stop_message}"
    )
    print(f"{'topic':<22} {'ticks':>7} {'dropped':>8} {'published':>10} {'in bag':>8} {'lost':>5}")
    for topic, st in stamps.items():
        got = set(int(s) for s in st)
        d = {s for s in dropped[topic] if first <= s <= last}
        published = span - d
        print(f"{topic:<22} {len(span):7d} {len(d):8d} {len(published):10d} {len(got):8d} "
              f"{len(published - got):5d}   missing = dropped: {span - got == d}")
    print(f"recorder CPU while recording: {cpu:.1f} % of a core")


def compare(a, b) -> str:
    """Largest relative difference of the gains and of the base parameters (those above 1e-3 of
    the largest), and of the parameters in units of b's σ."""
    g = np.max(np.abs(np.array(a.drive_gains) / np.array(b.drive_gains) - 1))
    vb = dict(zip(b.names, b.values))
    sb = {n: abs(v) * r for n, v, r in zip(b.names, b.values, b.rel_std)}
    top = max(abs(v) for v in vb.values())
    rel = max(abs(v / vb[n] - 1) for n, v in zip(a.names, a.values) if abs(vb[n]) > 1e-3 * top)
    sig = max(abs(v - vb[n]) / sb[n] for n, v in zip(a.names, a.values) if sb[n] > 0)
    gs = np.max(np.abs(np.array(a.drive_gains) - np.array(b.drive_gains))
                / (np.array(b.drive_gains) * np.array(b.drive_gains_rel_std)))
    return f"gains {g:.1e} ({gs:.3f} σ), parameters {rel:.1e} ({sig:.3f} σ)"


def effort_only_copy(path: str, out: Path) -> str:
    """The bag's /joint_states at the ticks /dynamic_joint_states also holds (the current then
    from the effort), same tag."""
    from mcap.reader import make_reader

    data = bags.read_bag(path)
    both = set(int(s) for s in data.current.stamps_ns)
    with bags.BagWriter(out, data.tags) as w:
        ch = w.add_topic("/joint_states", bags.topics.JOINT_STATE_TYPE)
        for f in sorted(Path(path).glob("*.mcap")):
            with open(f, "rb") as fh:
                for _, _channel, msg in make_reader(fh).iter_messages(topics=["/joint_states"]):
                    sec, nsec = struct.unpack_from("<iI", msg.data, 4)  # header.stamp
                    if sec * 10**9 + nsec in both:
                        w.write(ch, msg.data, msg.log_time)
    return str(out)


def run(out: Path, duration: float, drop_rate: float) -> dict:
    """The graph: two recordings, every node's live and offline result, the CPU while recording."""
    with Graph(out / "logs") as g:
        start(g, out / "bags", drop_rate)
        c0 = g.cpu_seconds()
        t0 = time.monotonic()
        paths = [record(g, "unloaded", "unloaded", 0.0, duration, quiet=True)]
        cpu = {k: (v - c0[k]) / (time.monotonic() - t0) * 100 for k, v in g.cpu_seconds().items()}
        stop_message = g.log_tail("orthoglide_recorder")[0].split("]: ", 1)[-1]
        g.set_params(STANDIN, payload=2.5, trajectory="exciting2")
        time.sleep(3.0)
        paths.append(record(g, "loaded", "loaded", 2.5, duration, quiet=True))
        time.sleep(2.0)
        results = {
            n: (call_identify(g, s, []), call_identify(g, s, paths)) for n, (s, _) in NODES.items()
        }
        log = (out / "logs" / f"{STANDIN}.log").read_text()
    start_ns = int(log.split("update k is stamped ", 1)[1].split()[0])
    return dict(paths=paths, cpu=cpu, stop=stop_message, results=results, start_ns=start_ns)


def sources_figures(out: Path, r: dict) -> None:
    """(A) vs (B): offline on the same ticks, live as each node got them."""
    from orthoglide_ident.identify import IdentifyOptions, identify
    from orthoglide_ident.model.registry import load_robot
    from orthoglide_sim.arms.description import load_arm
    from orthoglide_sim.arms.truth import load_truth

    paths, results = r["paths"], r["results"]
    copies = [effort_only_copy(p, out / "effort_only" / Path(p).name) for p in paths]
    opts, model = IdentifyOptions.of(lag_model="off"), load_robot("ur5_mount")
    a, b = identify(copies, model=model, options=opts), identify(paths, model=model, options=opts)
    ga, gb = [x.value for x in a.drive_gains], [x.value for x in b.drive_gains]
    same_p = [p.value for p in a.parameters] == [p.value for p in b.parameters]
    print(f"offline, the same ticks: gains identical {ga == gb}, parameters identical {same_p}")
    extra = 0
    for p in paths:
        data = bags.read_bag(p)
        extra += len(
            set(map(int, data.positions.stamps_ns)) - set(map(int, data.current.stamps_ns))
        )
    print(
        "live (A) vs live (B): "
        f"{compare(results['identification_effort'][0], results['orthoglide_identification'][0])}"
        f" ((A) also holds the {extra} ticks only /dynamic_joint_states dropped)"
    )
    g_true = load_truth(load_arm("ur5_mount")).drive_array("g_tau")
    print("gains vs the plant's truth (B, offline): " + ", ".join(f"{100 * (g / t - 1):+.3f} %"
                                                                 for g, t in zip(gb, g_true)))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=60.0, help="s per recording (default 60)")
    ap.add_argument(
        "--drop-rate", type=float, default=1e-4, help="the stand-in's drop rate per topic"
    )
    ap.add_argument("--keep", type=Path, help="keep the bags and logs here")
    args = ap.parse_args(argv)
    out = args.keep or Path(tempfile.mkdtemp(prefix="ros2c_bench_"))
    if out.exists():
        shutil.rmtree(out)
    r = run(out, args.duration, args.drop_rate)
    print("== 1. recorder from the stand-in")
    recorder_figures(
        r["paths"][0], r["start_ns"], args.drop_rate, r["stop"], r["cpu"]["orthoglide_recorder"]
    )
    print(
        "CPU % of a core while recording: "
        + ", ".join(f"{k} {v:.1f}" for k, v in sorted(r["cpu"].items()))
    )
    print(
        f"== 2. live vs offline ({args.duration:g} s + {args.duration:g} s), the current from "
        "/dynamic_joint_states"
    )
    for name in ("orthoglide_identification", "identification_lag"):
        live, offline = r["results"][name]
        print(f"lag_model {NODES[name][1]['lag_model']:>4}: {compare(live, offline)}")
    print("== 3. (A) JointState.effort vs (B) DynamicJointState")
    sources_figures(out, r)
    if not args.keep:
        shutil.rmtree(out, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
