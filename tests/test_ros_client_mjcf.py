"""MJCF out from the identification service (issue 45): ``identify --service --mjcf-out FILE
--robot R`` writes the identified robot on the client's side from the node's JSON
(orthoglide/identify/json) and R's description; the node's parameter ``mjcf_out`` writes it on
the node's side after each identification and says so in the reply. Checked against MuJoCo
itself: its inverse dynamics on the written file against Pinocchio's regressor times the
consistent χ_st of the JSON (model/mjcf_check.py), <= 1 % rms per joint."""
from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from orthoglide_ident.model.mjcf_check import RMS_BAR, inverse_dynamics_rms
from orthoglide_ident.model.registry import load_robot
from orthoglide_ident.ros import processes as children  # children end with this process


def cli(ros_env, *args: str, timeout: float = 180.0) -> subprocess.CompletedProcess:
    return children.run([sys.executable, "-m", "orthoglide_ident.cli", *args], env=ros_env,
                        capture_output=True, text=True, timeout=timeout)


@pytest.fixture(scope="module")
def ur5_bags(tmp_path_factory) -> list[str]:
    """6 s of the simulated UR5 unloaded and with a 2 kg payload, as bags."""
    from orthoglide_sim.arm_or_chain.bags import write_record
    from orthoglide_sim.arms.record import simulate_arm

    root = tmp_path_factory.mktemp("ur5_bags")
    runs = [simulate_arm(6.0, "ur5", payload=p, trajectory=t, seed=s)
            for p, t, s in ((None, "exciting1", 0), ("2.0", "exciting2", 1))]
    return [str(write_record(root / f"r{i}", r)) for i, r in enumerate(runs)]


def test_service_mjcf_out_on_both_sides(spawn_python, ros_env, tmp_path, ur5_bags):
    node_file = tmp_path / "node" / "identified.xml"  # a folder the node creates
    spawn_python("from orthoglide_ident.nodes.identification import main; import sys; "
                 "sys.exit(main())", "--ros-args", "-p", "robot:=ur5", "-p", "live:=false",
                 "-p", f"bag_dir:={tmp_path}", "-p", f"mjcf_out:={node_file}")
    client_file, served = tmp_path / "client" / "ur5.xml", tmp_path / "served.json"
    urdf = tmp_path / "client" / "ur5.urdf"
    out = cli(ros_env, "identify", "--service", *ur5_bags, "--robot", "ur5", "--mjcf-out",
              str(client_file), "--urdf-out", str(urdf), "--json", str(served))
    assert out.returncode == 0, (out.stdout, out.stderr)
    assert f"MJCF written to {node_file}" in out.stdout  # the reply says where
    assert f"wrote {client_file}" in out.stderr
    doc = json.loads(served.read_text())
    robot = load_robot("ur5")
    named = doc["consistency"]["standard"]  # the node ran the consistency step for mjcf_out
    chi = np.array([named[n] for n in robot.standard_names])
    q, qd, qdd = robot.random_states(40, seed=4)
    for f in (client_file, node_file):
        rms = inverse_dynamics_rms(f.read_text(), robot, chi, q, qd, qdd)
        assert np.all(rms < RMS_BAR), (f, rms)
    assert client_file.read_text() == node_file.read_text()  # one answer, one robot, one file
    masses = [i for i, n in enumerate(robot.standard_names) if n.startswith("m_")]
    from_urdf = load_robot(str(urdf)).standard_values()  # the URDF's inertials, read back
    np.testing.assert_allclose(from_urdf[masses], chi[masses], rtol=1e-6)


def test_service_mjcf_out_needs_the_robot(ros_env, tmp_path):
    """No node needed: refused before any call, in one line naming --robot."""
    out = cli(ros_env, "identify", "--service", "--mjcf-out", str(tmp_path / "x.xml"),
              timeout=60)
    assert out.returncode == 2 and "give --robot" in out.stderr, (out.stdout, out.stderr)
    assert len(out.stderr.strip().splitlines()) == 1 and not (tmp_path / "x.xml").exists()


def test_the_node_says_why_it_wrote_no_mjcf(tmp_path):
    """A partial answer (no consistent set: the standard parameters need every gain) writes
    nothing and the reply says so, the identification still a success."""
    from types import SimpleNamespace

    from orthoglide_ident.nodes.identification import IdentificationNode

    path = tmp_path / "x.xml"
    partial = SimpleNamespace(consistency=None, complete=False)
    said = IdentificationNode.write_mjcf(None, partial, load_robot("ur5"), str(path))
    assert said == f"MJCF not written to {path}: a partial answer" and not path.exists()
