"""Recorder soak: record a 1 kHz source (real driver or stand-in), count lost samples from stamps.

    python bench/recorder_soak.py [--source driver|standin] [--duration 60] [--max-rate-search]

Starts the recorder node and the source in their own ROS domain (localhost), records ``--duration``
seconds, then prints: ticks sent, samples lost (sent − recorded, and missing ticks found in the
header stamps), recorder CPU % (of one core) while recording, RSS at start and end, bag size, load
average during the run.

``--source standin`` (default): bench/recorder_publisher.py, which sends every tick (catch-up when
late); ``sent`` is what it reports. ``--source driver``: the simulator driver node (realtime,
exciting trajectory, pid, unloaded), which also publishes every tick at consecutive 1 ms stamps;
the recording starts once it publishes (after its jax compilation) and stops while it still runs,
so ``sent`` is the number of ticks in the recorded span (first to last stamp that both topics hold
in the bag) and any sample the bag lacks in that span is a loss. ``--max-rate-search`` (stand-in
only) repeats short runs at rising rates and prints the highest rate with zero loss. The 10-minute
figure of docs/benchmarks.md: ``--duration 600``.
"""

from __future__ import annotations

import argparse
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from orthoglide_ident.ros.processes import Interrupted, interrupt_on_signals, popen

HERE = Path(__file__).resolve().parent
DRIVER_START_S = 120.0  # the driver publishes within a second or two; far more under heavy load
CLK = os.sysconf("SC_CLK_TCK")


def cpu_s(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / CLK


def rss_mib(pid: int) -> float:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    return float("nan")


def loadavg() -> float:
    return float(Path("/proc/loadavg").read_text().split()[0])


def start_driver(env: dict[str, str], log: Path, node) -> subprocess.Popen:
    """The simulator driver, realtime, until interrupted; returns once its first tick arrived here
    (stopped, with a one-line reason, if it does not publish within DRIVER_START_S)."""
    import rclpy
    from sensor_msgs.msg import JointState

    drv = popen(
        [
            sys.executable,
            "-m",
            "orthoglide_sim.nodes.driver",
            "--ros-args",
            *("-p", "realtime:=true", "-p", "duration:=0.0", "-p", "trajectory:=exciting"),
            *("-p", "controller:=pid", "-p", "payload:=none"),
        ],
        env=env,
        stdout=log.open("w"),
        stderr=subprocess.STDOUT,
    )
    heard: list = []
    sub = node.create_subscription(JointState, "/orthoglide/joint_states", heard.append, 10)
    deadline = time.monotonic() + DRIVER_START_S
    try:
        while not heard:
            if drv.poll() is not None or time.monotonic() > deadline:
                tail = " | ".join(log.read_text().strip().splitlines()[-3:])
                raise SystemExit(
                    f"recorder_soak: the driver did not publish within {DRIVER_START_S:.0f} s "
                    f"(exit code {drv.poll()}): {tail}"
                )
            rclpy.spin_once(node, timeout_sec=0.1)
    except BaseException:
        stop(drv)
        raise
    finally:
        node.destroy_subscription(sub)
    time.sleep(1.0)
    return drv


def stop(proc: subprocess.Popen | None, timeout: float = 20.0) -> None:
    """SIGINT (a clean stop: the recorder closes its bag), then SIGKILL after ``timeout`` s."""
    if proc is None or proc.poll() is not None:
        return
    proc.send_signal(signal.SIGINT)
    try:
        proc.wait(timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()


def run(
    client,
    env: dict[str, str],
    out: Path,
    name: str,
    rate: float,
    duration: float,
    pid: int,
    driver: subprocess.Popen | None = None,
    stall: float = 0.0,
) -> dict:
    from orthoglide_ident import bags

    res = client.start("unloaded", 0.0, name)
    assert res.success, res.message
    rss0, c0, t0 = rss_mib(pid), cpu_s(pid), time.monotonic()
    loads = [loadavg()]
    if driver is not None:
        rss_samples = []
        while time.monotonic() - t0 < duration:
            left = max(0.0, t0 + duration - time.monotonic())
            if stall and time.monotonic() - t0 >= duration / 2:
                os.kill(pid, signal.SIGSTOP)
                time.sleep(stall)
                os.kill(pid, signal.SIGCONT)
                print(f"recorder stopped {stall} s at {time.monotonic() - t0:.1f} s", flush=True)
                stall = 0.0
                continue
            step = min(5.0, max(duration / 10, 0.5), left)
            if stall:
                step = min(step, max(0.0, t0 + duration / 2 - time.monotonic()))
            time.sleep(step)
            rss_samples.append(rss_mib(pid))
            loads.append(loadavg())
        if driver.poll() is not None:
            raise SystemExit("the driver stopped during the recording")
        cpu = (cpu_s(pid) - c0) / (time.monotonic() - t0) * 100
        rss1 = rss_mib(pid)
        stop = client.stop()
        data = bags.read_bag(res.bag_path)
        js, cr = data.joint_states.stamps_ns, data.current_reference.stamps_ns
        # the span both topics cover (start and stop cut the two streams a tick apart at most)
        first, last = max(js[0], cr[0]), min(js[-1], cr[-1])
        js, cr = js[(js >= first) & (js <= last)], cr[(cr >= first) & (cr <= last)]
        sent = int((last - first) // 1_000_000) + 1  # the driver publishes every 1 ms stamp
        size = sum(f.stat().st_size for f in Path(res.bag_path).glob("*.mcap"))
        return dict(
            rate=rate,
            sent=sent,
            pub_s=(last - first) / 1e9,
            lost_js=sent - len(js),
            lost_cr=sent - len(cr),
            gaps=bags.info.find_gaps(js, 1e6).missing + bags.info.find_gaps(cr, 1e6).missing,
            same=len(js) == len(cr) and bool((js == cr).all()),
            where={
                "js": bags.info.find_gaps(js, 1e6).where,
                "cr": bags.info.find_gaps(cr, 1e6).where,
            },
            cpu=cpu,
            rss0=rss0,
            rss1=rss1,
            rss_max=max(rss_samples + [rss1]),
            size=size,
            load=loads,
            stop=stop.message,
        )
    if stall:
        raise SystemExit("--stall needs --source driver")
    pub = popen(
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
        loads.append(loadavg())
    stdout = pub.communicate()[0]
    sent = int(stdout.split("sent ")[1].split()[0])
    pub_elapsed = float(stdout.split(" in ")[1].split()[0])
    time.sleep(0.5)
    cpu = (cpu_s(pid) - c0) / (time.monotonic() - t0) * 100
    rss1 = rss_mib(pid)
    stop = client.stop()
    data = bags.read_bag(res.bag_path)
    got_js, got_cr = len(data.joint_states.stamps_ns), len(data.current_reference.stamps_ns)
    gaps = bags.info.find_gaps(data.joint_states.stamps_ns, 1e9 / rate).missing
    js, cr = data.joint_states.stamps_ns, data.current_reference.stamps_ns
    size = sum(f.stat().st_size for f in Path(res.bag_path).glob("*.mcap"))
    return dict(
        rate=rate,
        sent=sent,
        pub_s=pub_elapsed,
        lost_js=sent - got_js,
        lost_cr=sent - got_cr,
        gaps=gaps,
        same=len(js) == len(cr) and bool((js == cr).all()),
        cpu=cpu,
        rss0=rss0,
        rss1=rss1,
        rss_max=max(rss_samples + [rss1]),
        size=size,
        load=loads,
        stop=stop.message,
    )


def soak(a: argparse.Namespace, env: dict[str, str]) -> list[dict]:
    """Start the recorder (and the driver), run the recordings; every child is stopped on the way
    out, whatever ends this (and dies with this process if it is killed: a parent-death signal)."""
    import rclpy
    from rclpy.signals import SignalHandlerOptions

    rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
    node = rclpy.create_node("soak_client")
    rec = driver = None
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) if a.keep is None else a.keep.resolve()
        out.mkdir(parents=True, exist_ok=True)
        try:
            rec = popen(
                [sys.executable, "-m", "orthoglide_ident.nodes.recorder", "--ros-args",
                 "-p", f"output_dir:={out}"],
                env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
            )
            client = _Client(node)
            if not client.s.wait_for_service(timeout_sec=30):
                raise SystemExit(
                    "recorder_soak: the recorder's services did not appear within 30 s"
                )
            time.sleep(1.0)
            t_start = time.monotonic()
            if a.source == "driver":
                driver = start_driver(env, out / "driver.log", node)
                print(f"driver publishing after {time.monotonic() - t_start:.1f} s", flush=True)
            rows = [run(client, env, out, "soak", 1000.0, a.duration, rec.pid, driver, a.stall)]
            if a.max_rate_search:
                for r in (float(x) for x in a.rates.split(",")):
                    rows.append(
                        run(client, env, out, f"rate{int(r)}", r, a.search_duration, rec.pid)
                    )
                    if rows[-1]["lost_js"] or rows[-1]["lost_cr"] or rows[-1]["gaps"]:
                        break
        finally:
            if driver is not None:
                stop(driver)
                said = [
                    ln for ln in (out / "driver.log").read_text().splitlines() if "driver: " in ln
                ]
                print(
                    "driver said: "
                    f"{said[-1] if said else f'(nothing; exit code {driver.returncode})'}"
                )
            stop(rec)
            node.destroy_node()
            rclpy.try_shutdown()
    return rows


class _Client:
    """The recorder's start and stop services."""

    def __init__(self, node) -> None:
        from std_srvs.srv import Trigger

        from orthoglide_msgs.srv import StartRecording

        self.node = node
        self.s = node.create_client(StartRecording, "/orthoglide/recorder/start")
        self.t = node.create_client(Trigger, "/orthoglide/recorder/stop")

    def call(self, cli, req):
        import rclpy

        fut = cli.call_async(req)
        rclpy.spin_until_future_complete(self.node, fut, timeout_sec=30)
        if not fut.done():
            raise SystemExit(f"recorder_soak: {cli.srv_name} did not answer within 30 s")
        return fut.result()

    def start(self, cond, mass, name):
        from orthoglide_msgs.srv import StartRecording

        return self.call(
            self.s, StartRecording.Request(condition=cond, payload_mass=mass, name=name)
        )

    def stop(self):
        from std_srvs.srv import Trigger

        return self.call(self.t, Trigger.Request())


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--source",
        choices=("standin", "driver"),
        default="standin",
        help="1 kHz source: the stand-in publisher or the simulator driver node",
    )
    ap.add_argument("--duration", type=float, default=60.0, help="seconds recorded at 1 kHz")
    ap.add_argument("--keep", type=Path, help="keep the bags (and driver log) in this folder")
    ap.add_argument(
        "--stall",
        type=float,
        default=0.0,
        help="stop the recorder process (SIGSTOP) this many seconds, once, half-way through "
        "(a recorder starved of CPU); the source keeps publishing",
    )
    ap.add_argument(
        "--max-rate-search", action="store_true", help="also find the highest zero-loss rate"
    )
    ap.add_argument("--search-duration", type=float, default=10.0)
    ap.add_argument("--rates", default="2000,3000,4000,5000,7000,10000")
    a = ap.parse_args(argv)
    if a.source == "driver" and a.max_rate_search:
        ap.error("--max-rate-search needs --source standin (the driver runs at 1 kHz)")

    env = dict(
        os.environ,
        # 215-232: valid on Linux (ports above the ephemeral range) and outside the 1-100 that
        # tests/conftest.py gives pytest runs, so a test run never talks to a soak
        ROS_DOMAIN_ID=str(215 + os.getpid() % 18),
        ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
        PYTHONUNBUFFERED="1",
    )
    env.pop("ROS_LOCALHOST_ONLY", None)
    os.environ.update(env)
    interrupt_on_signals()  # Ctrl-C, SIGTERM (timeout), SIGHUP: children stopped, one line
    try:
        rows = soak(a, env)
    except Interrupted as e:
        print(
            f"recorder_soak: interrupted by {e}: the recorder and the source were stopped",
            file=sys.stderr,
        )
        return e.exit_code
    print(
        f"{'rate Hz':>8} {'sent':>8} {'pub s':>7} {'lost js':>8} {'lost cr':>8} {'gaps':>6} "
        f"{'CPU %':>6} "
        f"{'RSS0 MiB':>9} {'RSS1 MiB':>9} {'RSSmax':>7} {'bag MB':>7}"
    )
    for r in rows:
        print(
            f"{r['rate']:>8.0f} {r['sent']:>8d} {r['pub_s']:>7.1f} {r['lost_js']:>8d} "
            f"{r['lost_cr']:>8d} "
            f"{r['gaps']:>6d} {r['cpu']:>6.1f} {r['rss0']:>9.1f} {r['rss1']:>9.1f} "
            f"{r['rss_max']:>7.1f} "
            f"{r['size'] / 1e6:>7.2f}"
        )
    print(f"recorder said: {rows[0]['stop']}")
    for r in rows:
        ld = r["load"]
        print(
            f"{r['rate']:.0f} Hz: source {a.source}, {r['sent']} ticks over {r['pub_s']:.1f} s, "
            f"identical stamps on both topics: {r['same']}, load average (1 min) during the run: "
            f"min {min(ld):.2f} mean {sum(ld) / len(ld):.2f} max {max(ld):.2f}"
        )
        for topic, where in r.get("where", {}).items():
            if where:
                at = ", ".join(f"{n} at {t:.3f} s" for t, n in where)
                print(f"  {topic} gaps (first 10): {at}")
    if a.max_rate_search:
        ok = [r["rate"] for r in rows if not (r["lost_js"] or r["lost_cr"] or r["gaps"])]
        print(
            f"highest rate with zero loss: {max(ok):.0f} Hz (both topics; publisher pacing in 'pub "
            "s')"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
