"""CTC node: computed torque control with the identified model (orthoglide_ident.control).

    ros2 run orthoglide_ident ctc [--ros-args -p trajectory:=test1 ...]
"""
from __future__ import annotations

import sys

from orthoglide_ident.nodes._spin import spin

HELP = """\
usage: ros2 run orthoglide_ident ctc [--ros-args -p NAME:=VALUE ... | --params-file config/ctc.yaml]

Computed torque control of the Orthoglide (Briot & Gautier 2013, Sect. 5.2): IDIM feed-forward
with the identified base parameters and payload mass along the reference, plus a PID with the
simulator's linear part (triple pole at omega on m_nominal), divided by the identified drive gains.

Subscribes /orthoglide/identified_parameters (orthoglide_msgs/IdentifiedParameters, transient
local, depth 1) and /orthoglide/joint_states (sensor_msgs/JointState, q11..q13). For every joint
state it publishes orthoglide_msgs/CurrentReference (A, same header) on /orthoglide/current_command
(what the driver's controller:=external applies). Until parameters arrive it publishes nothing and
says so in the log; new parameters replace the old ones at once.

Setpoint: the simulator's trajectory named by the parameter `trajectory`, evaluated from t = 0 at
the first joint state received once parameters are in (the start of control; time then follows
the joint states' header stamps). test1 and test2 start at rest where the driver's external mode
starts the robot.

ROS parameters:
  trajectory (string, default "test1")  test1, test2, exciting, exciting2 or a .json Fourier file
  payload_mass (double, default -1.0)   kg put in the model; < 0: the message's payload_mass
  omega (double, default 100.0)         rad/s, bandwidth of the linear part
  m_nominal (double, default 10.0)      kg, nominal mass of the linear part
"""
JOINTS = ["q11", "q12", "q13"]


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv if argv is None else argv
    if any(a in ("-h", "--help") for a in argv[1:]):
        print(HELP)
        return 0

    import numpy as np
    from rclpy.node import Node
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState

    from orthoglide_ident.control import CTC, CTCParameters, LinearGains
    from orthoglide_ident.errors import OrthoglideError
    from orthoglide_msgs.msg import CurrentReference, IdentifiedParameters
    from orthoglide_sim.trajectories import get_trajectory

    class CTCNode(Node):
        def __init__(self) -> None:
            super().__init__("orthoglide_ctc")
            self.declare_parameter("trajectory", "test1")
            self.declare_parameter("payload_mass", -1.0)
            self.declare_parameter("omega", 100.0)
            self.declare_parameter("m_nominal", 10.0)
            p = {n: self.get_parameter(n).value for n in ("trajectory", "payload_mass", "omega", "m_nominal")}
            self.reference = get_trajectory(str(p["trajectory"])).evaluate
            self.gains = LinearGains.from_bandwidth(float(p["omega"]), float(p["m_nominal"]))
            self.payload_mass = float(p["payload_mass"])
            self.ctc: CTC | None = None
            self.t0_ns: int | None = None
            latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                                 reliability=ReliabilityPolicy.RELIABLE)
            self.create_subscription(IdentifiedParameters, "/orthoglide/identified_parameters", self.on_params,
                                     latched)
            self.create_subscription(JointState, "/orthoglide/joint_states", self.on_joint_state, 100)
            self.pub = self.create_publisher(CurrentReference, "/orthoglide/current_command", 100)
            self.get_logger().info(f"trajectory {p['trajectory']}; waiting for /orthoglide/identified_parameters "
                                   "(publishing nothing until they arrive)")

        def on_params(self, msg) -> None:
            fields = {"names": msg.names, "values": msg.values, "drive_gains": msg.drive_gains,
                      "payload_mass": msg.payload_mass}
            try:
                params = CTCParameters.from_message_fields(
                    fields, None if self.payload_mass < 0 else self.payload_mass)
            except OrthoglideError as e:
                state = "keeping the previous ones" if self.ctc else "still waiting"
                self.get_logger().error(f"identified parameters rejected, {state}: {e}")
                return
            if self.ctc is None:
                self.ctc = CTC(params, self.reference, self.gains)
            else:
                self.ctc.set_params(params)
            gains = ", ".join(f"{g:.1f}" for g in params.drive_gains)
            self.get_logger().info(f"parameters in ({msg.method}): drive gains [{gains}] N/A, "
                                   f"{len(params.names)} base parameters, payload {params.payload_mass:.4g} kg")

        def on_joint_state(self, msg) -> None:
            if self.ctc is None:
                self.get_logger().warning("no identified parameters yet: no current command published",
                                          throttle_duration_sec=5.0)
                return
            try:
                q = np.array([msg.position[list(msg.name).index(j)] for j in JOINTS], dtype=float)
            except (ValueError, IndexError):
                self.get_logger().warning(f"joint state without positions for {', '.join(JOINTS)}: ignored",
                                          throttle_duration_sec=5.0)
                return
            stamp_ns = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
            if self.t0_ns is None:
                self.t0_ns = stamp_ns
                self.get_logger().info("control started: trajectory time 0 at this joint state")
            k = int(round((stamp_ns - self.t0_ns) * 1e-9 / self.ctc.tick))
            try:
                v_tau = self.ctc.command(k, q)
            except OrthoglideError as e:  # e.g. the reference crosses a singularity
                self.get_logger().error(f"no command: {e}", throttle_duration_sec=5.0)
                return
            self.pub.publish(CurrentReference(header=msg.header, name=JOINTS, current=[float(v) for v in v_tau]))

    return spin(CTCNode, argv, "ctc")

if __name__ == "__main__":
    sys.exit(main())
