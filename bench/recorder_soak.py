"""Recorder soak: record a stand-in controller at 1 kHz, count lost samples from the stamps.

    python bench/recorder_soak.py [--duration 60] [--max-rate-search] [--search-duration 10]

Starts the recorder node and bench/recorder_publisher.py in their own ROS domain (localhost),
records ``--duration`` seconds, then prints: ticks sent, samples lost (sent − recorded, and missing
ticks found in the header stamps), recorder CPU % (of one core) while recording, RSS at start and
end, bag size. ``--max-rate-search`` repeats short runs at rising rates and prints the highest rate
with zero loss on this machine. The 10-minute figure of DESIGN §7: ``--duration 600``.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
CLK = os.sysconf("SC_CLK_TCK")


def cpu_s(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / CLK


def rss_mib(pid: int) -> float:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    return float("nan")


def run(
    client, env: dict[str, str], out: Path, name: str, rate: float, duration: float, pid: int
) -> dict:
    from orthoglide_ident import bags

    res = client.start("unloaded", 0.0, name)
    assert res.success, res.message
    rss0, c0, t0 = rss_mib(pid), cpu_s(pid), time.monotonic()
    pub = subprocess.Popen(
        [
            sys.executable,
            str(HERE / "recorder_publisher.py"),
            "--rate",
            str(rate),
            "--duration",
            str(duration),
        ],
        env=env,
        stdout=subprocess.PIPE,
        text=True,
    )
    rss_samples = []
    while pub.poll() is None:
        time.sleep(min(5.0, max(duration / 10, 0.5)))
        rss_samples.append(rss_mib(pid))
    stdout = pub.communicate()[0]
    sent = int(stdout.split("sent ")[1].split()[0])
    pub_elapsed = float(stdout.split(" in ")[1].split()[0])
    time.sleep(0.5)
    cpu = (cpu_s(pid) - c0) / (time.monotonic() - t0) * 100
    rss1 = rss_mib(pid)
    stop = client.stop()
    data = bags.read_bag(res.bag_path)
    got_js, got_cr = len(data.joint_states.stamps_ns), len(data.current_reference.stamps_ns)
    gaps = bags.find_gaps(data.joint_states.stamps_ns, 1e9 / rate).missing
    size = sum(f.stat().st_size for f in Path(res.bag_path).glob("*.mcap"))
    return dict(
        rate=rate,
        sent=sent,
        pub_s=pub_elapsed,
        lost_js=sent - got_js,
        lost_cr=sent - got_cr,
        gaps=gaps,
        cpu=cpu,
        rss0=rss0,
        rss1=rss1,
        rss_max=max(rss_samples + [rss1]),
        size=size,
        stop=stop.message,
    )


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=60.0, help="seconds recorded at 1 kHz")
    ap.add_argument(
        "--max-rate-search", action="store_true", help="also find the highest zero-loss rate"
    )
    ap.add_argument("--search-duration", type=float, default=10.0)
    ap.add_argument("--rates", default="2000,3000,4000,5000,7000,10000")
    a = ap.parse_args(argv)

    env = dict(
        os.environ,
        ROS_DOMAIN_ID=str(101 - os.getpid() % 50),
        ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
        PYTHONUNBUFFERED="1",
    )
    env.pop("ROS_LOCALHOST_ONLY", None)
    os.environ.update(env)
    import rclpy
    from std_srvs.srv import Trigger

    from orthoglide_msgs.srv import StartRecording

    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        rec = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "orthoglide_ident.nodes.recorder",
                "--ros-args",
                "-p",
                f"output_dir:={out}",
            ],
            env=env,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        rclpy.init()
        node = rclpy.create_node("soak_client")

        class Client:
            s = node.create_client(StartRecording, "/orthoglide/recorder/start")
            t = node.create_client(Trigger, "/orthoglide/recorder/stop")

            def call(self, cli, req):
                fut = cli.call_async(req)
                rclpy.spin_until_future_complete(node, fut, timeout_sec=30)
                return fut.result()

            def start(self, cond, mass, name):
                return self.call(
                    self.s, StartRecording.Request(condition=cond, payload_mass=mass, name=name)
                )

            def stop(self):
                return self.call(self.t, Trigger.Request())

        client = Client()
        assert client.s.wait_for_service(timeout_sec=30)
        time.sleep(1.0)
        try:
            rows = [run(client, env, out, "soak", 1000.0, a.duration, rec.pid)]
            if a.max_rate_search:
                for r in (float(x) for x in a.rates.split(",")):
                    rows.append(
                        run(client, env, out, f"rate{int(r)}", r, a.search_duration, rec.pid)
                    )
                    if rows[-1]["lost_js"] or rows[-1]["lost_cr"] or rows[-1]["gaps"]:
                        break
        finally:
            rec.terminate()
            rec.wait(20)
            node.destroy_node()
            rclpy.shutdown()

    print(
        f"{'rate Hz':>8} {'sent':>8} {'pub s':>7} {'lost js':>8} {'lost cr':>8} {'gaps':>6} {'CPU %':>6} "
        f"{'RSS0 MiB':>9} {'RSS1 MiB':>9} {'RSSmax':>7} {'bag MB':>7}"
    )
    for r in rows:
        print(
            f"{r['rate']:>8.0f} {r['sent']:>8d} {r['pub_s']:>7.1f} {r['lost_js']:>8d} {r['lost_cr']:>8d} "
            f"{r['gaps']:>6d} {r['cpu']:>6.1f} {r['rss0']:>9.1f} {r['rss1']:>9.1f} {r['rss_max']:>7.1f} "
            f"{r['size'] / 1e6:>7.2f}"
        )
    print(f"recorder said: {rows[0]['stop']}")
    if a.max_rate_search:
        ok = [r["rate"] for r in rows if not (r["lost_js"] or r["lost_cr"] or r["gaps"])]
        print(
            f"highest rate with zero loss: {max(ok):.0f} Hz (both topics; publisher pacing in 'pub s')"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
