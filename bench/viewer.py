"""The Foxglove viewer next to the live graph: its CPU, what it costs the others, what a client
gets.

    .venv/bin/python bench/viewer.py [--seconds 15]

Starts the simulated driver (real time, 1 kHz), the recorder and the identification, and records
unloaded then loaded (1.983 kg) --seconds each; identifies (latched parameters: the viewer's
forces channel has a model). Then records loaded --seconds again twice: without the viewer, and
with the viewer and one Foxglove WebSocket client (foxglove.sdk.v1, subscribed to every channel,
reading as fast as it can). Prints, for both windows, the % of one core of each node, the ticks
the recorder missed and the live identification's estimates and lag; and the frames per second
the client got per channel.
"""
from __future__ import annotations

import argparse
import re
import sys
import tempfile
import threading
import time
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))

from foxglove_ws import FoxgloveClient  # noqa: E402

from orthoglide_sim.demos.graph import Graph  # noqa: E402
from orthoglide_sim.demos.node_set import identify  # noqa: E402


def recording(g: Graph, name: str, condition: str, mass: float, seconds: float) -> dict:
    """One recording through the services: per-node CPU % over it, missed ticks, live estimates."""
    from std_srvs.srv import Trigger

    from orthoglide_msgs.srv import StartRecording

    n_live = len(g.live)
    res = g.call(
        StartRecording,
        "orthoglide/recorder/start",
        condition=condition,
        payload_mass=mass,
        name=name,
    )
    assert res.success, res.message
    cpu0, t0 = g.cpu_seconds(), time.monotonic()
    time.sleep(seconds)
    cpu1, t1 = g.cpu_seconds(), time.monotonic()
    stop = g.call(Trigger, "orthoglide/recorder/stop")
    assert stop.success, stop.message
    missing = re.search(r"(\d+) missing on /orthoglide/joint_states", stop.message)
    written = re.search(
        r"wrote (\d+) /orthoglide/current_reference, (\d+) /orthoglide/joint_states", stop.message
    )
    live = g.live[n_live:]
    return {"cpu": {k: 100 * (cpu1[k] - cpu0.get(k, 0.0)) / (t1 - t0) for k in cpu1},
            "missing": int(missing.group(1)) if missing else -1,
            "written": int(written.group(2)) if written else -1,
            "live": len(live), "lag": max((m.lag for m in live), default=float("nan"))}


def client_frames(url: str, seconds: float, out: Counter, stop: threading.Event) -> None:
    client = FoxgloveClient(url)
    client.subscribe()
    t_end = time.monotonic() + seconds
    while time.monotonic() < t_end and not stop.is_set():
        out.update(f.topic for f in client.frames(0.1))
    client.close()


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=15.0)
    args = ap.parse_args(argv)
    s = args.seconds
    with tempfile.TemporaryDirectory() as tmp, Graph(Path(tmp) / "logs") as g:
        g.start("orthoglide_driver", "driver", {"trajectory": "exciting", "controller": "pid"})
        g.start("orthoglide_recorder", "recorder", {"output_dir": str(Path(tmp) / "bags")})
        g.start("orthoglide_identification", "identification", {"bag_dir": str(Path(tmp) / "bags")})
        g.wait_for_ticks()
        for topic in ("orthoglide/joint_states", "orthoglide/current_reference"):
            g.wait_for_subscriber(topic, "orthoglide_identification")
        recording(g, "unloaded", "unloaded", 0.0, s)
        g.set_params("orthoglide_driver", payload="1.983", trajectory="exciting2")
        time.sleep(3.0)
        recording(g, "loaded", "loaded", 1.983, s)
        identify(g, [])  # the live data: latched parameters for the viewer's model force
        without = recording(g, "loaded_without_viewer", "loaded", 1.983, s)

        g.start("orthoglide_viewer", "viewer", {"port": 0})
        log = Path(tmp) / "logs" / "orthoglide_viewer.log"
        while not (m := re.search(r"Foxglove view on (ws://[\d.]+:\d+)", log.read_text())):
            g.check_alive()
            time.sleep(0.1)
        g.wait_for_subscriber("orthoglide/joint_states", "orthoglide_viewer")
        frames: Counter = Counter()
        stop = threading.Event()
        reader = threading.Thread(target=client_frames, args=(m.group(1), s + 30, frames, stop))
        reader.start()
        time.sleep(3.0)  # connected, subscribed, the residual's filter filled
        frames.clear()
        t0 = time.monotonic()
        with_viewer = recording(g, "loaded_with_viewer", "loaded", 1.983, s)
        elapsed = time.monotonic() - t0
        got = dict(frames)
        stop.set()
        reader.join()

    print(
        f"viewer bench: {s:.0f} s recordings at 1 kHz (loaded), the driver in real time, 2 shared "
        "cores"
    )
    print(f"{'':28}{'without viewer':>16}{'with viewer + 1 client':>26}")
    for name in (
        "orthoglide_viewer",
        "orthoglide_recorder",
        "orthoglide_identification",
        "orthoglide_driver",
    ):
        a = without["cpu"].get(name)
        print(
            f"  {name + ' % of a core':<36}{'-' if a is None else f'{a:6.1f}':>8}"
            f"{with_viewer['cpu'][name]:>20.1f}"
        )
    for key, label in (("written", "ticks recorded"), ("missing", "ticks missed by the recorder"),
                       ("live", "live estimates"), ("lag", "live lag max (s)")):
        a, b = (
            f"{x:.2f}" if isinstance(x, float) else str(x) for x in (without[key], with_viewer[key])
        )
        print(f"  {label:<36}{a:>8}{b:>20}")
    print("frames per second delivered to the client:")
    for topic, n in sorted(got.items()):
        print(f"  {topic:<40}{n / elapsed:8.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
