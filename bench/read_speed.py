"""Bag write and read speed: orthoglide_ident.bags vs rosbags, on N bags of D seconds at 1 kHz.

    python bench/read_speed.py [--seconds 60] [--bags 2]

Prints a small table: write_bag time and msg/s (the official MCAP writer underneath), read_bag
time and msg/s, the official MCAP reader merely iterating the same messages (what our scanner must
beat to earn its place), rosbags AnyReader + deserialise time on the same bags (the docs/architecture.md §7
yardstick), the ratio, and peak RSS.
"""

from __future__ import annotations

import argparse
import resource
import sys
import tempfile
import time
from pathlib import Path

import numpy as np


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


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--bags", type=int, default=2)
    ap.add_argument(
        "--skip-rosbags", action="store_true", help="do not time the rosbags deserialiser"
    )
    a = ap.parse_args(argv)

    from orthoglide_ident import bags

    n = int(a.seconds * 1000)
    rng = np.random.default_rng(0)
    with tempfile.TemporaryDirectory() as tmp:
        paths = []
        t_write = 0.0
        for i in range(a.bags):
            stamps = 1_700_000_000_000_000_000 + np.arange(n, dtype=np.int64) * 1_000_000
            q, v = rng.normal(size=(n, 3)), rng.normal(size=(n, 3))
            t0 = time.perf_counter()
            paths.append(
                bags.write_bag(
                    Path(tmp) / f"b{i}",
                    stamps,
                    q,
                    v,
                    "loaded" if i else "unloaded",
                    1.136 if i else 0.0,
                )
            )
            t_write += time.perf_counter() - t0
        msgs = 2 * n * a.bags
        size = sum(f.stat().st_size for p in paths for f in p.glob("*.mcap"))

        t0 = time.perf_counter()
        for p in paths:
            bags.read_bag(p)
        t_read = time.perf_counter() - t0
        rss_ours = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024

        t_info = time.perf_counter()
        for p in paths:
            bags.bag_info(p)
        t_info = time.perf_counter() - t_info

        rows = [
            ("write_bag", t_write, msgs),
            ("read_bag", t_read, msgs),
            ("bag_info", t_info, msgs),
        ]
        rows.append(("mcap.reader iter_messages", _mcap_reader_time(paths), msgs))
        if not a.skip_rosbags:
            from rosbags.highlevel import AnyReader

            t0 = time.perf_counter()
            with AnyReader(paths) as reader:
                for conn, _, raw in reader.messages():
                    reader.deserialize(raw, conn.msgtype)
            rows.append(("rosbags AnyReader+deserialize", time.perf_counter() - t0, msgs))

    print(
        f"{a.bags} bags x {a.seconds:g} s at 1 kHz, 2 topics: {msgs} messages, {size / 1e6:.1f} MB on disk"
    )
    print(f"{'operation':<32}{'time [s]':>10}{'msg/s':>14}")
    for name, t, m in rows:
        print(f"{name:<32}{t:>10.3f}{m / t:>14,.0f}")
    if not a.skip_rosbags:
        print(f"read_bag / rosbags time ratio: {t_read / rows[-1][1]:.3f}")
    print(f"peak RSS after read_bag: {rss_ours:.0f} MiB")
    return 0


if __name__ == "__main__":
    sys.exit(main())
