"""Driver node: the simulated Orthoglide and its controller (`ros2 run orthoglide_ident driver`).

Publishes, once per 1 kHz controller tick and with the same header.stamp:
  /orthoglide/joint_states       sensor_msgs/JointState (name q11..q13, position m)
  /orthoglide/current_reference  orthoglide_msgs/CurrentReference (name q11..q13, current A)
In external mode it applies the latest orthoglide_msgs/CurrentReference received on
/orthoglide/current_command (zero-order hold). With realtime:=false it publishes /clock and runs
as fast as it can (stamps are simulated time from 0).
"""
from __future__ import annotations

import os
import sys
import threading
import time

PARAMETERS = {
    "payload": ("none", "none, 1.983, 1.136 or a custom mass in kg"),
    "trajectory": ("exciting", "exciting, exciting2, test1, test2 or a .json Fourier trajectory"),
    "controller": ("pid", "pid, pid_ff or external"),
    "duration": (0.0, "seconds to run, 0 = until shut down"),
    "realtime": (True, "false: publish /clock and run faster than real time"),
    "params_file": ("", "YAML overriding the true plant parameters (config/plant.yaml)"),
    "seed": (0, "seed of the current noise"),
    "noise": (True, "current noise on/off"),
}
JOINTS = ["q11", "q12", "q13"]


def _usage() -> str:
    lines = ["usage: ros2 run orthoglide_ident driver [--ros-args -p NAME:=VALUE ...]", "", __doc__.strip(), "",
             "ROS parameters (--ros-args -p name:=value):"]
    lines += [f"  {k:<12} default {v[0]!r:<12} {v[1]}" for k, v in PARAMETERS.items()]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv if argv is None else argv
    if "-h" in argv or "--help" in argv:
        print(_usage())
        return 0
    import rclpy
    from rclpy.executors import ExternalShutdownException
    from rcl_interfaces.msg import ParameterDescriptor
    from rclpy.node import Node
    from rosgraph_msgs.msg import Clock
    from sensor_msgs.msg import JointState

    from orthoglide_ident.errors import OrthoglideError
    from orthoglide_msgs.msg import CurrentReference
    from orthoglide_sim.session import DriverSession, parse_payload
    from orthoglide_sim.true_parameters import load_parameters

    class Driver(Node):
        def __init__(self):
            super().__init__("orthoglide_driver")
            for name, (default, text) in PARAMETERS.items():  # payload may be given as 1.983 or "none"
                self.declare_parameter(name, default, ParameterDescriptor(description=text,
                                                                          dynamic_typing=name == "payload"))
            v = {name: self.get_parameter(name).value for name in PARAMETERS}
            self.realtime, self.duration = bool(v["realtime"]), float(v["duration"])
            self.session = DriverSession(parse_payload(v["payload"]), v["trajectory"], v["controller"],
                                         load_parameters(v["params_file"] or None), int(v["seed"]), bool(v["noise"]),
                                         start_ns=0)
            # reliable, keep last 1000 (1 s): a subscriber starved of CPU for a moment gets the ticks
            # its DDS reader missed resent from this history (depth 100 lost ~280 on a 0.5 s stall)
            self.pub_js = self.create_publisher(JointState, "/orthoglide/joint_states", 1000)
            self.pub_cr = self.create_publisher(CurrentReference, "/orthoglide/current_reference", 1000)
            self.pub_clock = None if self.realtime else self.create_publisher(Clock, "/clock", 10)
            self.command = None
            if v["controller"] == "external":
                self.create_subscription(CurrentReference, "/orthoglide/current_command", self._on_command, 10)
            self.session.warm_up()
            self.late = 0
            self.get_logger().info(f"driver: controller {v['controller']}, payload {v['payload']}, "
                                   f"trajectory {v['trajectory']}, realtime {self.realtime}")

        def _on_command(self, msg):
            if len(msg.current) == 3:
                self.command = list(msg.current)
            else:
                self.get_logger().warning(f"ignored current command with {len(msg.current)} values (need 3)")

        def publish_tick(self) -> int:
            stamp_ns, q, v_tau = self.session.next_tick(self.command)
            sec, nsec = divmod(stamp_ns, 1_000_000_000)
            if self.pub_clock is not None:
                clock = Clock()
                clock.clock.sec, clock.clock.nanosec = sec, nsec
                self.pub_clock.publish(clock)
            js = JointState(name=JOINTS, position=[float(x) for x in q])
            js.header.stamp.sec, js.header.stamp.nanosec = sec, nsec
            cr = CurrentReference(header=js.header, name=JOINTS, current=[float(x) for x in v_tau])
            self.pub_js.publish(js)
            self.pub_cr.publish(cr)
            return stamp_ns

        def run(self) -> None:
            """Publish ticks at their deadlines (realtime) or back to back (sim time)."""
            n_ticks = int(round(self.duration * 1000)) if self.duration > 0 else None
            stop = threading.Event()
            worker = threading.Thread(target=self._produce, args=(stop,), daemon=True)
            worker.start()
            if self.realtime:  # stamps are the ticks' nominal wall-clock times from now on
                self.session.start_ns = time.time_ns()
            t0 = time.monotonic_ns()
            k = 0
            try:
                while rclpy.ok() and (n_ticks is None or k < n_ticks):
                    if self.realtime:
                        deadline = t0 + k * 1_000_000
                        delay = deadline - time.monotonic_ns()
                        if delay > 0:
                            time.sleep(delay / 1e9)
                        elif delay < -500_000:
                            self.late += 1
                    try:
                        self.publish_tick()
                    except Exception:
                        if rclpy.ok():
                            raise
                        break  # Ctrl-C shut the context down between the check and the publish
                    k += 1
            finally:
                stop.set()
                # a daemon thread still inside jax when Python finalises aborts the process
                # ("terminate called ... FATAL: exception not rethrown", exit -6): wait for it
                worker.join(timeout=30.0)
            done = f"driver: {k} ticks published, {self.late} more than 0.5 ms late"
            if rclpy.ok():
                self.get_logger().info(done)
            else:
                print(done, file=sys.stderr)

        def _produce(self, stop) -> None:
            try:  # compute ahead at a lower priority than the publishing loop
                os.setpriority(os.PRIO_PROCESS, threading.get_native_id(), 10)
            except (AttributeError, OSError):
                pass
            while not stop.is_set():
                if not self.session.fill_ahead(min_ticks=3 * 1000):
                    time.sleep(0.01)

    from rclpy.executors import SingleThreadedExecutor

    rclpy.init(args=argv)
    executor = SingleThreadedExecutor()
    spinner = None
    try:
        node = Driver()
        executor.add_node(node)
        def spin_quietly() -> None:  # subscriptions (external mode); Ctrl-C ends it, not an error
            try:
                executor.spin()
            except (KeyboardInterrupt, ExternalShutdownException):
                pass

        spinner = threading.Thread(target=spin_quietly, daemon=True)
        spinner.start()
        node.run()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except OrthoglideError as exc:
        print(f"driver: {exc}", file=sys.stderr)
        return 2
    finally:
        executor.shutdown()
        if spinner is not None:
            spinner.join(timeout=2.0)
        if rclpy.ok():
            rclpy.shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
