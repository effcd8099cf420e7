"""Start the node set as processes and talk to it over ROS 2, as a user at the robot would.

``Graph`` owns the node processes (started with the `ros2 run` launchers of the venv, logs in a
folder) and one client node in this process, spun on its own thread, through which it calls the
services, sets parameters and listens to topics. Used by ``orthoglide_sim.demos.node_set`` and the
tests of
the live graph; nothing here is numerical.
"""
from __future__ import annotations

import importlib
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.executors import MultiThreadedExecutor
from rclpy.parameter import Parameter
from rclpy.parameter_client import AsyncParameterClient
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions
from sensor_msgs.msg import JointState

from orthoglide_ident.errors import OrthoglideError
from orthoglide_ident.ros.processes import popen
from orthoglide_msgs.msg import CurrentReference, LiveIdentification, RecorderStatus

LAUNCHERS = Path(sys.prefix) / "lib" / "orthoglide_ident"


def own_ros_domain() -> str:
    """A demo talks on a ROS domain of its own unless ``ROS_DOMAIN_ID`` is set: a second graph on
    the machine (another demo, a test run) would otherwise cross into it. Returns the line that
    says which domain, for the demo to print."""
    if os.environ.get("ROS_DOMAIN_ID"):
        return f"ROS domain {os.environ['ROS_DOMAIN_ID']} (from ROS_DOMAIN_ID)"
    domain = 1 + os.getpid() % 100  # 1..100: above 101 domains can collide with ephemeral ports
    os.environ["ROS_DOMAIN_ID"] = str(domain)
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    return (f"ROS domain {domain}, localhost only: a domain of its own (set ROS_DOMAIN_ID to run "
            "on another)")


class GraphError(OrthoglideError):
    """A node of the graph did not start, died, or did not answer."""


def _stamp(msg: Any) -> int:
    return msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec


class Graph:
    """The node processes and a client node (``with Graph(logs) as g: ...``)."""

    def __init__(self, log_dir: Path, env: dict[str, str] | None = None):
        self.log_dir = Path(log_dir)
        self.log_dir.mkdir(parents=True, exist_ok=True)
        self.env = dict(os.environ if env is None else env, PYTHONUNBUFFERED="1")
        self.procs: dict[str, subprocess.Popen] = {}
        self._logs: dict[str, Any] = {}

    def __enter__(self) -> Graph:
        # no rclpy signal handlers: SIGTERM shut the context down under the running calls (chained
        # RCLError tracebacks); the caller's handlers (ros.processes.interrupt_on_signals) or
        # Python's default end the run, and __exit__ stops the nodes
        rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
        self.node = rclpy.create_node("orthoglide_demo")
        # entities are created here, once: destroying one while the executor waits on it races
        self._clients: dict[str, Any] = {}
        self._param_clients: dict[str, AsyncParameterClient] = {}
        self.live: list[Any] = []  # orthoglide/identification/live messages (about 1 Hz)
        self.node.create_subscription(LiveIdentification, "orthoglide/identification/live",
                                      lambda m: self.live.append(m), 10)
        # (monotonic s, the ctc's /diagnostics values)
        self.ctc_figures: list[tuple[float, dict[str, str]]] = []
        self.node.create_subscription(DiagnosticArray, "/diagnostics", self._on_diagnostics, 10)
        self.executor = MultiThreadedExecutor(num_threads=2)
        self.executor.add_node(self.node)
        self._spinner = threading.Thread(target=self.executor.spin, daemon=True)
        self._spinner.start()
        return self

    def __exit__(self, *exc: Any) -> None:
        for proc in self.procs.values():  # all at once, then each waited for
            if proc.poll() is None:
                proc.send_signal(signal.SIGINT)
        for name in list(self.procs):
            self.stop(name)
        self.executor.shutdown()
        self._spinner.join(5.0)  # a thread left in rclpy's wait at exit aborted the interpreter
        self.node.destroy_node()
        rclpy.try_shutdown()

    # ---- processes -------------------------------------------------------------------------------
    def start(self, name: str, executable: str, params: dict[str, Any] | None = None,
              remap: dict[str, str] | None = None, params_file: Path | None = None) -> None:
        """`ros2 run orthoglide_ident <executable> --ros-args -r __node:=<name> ...`, logged to
        <name>.log."""
        args = [str(LAUNCHERS / executable), "--ros-args", "-r", f"__node:={name}"]
        if params_file is not None:
            args += ["--params-file", str(params_file)]
        for k, v in (params or {}).items():
            args += ["-p", f"{k}:={_param_text(v)}"]
        for a, b in (remap or {}).items():
            args += ["-r", f"{a}:={b}"]
        log = open(self.log_dir / f"{name}.log", "w")
        self._logs[name] = log
        # the node ends with this process whatever ends it (SIGKILL too): a parent-death signal
        self.procs[name] = popen(args, stdout=log, stderr=subprocess.STDOUT, env=self.env)

    def stop(self, name: str, timeout: float = 10.0) -> int | None:
        proc = self.procs.pop(name, None)
        if proc is None:
            return None
        if proc.poll() is None:
            proc.send_signal(signal.SIGINT)
            try:
                proc.wait(timeout)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
        self._logs.pop(name).close()
        return proc.returncode

    def check_alive(self) -> None:
        for name, proc in self.procs.items():
            if proc.poll() is not None:
                tail = (self.log_dir / f"{name}.log").read_text().strip().splitlines()[-3:]
                raise GraphError(f"node {name} exited ({proc.returncode}): " + " | ".join(tail))

    def cpu_seconds(self) -> dict[str, float]:
        """CPU time (user + system, s) each node process has used so far (from /proc)."""
        out = {}
        for name, proc in self.procs.items():
            try:
                fields = Path(f"/proc/{proc.pid}/stat").read_text().rsplit(")", 1)[1].split()
                out[name] = (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
            except (OSError, IndexError, ValueError):
                pass
        return out

    def log_tail(self, name: str, n: int = 1) -> list[str]:
        return (self.log_dir / f"{name}.log").read_text().strip().splitlines()[-n:]

    # ---- services and parameters -----------------------------------------------------------------
    def call(self, srv_type: Any, service: str, timeout: float = 120.0, **fields: Any) -> Any:
        """Call ``service`` with the request ``fields``; GraphError if it never answers."""
        client = self._clients.get(service) or self._clients.setdefault(
            service, self.node.create_client(srv_type, service))
        if not client.wait_for_service(timeout_sec=30.0):
            self.check_alive()
            raise GraphError(f"service {service} did not appear within 30 s")
        request = srv_type.Request()
        for k, v in fields.items():
            setattr(request, k, v)
        return self._wait(client.call_async(request), timeout, f"service {service}")

    def set_params(self, node_name: str, **values: Any) -> None:
        """`ros2 param set` for each value; GraphError with the node's reason when refused."""
        client = self._param_clients.get(node_name) or self._param_clients.setdefault(
            node_name, AsyncParameterClient(self.node, node_name))
        if not client.wait_for_services(timeout_sec=30.0):
            raise GraphError(f"parameter services of {node_name} did not appear")
        result = self._wait(
            client.set_parameters([Parameter(k, value=v) for k, v in values.items()]),
            10.0,
            f"{node_name} set_parameters",
        )
        for (k, _), r in zip(values.items(), result.results):
            if not r.successful:
                raise GraphError(f"{node_name} refused {k}: {r.reason}")

    def _wait(self, future: Any, timeout: float, what: str) -> Any:
        t_end = time.monotonic() + timeout
        while not future.done():
            if time.monotonic() > t_end:
                raise GraphError(f"{what}: no answer within {timeout:.0f} s")
            self.check_alive()
            time.sleep(0.02)
        return future.result()

    # ---- topics ----------------------------------------------------------------------------------
    def _listen(
        self,
        msg_type: Any,
        topic: str,
        qos: Any,
        on_message: Any,
        done: Any,
        timeout: float,
        failure: Any,
    ) -> float:
        """Spin a short-lived node of its own subscribed to ``topic`` until ``done()``; seconds it
        took.
        Its own node, so that nothing subscribes at 1 kHz in this process the rest of the time;
        GraphError with ``failure()`` after ``timeout`` s."""
        probe = rclpy.create_node("orthoglide_demo_probe")
        probe.create_subscription(msg_type, topic, on_message, qos)
        t0 = time.monotonic()
        try:
            while not done():
                rclpy.spin_once(probe, timeout_sec=0.05)
                if time.monotonic() - t0 > timeout:
                    self.check_alive()
                    raise GraphError(failure())
        finally:
            probe.destroy_node()
        return time.monotonic() - t0

    def latched(
        self, msg_type: Any, topic: str, match: Any = None, timeout: float = 30.0
    ) -> Any:
        """The first message on the latched (transient local) ``topic`` for which ``match(msg)``
        holds; without ``match``, the message it holds now."""
        match = match or (lambda _m: True)
        seen: list[Any] = []
        latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                             durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self._listen(msg_type, topic, latched, seen.append,
                     lambda: any(match(m) for m in seen), timeout,
                     lambda: f"no matching message on {topic} within {timeout:.0f} s")
        return next(m for m in seen if match(m))

    def wait_for_messages(
        self, msg_type: Any, topic: str, count: int = 1, timeout: float = 30.0
    ) -> float:
        """Seconds until ``count`` messages arrived on ``topic``."""
        got = [0]
        return self._listen(
            msg_type,
            topic,
            QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE),
            lambda m: got.__setitem__(0, got[0] + 1),
            lambda: got[0] >= count,
            timeout,
            lambda: f"{got[0]} of {count} messages on {topic} within {timeout:.0f} s",
        )

    def wait_for_status(
        self, done: Any, timeout: float = 60.0, topic: str = "orthoglide/recorder/status"
    ) -> Any:
        """The first recorder status (latched) for which ``done(status)`` holds; GraphError with the
        last one seen after ``timeout`` s (a bound on a hang, not a figure)."""
        seen: list[Any] = []
        latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                             durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self._listen(
            RecorderStatus,
            topic,
            latched,
            seen.append,
            lambda: bool(seen) and done(seen[-1]),
            timeout,
            lambda: (
                f"recorder status not as awaited within {timeout:.0f} s: "
                f"{seen[-1] if seen else 'none received'}"
            ),
        )
        return seen[-1]

    def wait_for_match(self, publisher: Any, timeout: float = 30.0) -> None:
        """Until ``publisher`` (of this graph's node) is matched with a subscription: what it
        publishes from then on reaches a subscriber (DDS matching is not instant after
        discovery)."""
        t_end = time.monotonic() + timeout
        while publisher.get_subscription_count() < 1:
            if time.monotonic() > t_end:
                self.check_alive()
                raise GraphError(
                    f"nothing subscribed to {publisher.topic_name} within {timeout:.0f} s"
                )
            time.sleep(0.02)

    def driver_counters(self, timeout: float = 5.0) -> dict[str, str]:
        """The driver's counters (ticks, late, feedforward_fresh, ...) from its next /diagnostics
        message (published once a second)."""
        got: dict[str, str] = {}

        def on_diagnostics(m: DiagnosticArray) -> None:
            for st in m.status:
                if st.hardware_id == "orthoglide_sim":
                    got.update({kv.key: kv.value for kv in st.values})

        self._listen(
            DiagnosticArray,
            "/diagnostics",
            10,
            on_diagnostics,
            lambda: bool(got),
            timeout,
            lambda: f"no driver counters on /diagnostics within {timeout:.0f} s",
        )
        return got

    def _on_diagnostics(self, msg: DiagnosticArray) -> None:
        for st in msg.status:
            if st.hardware_id == "orthoglide_ctc":
                self.ctc_figures.append((time.monotonic(), {kv.key: kv.value for kv in st.values}))

    def ctc_figures_between(self, t0: float, t1: float) -> list[dict[str, str]]:
        """The ctc's once-a-second figures (lead, CPU; nodes/ctc.py) received between ``t0`` and
        ``t1`` (time.monotonic())."""
        return [v for t, v in self.ctc_figures if t0 <= t <= t1]

    def wait_for_subscriber(self, topic: str, node_prefix: str, timeout: float = 30.0) -> float:
        """Seconds until a node whose name starts with ``node_prefix`` subscribes to ``topic`` (its
        batch intake is the hidden ``_<node>_rx`` node) and the topic's publishers deliver to a
        subscription made after it: a subscriber gets nothing published before DDS matched it."""
        name = self.node.resolve_topic_name(topic)
        t0 = time.monotonic()
        while not any(i.node_name.lstrip("_").startswith(node_prefix)
                      for i in self.node.get_subscriptions_info_by_topic(name)):
            if time.monotonic() - t0 > timeout:
                self.check_alive()
                raise GraphError(
                    f"{node_prefix} did not subscribe to {name} within {timeout:.0f} s"
                )
            time.sleep(0.05)
        self._wait_for_delivery(name, timeout)
        return time.monotonic() - t0

    def _wait_for_delivery(self, name: str, timeout: float) -> None:
        """Until a probe subscription, made after the awaited one was discovered here, receives a
        message of ``name``: the publishers reach this process. The match of two other processes
        cannot be seen from outside (it may come later: a node that must get every tick says when
        it receives, e.g. the identification's 'live identification: receiving <topic>'). Nothing
        to wait for while the topic has no publisher but this process's own."""
        own = self.node.get_name()  # this process's publishers: wait_for_match sees their match
        publishers = [p for p in self.node.get_publishers_info_by_topic(name) if p.node_name != own]
        if not publishers:
            return
        package, kind, type_name = publishers[0].topic_type.split("/")
        msg_type = getattr(importlib.import_module(f"{package}.{kind}"), type_name)
        got = [0]
        any_reliability = QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT)
        if all(p.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL for p in publishers):
            # a latched topic (a status published on change): its last message comes on matching
            any_reliability = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                                         durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self._listen(msg_type, name, any_reliability, lambda m: got.__setitem__(0, 1),
                     lambda: got[0] > 0, timeout,
                     lambda: f"no message on {name} within {timeout:.0f} s of its subscriber")

    def wait_for_log(self, name: str, text: str, timeout: float = 120.0) -> str:
        """The first line of node ``name``'s log holding ``text`` (what the node says when it has
        done something); GraphError with the log's last lines after ``timeout`` s (a hang bound)."""
        path = self.log_dir / f"{name}.log"
        t_end = time.monotonic() + timeout
        while not (lines := [ln for ln in path.read_text().splitlines() if text in ln]):
            if time.monotonic() > t_end:
                self.check_alive()
                raise GraphError(f"{name} did not log {text!r} within {timeout:.0f} s: "
                                 + " | ".join(self.log_tail(name, 3)))
            time.sleep(0.05)
        return lines[0]

    def wait_for_robot_time(self, seconds: float, topic: str = "orthoglide/joint_states",
                            timeout: float = 120.0) -> float:
        """Until ``seconds`` of robot time went by: that many seconds of 1 kHz joint states
        arrived (a trajectory blends in, a controller settles, in the robot's time whatever the
        load of the machine). Wall-clock seconds it took."""
        return self.wait_for_messages(JointState, topic, round(seconds * 1000), timeout)

    def wait_for_ticks(self, timeout: float = 30.0) -> float:
        """Seconds until a joint state arrives (the driver or robot is publishing)."""
        return self.wait_for_messages(JointState, "orthoglide/joint_states", 1, timeout)

    def wait_for_feedforward(self, ticks: int = 200, timeout: float = 20.0) -> float:
        """Until ``ticks`` feed-forward messages arrived (a ctc node fed with parameters is
        running)."""
        return self.wait_for_messages(CurrentReference, "orthoglide/feedforward", ticks, timeout)


YAML_BOOL_WORDS = ("on", "off", "yes", "no", "y", "n", "true", "false")


def _param_text(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (list, tuple)):
        return "[" + ",".join(_param_text(x) for x in v) + "]"
    if isinstance(v, str) and v.lower() in YAML_BOOL_WORDS:
        return f'"{v}"'  # a string parameter, not the YAML boolean the bare word would be
    return str(v)
