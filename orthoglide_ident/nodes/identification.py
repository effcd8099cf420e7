"""Identification node: the /orthoglide/identify service over the IDIM-TLS core.

    ros2 run orthoglide_ident identification [--ros-args -p bag_dir:=bags -p method:=tls ...]

A call identifies drive gains and base parameters from the bags it names (or, when it names none,
every bag under ``bag_dir``), answers with the result, and publishes it latched on
/orthoglide/identified_parameters for the CTC node. The work runs on its own thread of a
multi-threaded executor: a second call while one runs gets ``success: false`` at once.
"""
from __future__ import annotations

import sys
import threading
from pathlib import Path

from orthoglide_ident.nodes._spin import spin

HELP = """\
usage: ros2 run orthoglide_ident identification [--ros-args -p NAME:=VALUE ...]

Identifies the Orthoglide's drive gains and dynamic parameters (IDIM-TLS, Briot & Gautier 2013)
from recorded bags when /orthoglide/identify is called.

ROS parameters:
  bag_dir (string, default "bags")   where to look for bags when a request names none
  method (string, default "tls")     tls: gains identified, payload mass known;
                                     wls: gains given (manufacturer's 2001 N/A), payload estimated
  essential (bool, default false)    also reduce to essential parameters (Sect. 5.2)
  r_sigma (double, default 10.0)     stop ratio max %sigma / min %sigma of that reduction
  config (string, default "")        identification options YAML (same keys as the CLI's --config)

Service  /orthoglide/identify (orthoglide_msgs/srv/Identify)
  request: bags (paths; empty = every bag in bag_dir), payload_mass (kg; 0 = from the bag tags),
           method ("" = the parameter), essential
  reply:   success, message (one line), parameters
Topic    /orthoglide/identified_parameters (orthoglide_msgs/msg/IdentifiedParameters,
         transient local, depth 1): the last successful result.
"""


def find_bags(bag_dir: Path) -> list[str]:
    """Bag directories (holding metadata.yaml) and lone .mcap files directly under bag_dir."""
    if not bag_dir.is_dir():
        return []
    found = []
    for p in sorted(bag_dir.iterdir()):
        if (p / "metadata.yaml").is_file() or (p.is_file() and p.suffix == ".mcap"):
            found.append(str(p))
    return found


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv if argv is None else argv
    if any(a in ("-h", "--help") for a in argv[1:]):
        print(HELP)
        return 0

    # One BLAS thread: the solves are small, and threads only contend on a loaded machine.
    import os

    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    from rclpy.callback_groups import ReentrantCallbackGroup
    from rclpy.node import Node
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

    from orthoglide_ident.errors import OrthoglideError
    from orthoglide_ident.identify.options import IdentifyOptions
    from orthoglide_ident.identify.pipeline import identify
    from orthoglide_msgs.msg import IdentifiedParameters
    from orthoglide_msgs.srv import Identify

    class IdentificationNode(Node):
        def __init__(self) -> None:
            super().__init__("orthoglide_identification")
            self.declare_parameter("bag_dir", "bags")
            self.declare_parameter("method", "tls")
            self.declare_parameter("essential", False)
            self.declare_parameter("r_sigma", 10.0)
            self.declare_parameter("config", "")
            latched = QoSProfile(
                depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL, reliability=ReliabilityPolicy.RELIABLE
            )
            self.pub = self.create_publisher(IdentifiedParameters, "/orthoglide/identified_parameters", latched)
            self.busy = threading.Lock()
            self.create_service(
                Identify, "/orthoglide/identify", self.on_identify, callback_group=ReentrantCallbackGroup()
            )
            self.get_logger().info("ready: call /orthoglide/identify")

        def param(self, name: str):
            return self.get_parameter(name).value

        def on_identify(self, request, response):
            if not self.busy.acquire(blocking=False):
                response.success = False
                response.message = "busy: another identification is running; call again when it has answered"
                return response
            try:
                self.run(request, response)
            finally:
                self.busy.release()
            return response

        def run(self, request, response) -> None:
            bags = list(request.bags) or find_bags(Path(self.param("bag_dir")))
            method = request.method or self.param("method")
            try:
                if not bags:
                    raise OrthoglideError(f"no bags given and none found in bag_dir '{self.param('bag_dir')}'")
                options = IdentifyOptions.from_yaml(self.param("config")) if self.param("config") else None
                if options is not None or self.param("r_sigma") != 10.0:
                    options = (options or IdentifyOptions()).replace(r_sigma=float(self.param("r_sigma")))
                self.get_logger().info(f"identifying ({method}) from {len(bags)} bag(s): {', '.join(bags)}")
                result = identify(
                    bags,
                    payload_mass=request.payload_mass if request.payload_mass > 0 else None,
                    method=method,
                    essential=bool(request.essential or self.param("essential")),
                    options=options,
                )
            except OrthoglideError as e:
                response.success, response.message = False, str(e).splitlines()[0]
                self.get_logger().error(f"identification failed: {response.message}")
                return
            except Exception as e:  # a bug must not kill the node: answer and log it
                response.success, response.message = False, f"internal error: {type(e).__name__}: {e}"
                self.get_logger().error(response.message)
                return
            msg = IdentifiedParameters()
            msg.header.stamp = self.get_clock().now().to_msg()
            for key, value in result.message_fields().items():
                setattr(msg, key, value)
            self.pub.publish(msg)
            gains = ", ".join(f"{g:.1f}" for g in msg.drive_gains)
            response.success = True
            response.message = (
                f"{method}: drive gains [{gains}] N/A, {len(msg.names)} parameters, "
                f"residual rms {msg.residual_rms:.3g} N, cond {msg.condition_number:.3g}"
            )
            response.parameters = msg
            self.get_logger().info(response.message)

    return spin(IdentificationNode, argv, "identification", threads=2)

if __name__ == "__main__":
    sys.exit(main())
