"""ros/guard.py and the checks of ros/spin.py: a callback that raises is one log line, a
service that raises still answers (success false, the reason), the executor goes on serving; a
bad parameter file is a one-line reason before rcl sees it."""
from __future__ import annotations

import threading
import time

import pytest
import rclpy

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.ros.spin import check_params_files


def test_raising_callbacks_are_logged_once_answered_and_the_node_goes_on(capfd):
    from rclpy.executors import SingleThreadedExecutor
    from std_msgs.msg import String
    from std_srvs.srv import Trigger

    from orthoglide_ident.ros.guard import REPEAT_LOG_S, CallbackGuard

    t0 = time.monotonic()
    rclpy.init()
    node = rclpy.create_node("test_guard_node")
    client_node = rclpy.create_node("test_guard_client")
    ticks, heard = [], []

    def on_trigger(request, response):
        response.success = True  # half-filled when it fails: the answer must not say success
        raise ZeroDivisionError("division by zero")

    def on_timer():
        ticks.append(1)
        raise RuntimeError("timer bug")

    def on_message(msg):
        heard.append(msg.data)
        if msg.data == "bad":
            raise ValueError("cannot parse 'bad'")

    node.create_service(Trigger, "guard_test", on_trigger)
    node.create_timer(0.05, on_timer)
    node.create_subscription(String, "guard_topic", on_message, 10)
    CallbackGuard(node).wrap_all()
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    spinner = threading.Thread(target=executor.spin, daemon=True)
    spinner.start()
    try:
        cli = client_node.create_client(Trigger, "guard_test")
        pub = client_node.create_publisher(String, "guard_topic", 10)
        assert cli.wait_for_service(timeout_sec=20)
        for _ in range(2):  # answered both times: the node was not left deaf by the first failure
            fut = cli.call_async(Trigger.Request())
            rclpy.spin_until_future_complete(client_node, fut, timeout_sec=20)
            assert fut.done()
            res = fut.result()
            assert (
                not res.success
                and res.message == "internal error: ZeroDivisionError: division by zero"
            )
        deadline = time.monotonic() + 20
        while pub.get_subscription_count() < 1 and time.monotonic() < deadline:
            time.sleep(0.05)
        for data in ("bad", "good"):
            pub.publish(String(data=data))
        while heard != ["bad", "good"] and time.monotonic() < deadline:
            time.sleep(0.05)
        assert heard == ["bad", "good"]  # the message after the failing one arrived
        n = len(ticks)
        while len(ticks) < n + 3 and time.monotonic() < deadline:
            time.sleep(0.05)
        # the timer goes on firing, the executor spinning
        assert len(ticks) >= n + 3 and spinner.is_alive()
    finally:
        executor.shutdown()
        spinner.join(5)
        node.destroy_node()
        client_node.destroy_node()
        rclpy.shutdown()
    elapsed = time.monotonic() - t0
    err = capfd.readouterr().err
    lines = [ln for ln in err.splitlines() if "failed:" in ln]
    # one line per failing callback, then one per REPEAT_LOG_S at most (repeats counted, not logged)
    assert len([ln for ln in lines if "service guard_test failed: ZeroDivisionError" in ln]) == 1, (
        lines
    )
    timer = [
        ln for ln in lines if "on_timer failed: RuntimeError: timer bug; the node goes on" in ln
    ]
    assert 1 <= len(timer) <= 1 + elapsed / REPEAT_LOG_S and len(timer) < len(ticks), (
        timer,
        len(ticks),
    )
    assert (
        len([ln for ln in lines if "guard_topic failed: ValueError: cannot parse 'bad'" in ln]) == 1
    )
    assert "Traceback" not in err


def test_a_parameter_file_is_checked_before_rcl_reads_it(tmp_path):
    good = tmp_path / "good.yaml"
    good.write_text("/**:\n  ros__parameters:\n    batch: 5\n")
    check_params_files(["ctc", "--ros-args", "--params-file", str(good), "-p", "batch:=3"])
    # outside --ros-args: not ours
    check_params_files(["ctc", "--params-file", "not/ros/args.yaml"])
    bad = tmp_path / "bad.yaml"
    bad.write_text("orthoglide_ctc:\n  ros__parameters: [batch]\n")
    with pytest.raises(ConfigError, match="is not a ROS 2 parameter file"):
        check_params_files(["ctc", "--ros-args", "-p", "x:=1", "--params-file", str(bad)])
    with pytest.raises(
        ConfigError, match="cannot read parameter file .*missing.yaml: No such file"
    ):
        check_params_files(["ctc", "--ros-args", "--params-file", str(tmp_path / "missing.yaml")])
