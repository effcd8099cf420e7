"""The identification node with a robot whose joints are locked (issue 43): its ``robot``
parameter names the Panda's robot file (example-robot-data as it comes, the fingers locked:
tests/locked_panda.py); its identify service answers from the bags of the 7 arm joints with the
gains within 3 σ of the generator's (Pinocchio's RNEA on the full URDF)."""
from __future__ import annotations

import numpy as np
import pytest

from orthoglide_ident import bags

pytest.importorskip("rclpy")
L = pytest.importorskip("locked_panda")
if not L.installed():
    pytest.skip("example-robot-data (requirements.txt) is not installed", allow_module_level=True)

pytestmark = pytest.mark.slow  # ~20 s on a busy machine: the node's start and its imports

NODE = "from orthoglide_ident.nodes.identification import main; import sys; sys.exit(main())"


def test_the_node_identifies_the_panda_with_its_fingers_locked(spawn_python, tmp_path):
    import rclpy

    from orthoglide_msgs.srv import Identify

    folder = tmp_path / "bags"
    for rec in L.records(10.0, 0.002):
        p = {"payload_frame": L.PAYLOAD_FRAME, "payload_com": L.PAYLOAD_COM,
             "payload_inertia": L.PAYLOAD_INERTIA} if rec.payload_mass else None
        bags.write_bag(folder / rec.source, rec.stamps_q_ns, rec.q, rec.v_tau, rec.condition,
                       rec.payload_mass, L.ARM, payload=p)
    proc = spawn_python(NODE, "--ros-args", "-p", f"bag_dir:={folder}", "-p",
                        f"robot:={L.robot_file(tmp_path)}", "-p", "live:=false", "-p",
                        "lag_model:=off")
    rclpy.init()
    try:
        n = rclpy.create_node("test_locked_client")
        cli = n.create_client(Identify, "/orthoglide/identify")
        assert cli.wait_for_service(timeout_sec=60), "service /orthoglide/identify did not appear"
        fut = cli.call_async(Identify.Request())
        rclpy.spin_until_future_complete(n, fut, timeout_sec=120)
        res = fut.result()
        assert res is not None and res.success, res and res.message
        p = res.parameters
        assert tuple(p.joint_names) == L.ARM and all(p.drive_gains_determined)
        err = np.array(p.drive_gains) / L.TRUE_GAINS - 1
        assert np.all(np.abs(err) < 3 * np.array(p.drive_gains_rel_std)), (err, p)
        n.destroy_node()
    finally:
        rclpy.shutdown()
    assert proc.poll() is None, "the node died"
