"""Bag write and read speed: orthoglide_ident.bags vs rosbags, on N bags of D seconds at 1 kHz.

    python bench/read_speed.py [--seconds 60] [--bags 2] [--layouts orthoglide,joint_states,...]
                               [--json PATH]   (the tables for bench/write_benchmarks.py)

For each layout, a small table: write_bag time and msg/s (the official MCAP writer underneath),
read_bag time and msg/s, the official MCAP reader merely iterating the same messages (what our
scanner must beat to earn its place), rosbags AnyReader + deserialise time on the same bags (the
docs/benchmarks.md yardstick), the ratio, and peak RSS. Layouts:

- ``orthoglide``: /orthoglide/joint_states + /orthoglide/current_reference, 3 joints;
- ``joint_states``: a ros2_control /joint_states (position, velocity, effort = current), 6 joints
  in the hardware's order + 1 extra joint;
- ``dynamic_joint_states``: the same plus /dynamic_joint_states (position, velocity, current);
- ``variable``: dynamic_joint_states written message by message by rosbags, the frame id and
  the interface order changing (several bulk layouts), and 1 message in 50 with a one-off
  interface (decoded one by one from the bag's schema).
"""

from __future__ import annotations

import argparse
import resource
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from _figures import Figures, add_json_option

from orthoglide_ident.model.registry import load_robot

ORTHOGLIDE = load_robot("orthoglide")  # the robot these records are of

UR5 = ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint",
       "wrist_2_joint", "wrist_3_joint")
HW_ORDER = ("wrist_3_joint", "elbow_joint", "gripper_finger_joint", "shoulder_pan_joint",
            "wrist_1_joint", "shoulder_lift_joint", "wrist_2_joint")
EMITS_JSON = True  # --json PATH: the figures for bench/write_benchmarks.py
LAYOUTS = ("orthoglide", "joint_states", "dynamic_joint_states", "variable")
BEFORE = ("240k messages: read 0.09 s (rosbags 1.9 s, ratio 0.048), write 0.95 s (official mcap "
          "writer); 2026-12-02 at load 5–6: Orthoglide 240k read 0.17 s (rosbags 3.8 s, 0.044); "
          "ros2_control 6 + 1 joints, /joint_states 120k 0.22 s (0.098), + /dynamic_joint_states "
          "240k 0.69 s (0.075), rosbags-written with changing layouts 2.8 s (0.24); before the "
          "official writer, write 0.16–0.23 s (hand-written)")


def _mcap_reader_time(paths: list[Path]) -> float:
    """Seconds the official MCAP reader takes merely to iterate every message (no decoding)."""
    from mcap.reader import make_reader

    t0 = time.perf_counter()
    for p in paths:
        for f in sorted(p.glob("*.mcap")):
            with f.open("rb") as fh:
                for _ in make_reader(fh).iter_messages(log_time_order=False):
                    pass
    return time.perf_counter() - t0


def _variable_bag(path: Path, stamps: np.ndarray, q: np.ndarray, v: np.ndarray) -> None:
    """What a real robot's bag may look like to the bulk decoder: written by rosbags."""
    from rosbags.rosbag2 import StoragePlugin, Writer

    from orthoglide_ident import bags

    store = bags.topics.typestore()
    T, H = store.types["builtin_interfaces/msg/Time"], store.types["std_msgs/msg/Header"]
    JS = store.types[bags.topics.JOINT_STATE_TYPE]
    DJS = store.types[bags.topics.DYNAMIC_JOINT_STATE_TYPE]
    IV = store.types[bags.topics.INTERFACE_VALUE_TYPE]
    col = {j: UR5.index(j) for j in UR5}
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        w.set_custom_data("orthoglide.condition", "unloaded")
        w.set_custom_data("orthoglide.payload_mass", "0")
        a = w.add_connection("/joint_states", bags.topics.JOINT_STATE_TYPE, typestore=store)
        b = w.add_connection("/dynamic_joint_states", bags.topics.DYNAMIC_JOINT_STATE_TYPE,
                             typestore=store)
        for i, t in enumerate(stamps.tolist()):
            hdr = H(stamp=T(sec=t // 10**9, nanosec=t % 10**9),
                    frame_id="base" if (i // 1000) % 2 else "")
            pos = np.array([q[i, col[j]] if j in col else 0.0 for j in HW_ORDER])
            js = JS(header=hdr, name=list(HW_ORDER), position=pos, velocity=np.zeros(7),
                    effort=np.full(7, np.nan))
            ivs = []
            for j in HW_ORDER:
                names = ["position", "velocity", "current"] if j in col else ["position"]
                vals = [pos[HW_ORDER.index(j)], 0.0, v[i, col[j]]] if j in col else [0.0]
                if i % 3 == 0:
                    names, vals = names[::-1], vals[::-1]
                if i % 50 == 7:
                    names, vals = names + [f"temperature_{i:07d}"], vals + [40.0]
                ivs.append(IV(interface_names=names, values=np.array(vals)))
            w.write(a, t, bytes(store.serialize_cdr(js, bags.topics.JOINT_STATE_TYPE)))
            djs = DJS(header=hdr, joint_names=list(HW_ORDER), interface_values=ivs)
            w.write(b, t, bytes(store.serialize_cdr(djs, bags.topics.DYNAMIC_JOINT_STATE_TYPE)))


def _write(layout: str, path: Path, i: int, n: int, rng: np.random.Generator) -> int:
    """One bag; returns its message count."""
    from orthoglide_ident import bags

    stamps = 1_700_000_000_000_000_000 + np.arange(n, dtype=np.int64) * 1_000_000
    cond, mass = ("loaded", 1.136) if i else ("unloaded", 0.0)
    if layout == "orthoglide":
        bags.write_bag(path, stamps, rng.normal(size=(n, 3)), rng.normal(size=(n, 3)), cond, mass,
                       joint_names=ORTHOGLIDE.joint_names)
        return 2 * n
    q, v = rng.normal(size=(n, 6)), rng.normal(size=(n, 6))
    if layout == "variable":
        _variable_bag(path, stamps, q, v)
        return 2 * n
    bags.write_bag(path, stamps, q, v, cond, mass, UR5, layout=layout, joint_order=HW_ORDER,
                   extra_joints={"gripper_finger_joint": 0.0})
    return n * (2 if layout == "dynamic_joint_states" else 1)


def _bench(figs: Figures, layout: str, seconds: float, n_bags: int, skip_rosbags: bool) -> None:
    from orthoglide_ident import bags

    n = int(seconds * 1000)
    rng = np.random.default_rng(0)
    with tempfile.TemporaryDirectory() as tmp:
        paths, msgs = [], 0
        t_write = time.perf_counter()
        for i in range(n_bags):
            paths.append(Path(tmp) / f"b{i}")
            msgs += _write(layout, paths[-1], i, n, rng)
        t_write = time.perf_counter() - t_write
        size = sum(f.stat().st_size for p in paths for f in p.glob("*.mcap"))

        t0 = time.perf_counter()
        for p in paths:
            bags.read_bag(p, require_tags=False)
        t_read = time.perf_counter() - t0
        rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
        t_info = time.perf_counter()
        for p in paths:
            bags.bag_info(p)
        t_info = time.perf_counter() - t_info
        writer = "rosbags Writer (per message)" if layout == "variable" else "write_bag"
        rows = [(writer, t_write), ("read_bag", t_read), ("bag_info", t_info),
                ("mcap.reader iter_messages", _mcap_reader_time(paths))]
        if not skip_rosbags:
            from rosbags.highlevel import AnyReader

            t0 = time.perf_counter()
            with AnyReader(paths) as reader:
                for conn, _, raw in reader.messages():
                    reader.deserialize(raw, conn.msgtype)
            rows.append(("rosbags AnyReader+deserialize", time.perf_counter() - t0))

    print(f"== {layout}: {n_bags} bags x {seconds:g} s at 1 kHz: {msgs} messages, "
          f"{size / 1e6:.1f} MB on disk")
    print(f"{'operation':<32}{'time [s]':>10}{'msg/s':>14}")
    for name, t in rows:
        print(f"{name:<32}{t:>10.3f}{msgs / t:>14,.0f}")
    if not skip_rosbags:
        print(f"read_bag / rosbags time ratio: {t_read / rows[-1][1]:.3f}")
    print(f"peak RSS after read_bag: {rss:.0f} MiB")
    ratio = f", read_bag / rosbags {t_read / rows[-1][1]:.3f}" if not skip_rosbags else ""
    table = figs.table(f"{layout}: {n_bags} bags x {seconds:g} s at 1 kHz, {msgs} messages, "
                       f"{size / 1e6:.1f} MB{ratio}, peak RSS {rss:.0f} MiB",
                       ["operation", ("time", "s"), "msg/s"])
    for name, t in rows:
        table.row(name, f"{t:.3f}", f"{msgs / t:,.0f}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--bags", type=int, default=2)
    ap.add_argument("--layouts", default=",".join(LAYOUTS),
                    help=f"comma-separated, of {', '.join(LAYOUTS)}")
    ap.add_argument(
        "--skip-rosbags", action="store_true", help="do not time the rosbags deserialiser"
    )
    add_json_option(ap)
    a = ap.parse_args(argv)
    layouts = [x for x in a.layouts.split(",") if x]
    unknown = [x for x in layouts if x not in LAYOUTS]
    if unknown:
        ap.error(f"unknown layout {unknown[0]!r}: use {', '.join(LAYOUTS)}")
    figs = Figures(before=BEFORE)
    for layout in layouts:
        _bench(figs, layout, a.seconds, a.bags, a.skip_rosbags)
    figs.write(a.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
