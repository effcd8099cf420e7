"""The viewer node: a real Foxglove WebSocket client (foxglove.sdk.v1) subscribes and receives the
graph's topics as JSON frames; garbage, a vanished and a stalled client leave it serving; a port in
use is a one-line reason and exit 2."""
from __future__ import annotations

import re
import socket
import subprocess
import sys
import threading
import time

import numpy as np
import pytest
from foxglove_ws import FoxgloveClient
from synthetic import synthetic_record

T0 = 1_796_000_000_000_000_000  # ns, a multiple of the 20 ms period
TICK = 1_000_000
PERIOD = 20 * TICK  # the viewer's default decimation period (50 Hz)
PROBES = 50  # probe ticks tried, 1 s each: a bound on a hang
HANG_S = 120.0  # s: a bound on a hang (a busy machine takes what it takes), not a figure


class ViewerRun:
    """A viewer process on a free port and an in-test node that publishes its inputs."""

    def __init__(self, ros_env, args=()):
        import rclpy
        from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
        from sensor_msgs.msg import JointState

        from orthoglide_msgs.msg import (
            CurrentReference,
            IdentifiedParameters,
            LiveIdentification,
            RecorderStatus,
        )

        self.proc = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "orthoglide_ident.nodes.viewer",
                "--ros-args",
                "-p",
                "port:=0",
                *args,
            ],
            env=ros_env,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
        )
        self.lines: list[str] = []
        self._reader = threading.Thread(
            target=lambda: self.lines.extend(iter(self.proc.stdout.readline, "")), daemon=True
        )
        self._reader.start()
        self.rclpy = rclpy
        rclpy.init()
        self.node = rclpy.create_node("viewer_test_publisher")
        latched = QoSProfile(
            depth=1,
            durability=DurabilityPolicy.TRANSIENT_LOCAL,
            reliability=ReliabilityPolicy.RELIABLE,
        )
        self.pub = {
            "q": self.node.create_publisher(JointState, "/orthoglide/joint_states", 1000),
            "v": self.node.create_publisher(
                CurrentReference, "/orthoglide/current_reference", 1000
            ),
            "live": self.node.create_publisher(
                LiveIdentification, "/orthoglide/identification/live", 10
            ),
            "status": self.node.create_publisher(
                RecorderStatus, "/orthoglide/recorder/status", latched
            ),
            "ident": self.node.create_publisher(
                IdentifiedParameters, "/orthoglide/identified_parameters", latched
            ),
        }
        self.url = self._url()

    def _url(self) -> str:
        t_end = time.monotonic() + 60
        while time.monotonic() < t_end and self.proc.poll() is None:
            for line in self.lines:
                m = re.search(r"Foxglove view on (ws://[\d.]+:\d+)", line)
                if m:
                    return m.group(1)
            time.sleep(0.05)
        raise AssertionError("the viewer never printed its URL:\n" + "".join(self.lines))

    def wait_matched(self, keys=("q", "v")) -> None:
        t_end = time.monotonic() + 30
        while any(self.pub[k].get_subscription_count() == 0 for k in keys):
            assert time.monotonic() < t_end, "the viewer never subscribed"
            time.sleep(0.05)

    def wait_flowing(self, client, channels=("/orthoglide/joint_states",), before_ns=T0,
                     publish=None) -> None:
        """Until a probe tick published now reaches ``client`` on each of ``channels``: the ROS
        subscriptions are matched and the server has taken the client's subscription (the
        protocol has no acknowledgement). Probe k is stamped in a period of its own before
        ``before_ns`` (the decimator sends the first tick of each period, in order), so the test's
        own ticks after it are all new; only the last probe's frames are awaited, so none of the
        earlier ones (lost, or in flight) comes after it."""
        publish = publish or (
            lambda ns: self.publish_ticks(
                [ns],
                ["q11", "q12", "q13"],
                np.zeros((1, 3)),
                ["q11", "q12", "q13"],
                np.zeros((1, 3)),
            )
        )
        for k in range(PROBES):
            ns = before_ns - (PROBES - k) * PERIOD
            publish(ns)
            if self._probe_arrived(client, channels, ns):
                return
        raise AssertionError(f"no probe tick reached the client on {channels} in {PROBES} tries")

    @staticmethod
    def _probe_arrived(client, channels, ns) -> bool:
        def arrived(fs) -> bool:
            return all(any(f.topic == c and f.log_time == ns for f in fs) for c in channels)

        return arrived(client.frames(1.0, until=arrived))

    def publish_ticks(self, stamps, q_names, q, v_names, v, burst=50) -> None:
        from sensor_msgs.msg import JointState

        from orthoglide_msgs.msg import CurrentReference

        for k, ns in enumerate(stamps):
            js = JointState(name=list(q_names), position=[float(x) for x in q[k]])
            cr = CurrentReference(name=list(v_names), current=[float(x) for x in v[k]])
            for m in (js, cr):
                m.header.stamp.sec, m.header.stamp.nanosec = divmod(int(ns), 10**9)
            self.pub["q"].publish(js)
            self.pub["v"].publish(cr)
            if k % burst == burst - 1:
                time.sleep(0.01)  # about 5 kHz: faster than real time, within the queue depths

    def close(self) -> str:
        self.node.destroy_node()
        self.rclpy.shutdown()
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=15)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self._reader.join(10)  # it has read the output to its end
        return "".join(self.lines)


@pytest.fixture
def viewer(ros_env):
    run = ViewerRun(ros_env)
    yield run
    log = run.close()
    assert "Traceback" not in log, log


def _live_message():
    from orthoglide_msgs.msg import LiveIdentification

    m = LiveIdentification(status="gains known to 0.14 %: enough data", enough_data=True,
                           joint_names=["q11", "q12", "q13"], drive_gains=[2170.0, 2100.0, 2070.0],
                           drive_gains_rel_std=[0.0014, 0.0011, 0.0008], unloaded_seconds=15.0,
                           loaded_seconds=9.0, singular_ratio=0.01, condition_number=float("inf"),
                           residual_rms=[0.5, 0.4, 0.3], lag=0.9, warnings=["3 ticks lost"])
    m.header.stamp.sec, m.header.stamp.nanosec = divmod(T0 + 123, 10**9)
    return m


def test_a_client_subscribes_and_receives_decimated_frames_of_any_joints(viewer):
    client = FoxgloveClient(viewer.url)
    assert client.server_info["name"] == "orthoglide_ident viewer"
    assert {
        "/orthoglide/joint_states",
        "/orthoglide/current_reference",
        "/orthoglide/setpoints",
        "/orthoglide/identification/live",
        "/orthoglide/recorder/status",
        "/orthoglide/identified_parameters",
        "/orthoglide/forces",
    } <= set(client.channels)
    assert all(
        c["encoding"] == "json" and c["schemaEncoding"] == "jsonschema"
        for c in client.channels.values()
    )
    client.subscribe()
    viewer.wait_matched()
    viewer.wait_flowing(client, ("/orthoglide/joint_states", "/orthoglide/current_reference"))
    names = [f"joint_{i}" for i in range(6)]  # not the Orthoglide: six joints, any names
    stamps = T0 + TICK * np.arange(400)
    q = 0.01 * np.arange(400)[:, None] + np.arange(6)[None, :]
    viewer.publish_ticks(stamps, names, q, ["a", "b"], np.ones((400, 2)))
    viewer.pub["live"].publish(_live_message())
    frames = client.frames(
        HANG_S,
        until=lambda fs: (
            sum(f.topic == "/orthoglide/identification/live" for f in fs)
            and sum(f.topic == "/orthoglide/joint_states" for f in fs) >= 20
        ),
    )
    js = [f for f in frames if f.topic == "/orthoglide/joint_states"]
    # the first tick of every 20 ms of stamps: 1 kHz in, 50 Hz out
    assert [f.log_time for f in js] == list(stamps[::20])
    for f in js:
        k = (f.log_time - T0) // TICK
        assert f.message["header"]["stamp"] == {
            "sec": f.log_time // 10**9,
            "nanosec": f.log_time % 10**9,
        }
        assert f.message["name"] == names and f.message["position"] == pytest.approx(q[k].tolist())
    cr = [f for f in frames if f.topic == "/orthoglide/current_reference"]
    assert cr and cr[0].message["name"] == ["a", "b"]
    live = next(f for f in frames if f.topic == "/orthoglide/identification/live")
    assert live.log_time == T0 + 123
    g = live.message["gains"][1]
    assert (g["joint"], g["value"]) == ("q12", 2100.0) and g["sigma"] == pytest.approx(
        2100 * 0.0011
    )
    assert (
        live.message["status"].startswith("gains known")
        and live.message["warnings"] == "3 ticks lost"
    )
    assert live.message["condition_number"] is None  # inf is not JSON
    client.close()


def test_the_forces_channel_compares_the_measured_and_the_model_force(viewer):
    """Ticks of a model-consistent record and its parameters: measured and model force agree."""
    from orthoglide_ident.model.registry import load_robot
    from orthoglide_msgs.msg import IdentifiedParameters
    from orthoglide_sim.orthoglide import truth as true_parameters

    bm = load_robot(None)
    tp = true_parameters.default_parameters()
    chi = bm.base_values(tp.standard_vector())
    rec = synthetic_record(
        2.0, 0.0, model=bm, chi=chi, g_tau=np.array(tp.g_tau), noise=False, amplitude=0.04, t0_ns=T0
    )
    client = FoxgloveClient(viewer.url)
    client.subscribe(["/orthoglide/forces", "/orthoglide/identified_parameters"])
    viewer.wait_matched(("q", "v", "ident"))
    viewer.pub["ident"].publish(
        IdentifiedParameters(
            method="tls",
            joint_names=list(bm.joint_names),
            drive_gains=list(tp.g_tau),
            drive_gains_rel_std=[0.001] * 3,
            names=list(bm.names),
            values=[float(x) for x in chi],
            rel_std=[0.01] * bm.n_b,
        )
    )
    t_end = time.monotonic() + 20
    while not any("model force from the identified parameters" in line for line in viewer.lines):
        assert time.monotonic() < t_end, "".join(viewer.lines)
        time.sleep(0.05)
    viewer.publish_ticks(rec.stamps_q_ns, bm.joint_names, rec.q, bm.joint_names, rec.v_tau)
    frames = client.frames(
        HANG_S, until=lambda fs: sum(f.topic == "/orthoglide/forces" for f in fs) >= 80
    )
    forces = [f.message for f in frames if f.topic == "/orthoglide/forces"]
    assert len(forces) >= 80  # (2000 ticks - the filter's 2 x 164) / 20
    meas = np.array([m["measured"] for m in forces])
    resid = np.array([m["residual"] for m in forces])
    assert np.all(np.sqrt(np.mean(meas ** 2, axis=0)) > 20.0)  # N
    # the model's sign() friction jumps where a joint reverses: the median, not the max
    assert np.all(np.median(np.abs(resid), axis=0) < 0.01 * np.sqrt(np.mean(meas ** 2, axis=0)))
    # latched, sent on subscribe
    assert any(f.topic == "/orthoglide/identified_parameters" for f in frames)
    client.close()


def test_a_robot_with_a_transmission_is_viewed_by_motor(ros_env, tmp_path):
    """The coupled-wrist UR5 (tests/coupled_view.py): positions joint-side under the joints'
    names, currents under the motors' m1 .. m6. The identified gains and the live estimate come
    named by motor; the forces channel is per motor (measured = model for a model-consistent
    record) with the joints' residual Nᵀ (measured − model) beside it."""
    from coupled_view import G_MOTORS, MOTORS, N_WRIST, coupled_model, coupled_record

    from orthoglide_msgs.msg import IdentifiedParameters, LiveIdentification

    model, chi = coupled_model(tmp_path)
    stamps, q_j, v = coupled_record(model, chi, 2.0, T0)
    joints = list(model.transmission.joints)
    run = ViewerRun(ros_env, ["-p", f"robot:={tmp_path / 'ur5_coupled_view.yaml'}"])
    try:
        client = FoxgloveClient(run.url)
        client.subscribe(["/orthoglide/forces", "/orthoglide/identified_parameters",
                          "/orthoglide/identification/live"])
        run.wait_matched(("q", "v", "ident", "live"))
        run.pub["ident"].publish(
            IdentifiedParameters(
                method="tls",
                joint_names=list(MOTORS),
                drive_gains=G_MOTORS.tolist(),
                drive_gains_rel_std=[0.001] * 6,
                names=list(model.names),
                values=[float(x) for x in chi],
                rel_std=[0.01] * model.n_b,
            )
        )
        t_end = time.monotonic() + 30
        while not any("model force from the identified parameters" in line for line in run.lines):
            assert time.monotonic() < t_end, "".join(run.lines)
            time.sleep(0.05)
        live = LiveIdentification(
            status="ok",
            joint_names=list(MOTORS),
            drive_gains=G_MOTORS.tolist(),
            drive_gains_rel_std=[0.002] * 6,
            residual_rms=[0.001] * 6,
        )
        run.pub["live"].publish(live)
        run.publish_ticks(stamps, joints, q_j, MOTORS, v)
        frames = client.frames(
            HANG_S,
            until=lambda fs: (
                sum(f.topic == "/orthoglide/forces" for f in fs) >= 80
                and any(f.topic == "/orthoglide/identification/live" for f in fs)
            ),
        )
        forces = [f.message for f in frames if f.topic == "/orthoglide/forces"]
        assert len(forces) >= 80  # (2000 ticks - the filter's 2 x 164) / 20
        assert all(m["name"] == list(MOTORS) and m["joint_name"] == joints for m in forces)
        meas = np.array([m["measured"] for m in forces])
        resid = np.array([m["residual"] for m in forces])
        rms = np.sqrt(np.mean(meas ** 2, axis=0))
        assert np.all(rms > 0.01)  # N·m at the motors
        # tests/view/test_residual.py
        assert np.all(np.sqrt(np.mean(resid ** 2, axis=0)) < 1e-6 * rms)
        np.testing.assert_allclose(
            [m["joint_residual"] for m in forces], resid @ N_WRIST, atol=1e-12
        )
        for topic in ("/orthoglide/identified_parameters", "/orthoglide/identification/live"):
            msg = next(f.message for f in frames if f.topic == topic)
            assert [g["joint"] for g in msg["gains"]] == list(MOTORS), msg
            assert [g["value"] for g in msg["gains"]] == pytest.approx(G_MOTORS.tolist())
        client.close()
    finally:
        log = run.close()
    assert "model force: currents from /orthoglide/current_reference" in log, log
    assert "Traceback" not in log and "internal error" not in log, log


def test_a_ros2_control_robot_is_viewed_from_its_broadcaster_topics(ros_env):
    """joint_states (positions, and the effort as currents) and dynamic_joint_states (the current
    interface) as config/ros2_control.yaml sets them: each on its channel, a gripper without a
    current ignored by the model force, which takes the interface (the preferred source)."""
    from sensor_msgs.msg import JointState

    from control_msgs.msg import DynamicJointState, InterfaceValue
    from orthoglide_ident.model.registry import load_robot

    run = ViewerRun(ros_env, ["-p", "robot:=ur5_mount", "-p", "joint_states_topic:=/joint_states",
                              "-p", "dynamic_joint_states_topic:=/dynamic_joint_states"])
    try:
        # hardware order
        joints = list(load_robot("ur5_mount").joint_names)[::-1] + ["gripper_finger_joint"]
        pub_js = run.node.create_publisher(JointState, "/joint_states", 1000)
        pub_d = run.node.create_publisher(DynamicJointState, "/dynamic_joint_states", 1000)
        client = FoxgloveClient(run.url)
        assert {"/joint_states", "/dynamic_joint_states"} <= set(client.channels)
        client.subscribe()
        t_end = time.monotonic() + 30
        while not (pub_js.get_subscription_count() and pub_d.get_subscription_count()):
            assert time.monotonic() < t_end, "the viewer never subscribed"
            time.sleep(0.05)

        def probe(ns: int) -> None:
            for m in (JointState(name=joints, position=[0.0] * 7, effort=[0.0] * 7),
                      DynamicJointState(joint_names=joints, interface_values=[InterfaceValue(
                          interface_names=["position", "current"], values=[0.0, 0.0])] * 7)):
                m.header.stamp.sec, m.header.stamp.nanosec = divmod(ns, 10**9)
                (pub_js if isinstance(m, JointState) else pub_d).publish(m)

        run.wait_flowing(client, ("/joint_states", "/joint_states/effort", "/dynamic_joint_states"),
                         publish=probe)
        for k in range(400):
            sec, nsec = divmod(T0 + k * TICK, 10**9)
            effort = [0.1 * k + j for j in range(6)] + [float("nan")]
            js = JointState(
                name=joints, position=[0.001 * k] * 7, velocity=[0.0] * 7, effort=effort
            )
            d = DynamicJointState(
                joint_names=joints,
                interface_values=[
                    InterfaceValue(
                        interface_names=["position", "current"], values=[0.001 * k, 2 * e]
                    )
                    for e in effort
                ],
            )
            for m in (js, d):
                m.header.stamp.sec, m.header.stamp.nanosec = sec, nsec
            pub_js.publish(js)
            pub_d.publish(d)
            if k % 50 == 49:
                time.sleep(0.01)  # paces the publisher (about 5 kHz), within the queue depths
        frames = client.frames(HANG_S, until=lambda fs: all(
            sum(f.topic == t for f in fs) >= 20 for t in ("/joint_states", "/joint_states/effort",
                                                          "/dynamic_joint_states")))
        by = {
            t: [f for f in frames if f.topic == t]
            for t in ("/joint_states", "/joint_states/effort", "/dynamic_joint_states")
        }
        assert all(len(v) >= 20 for v in by.values()), {t: len(v) for t, v in by.items()}
        f = by["/joint_states/effort"][3]
        k = (f.log_time - T0) // TICK
        assert f.message["name"] == joints and f.message["current"][:6] == pytest.approx(
            [0.1 * k + j for j in range(6)]
        )
        assert f.message["current"][6] is None  # NaN is not JSON
        f = by["/dynamic_joint_states"][3]
        k = (f.log_time - T0) // TICK
        assert f.message["current"][:6] == pytest.approx([2 * (0.1 * k + j) for j in range(6)])
        assert by["/joint_states"][3].message["position"] == pytest.approx([0.001 * k] * 7)
        client.close()
    finally:
        log = run.close()
    assert "model force: currents from /dynamic_joint_states" in log, log
    assert "Traceback" not in log and "Callback failed" not in log, log


def test_garbage_a_vanished_and_a_stalled_client_leave_the_node_serving(viewer):
    garbage = FoxgloveClient(viewer.url)
    garbage.ws.send("{not json")
    garbage.ws.send_binary(b"\x07\x00\xff garbage")
    garbage.ws.send('{"op": "subscribe", "subscriptions": [{"id": 1, "channelId": 99999}]}')
    garbage.ws.send('{"op": "unsubscribe", "subscriptionIds": [42]}')
    stalled = FoxgloveClient(viewer.url)  # subscribes, then never reads
    stalled.subscribe()
    vanished = FoxgloveClient(viewer.url)
    vanished.subscribe()
    viewer.wait_matched()
    viewer.wait_flowing(vanished)
    stamps = T0 + TICK * np.arange(3000)
    q = np.zeros((3000, 3))
    half = 1500
    viewer.publish_ticks(
        stamps[:half], ["q11", "q12", "q13"], q[:half], ["q11", "q12", "q13"], q[:half]
    )
    vanished.ws.sock.shutdown(socket.SHUT_RDWR)  # gone without a closing handshake
    vanished.ws.sock.close()
    viewer.publish_ticks(
        stamps[half:], ["q11", "q12", "q13"], q[half:], ["q11", "q12", "q13"], q[half:]
    )
    garbage.frames(1.0)
    assert garbage.status  # the server told it what was wrong
    fresh = FoxgloveClient(viewer.url)
    fresh.subscribe(["/orthoglide/joint_states"])
    more = T0 + TICK * np.arange(4000, 4200)  # after the probes, in the second after the ticks
    viewer.wait_flowing(fresh, before_ns=int(more[0]))
    viewer.publish_ticks(
        more, ["q11", "q12", "q13"], np.zeros((200, 3)), ["q11", "q12", "q13"], np.zeros((200, 3))
    )
    got = fresh.frames(HANG_S, until=lambda fs: any(f.log_time == more[-20] for f in fs))
    assert [f.log_time for f in got] == list(more[::20])  # every new period, in order
    assert viewer.proc.poll() is None
    for c in (garbage, stalled, fresh):
        c.close()


def test_a_best_effort_publisher_is_followed(viewer):
    """A reliable subscription never matches a best-effort publisher: the viewer takes the topic as
    its publishers offer it (re-checked every 2 s), here the setpoints."""
    from rclpy.qos import QoSProfile, ReliabilityPolicy

    from orthoglide_msgs.msg import JointSetpoint

    pub = viewer.node.create_publisher(
        JointSetpoint,
        "/orthoglide/setpoints",
        QoSProfile(depth=100, reliability=ReliabilityPolicy.BEST_EFFORT),
    )
    t_end = time.monotonic() + 30
    while not any("/orthoglide/setpoints: now taken best_effort" in line for line in viewer.lines):
        assert time.monotonic() < t_end, "".join(viewer.lines)
        time.sleep(0.05)
    client = FoxgloveClient(viewer.url)
    client.subscribe(["/orthoglide/setpoints"])
    while pub.get_subscription_count() == 0:
        assert time.monotonic() < t_end
        time.sleep(0.05)

    def probe(ns: int) -> None:
        m = JointSetpoint(name=["q11", "q12", "q13"], position=[0.0] * 3, velocity=[0.0] * 3,
                          acceleration=[0.0] * 3)
        m.header.stamp.sec, m.header.stamp.nanosec = divmod(ns, 10**9)
        pub.publish(m)

    viewer.wait_flowing(client, ("/orthoglide/setpoints",), publish=probe)
    for k in range(100):
        m = JointSetpoint(name=["q11", "q12", "q13"], position=[0.001 * k] * 3, velocity=[0.1] * 3,
                          acceleration=[-2.0] * 3)
        m.header.stamp.sec, m.header.stamp.nanosec = divmod(T0 + k * TICK, 10**9)
        pub.publish(m)
        time.sleep(0.001)  # paces the publisher (about 1 kHz): best effort drops a burst
    got = client.frames(HANG_S, until=lambda fs: len(fs) >= 3)
    assert got, "no setpoints frame"
    for f in got:  # best effort may lose a message on the way, never alter one
        k = (f.log_time - T0) // TICK
        assert f.message["position"] == pytest.approx([0.001 * k] * 3)
        assert f.message["velocity"] == [0.1] * 3 and f.message["acceleration"] == [-2.0] * 3
    client.close()


@pytest.mark.slow
def test_a_stalled_client_loses_frames_the_others_do_not(ros_env):
    """Every tick sent (rate 1000 Hz), ~24 MB of frames: more than a stalled client's socket
    buffers and queue hold. It loses the excess; a client that reads gets every frame."""
    run = ViewerRun(ros_env, ["-p", "rate:=1000.0"])
    try:
        stalled, reader = FoxgloveClient(run.url), FoxgloveClient(run.url)
        for c in (stalled, reader):
            c.subscribe(["/orthoglide/joint_states"])
        run.wait_matched()
        # the stalled client's subscription is taken with it (one op each, in order)
        run.wait_flowing(reader)
        n, names = 16000, [f"joint_{i:02d}" for i in range(48)]
        stamps = T0 + TICK * np.arange(n)
        q = np.random.default_rng(0).random((n, 48))
        got: list = []
        # in chunks, each read before the next is sent: the reader keeps up whatever the load
        # of the machine (a test of the server's per-client queues, not of this machine's speed)
        for a in range(0, n, 1000):
            run.publish_ticks(stamps[a:a + 1000], names, q[a:a + 1000], ["x"],
                              np.zeros((1000, 1)), burst=100)
            want = a + 1000
            got.extend(reader.frames(60, until=lambda fs: len(got) + len(fs) >= want))
        assert [f.log_time for f in got] == list(stamps)
        late = [f for f in stalled.frames(5) if f.log_time >= T0]  # not the probe ticks before T0
        assert 0 < len(late) < n
        times = [f.log_time for f in late]
        assert times == sorted(times) and set(times) <= set(stamps.tolist())
        assert run.proc.poll() is None
        stalled.close()
        reader.close()
    finally:
        assert "Traceback" not in run.close()


def test_a_port_in_use_is_a_one_line_reason_and_exit_2(ros_env):
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen()
        port = s.getsockname()[1]
        out = subprocess.run(
            [
                sys.executable,
                "-m",
                "orthoglide_ident.nodes.viewer",
                "--ros-args",
                "-p",
                f"port:={port}",
            ],
            env=ros_env,
            capture_output=True,
            text=True,
            timeout=120,
        )
    assert out.returncode == 2
    assert "Traceback" not in out.stderr
    assert out.stderr.strip().splitlines()[-1] == (
        f"viewer: cannot serve the Foxglove view on 127.0.0.1:{port}: Failed to bind port: Address "
        "already in use "
        "(os error 98) (another viewer or program uses it: set the port parameter)"
    )


def test_viewer_help_does_not_start_ros(capsys):
    from orthoglide_ident.nodes.viewer import main

    assert main(["viewer", "--help"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("usage:")
    for word in (
        "host",
        "port",
        "foxglove.sdk.v1",
        "orthoglide/forces",
        "orthoglide/identification/live",
    ):
        assert word in out
