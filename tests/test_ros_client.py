"""orthoglide-ident's client side of the node set: record start|stop|status, watch, identify
--service."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from orthoglide_ident.ros import processes as children  # children end with this process

ROOT = Path(__file__).resolve().parents[1]


def cli(ros_env, *args: str, timeout: float = 120.0) -> subprocess.CompletedProcess:
    return children.run([sys.executable, "-m", "orthoglide_ident.cli", *args], env=ros_env,
                          capture_output=True, text=True, timeout=timeout)


def test_record_commands_against_the_recorder(spawn_python, ros_env, tmp_path):
    spawn_python("from orthoglide_ident.nodes.recorder import main; import sys; sys.exit(main())",
                 "--ros-args", "-p", f"output_dir:={tmp_path}")
    bad = cli(ros_env, "record", "start", "--condition", "loaded")  # no payload mass
    assert bad.returncode == 2 and "payload" in bad.stderr and "Traceback" not in bad.stderr, (
        bad.stderr
    )
    start = cli(ros_env, "record", "start", "--condition", "unloaded", "--name", "cli_run")
    assert start.returncode == 0 and "recording unloaded" in start.stdout, start.stderr
    status = cli(ros_env, "record", "status")
    assert (
        status.returncode == 0
        and "recording unloaded" in status.stdout
        and "cli_run" in status.stdout
    )
    watch = cli(ros_env, "watch", "--seconds", "5")
    assert watch.returncode == 0 and "recorder: recording unloaded" in watch.stdout
    stop = cli(ros_env, "record", "stop")  # nothing published: a failure that says why
    assert stop.returncode == 2 and "nothing recorded" in stop.stderr, (stop.stdout, stop.stderr)
    again = cli(ros_env, "record", "stop")
    assert again.returncode == 2 and "not recording" in again.stderr


def test_identify_through_the_service(spawn_python, ros_env, tmp_path):
    spawn_python(
        "from orthoglide_ident.nodes.identification import main; import sys; sys.exit(main())",
        "--ros-args",
        "-p",
        f"bag_dir:={tmp_path}",
        "-p",
        "live:=false",
    )
    out = cli(
        ros_env, "identify", "--service", str(ROOT / "bags/unloaded"), str(ROOT / "bags/loaded")
    )
    assert out.returncode == 0 and out.stdout.startswith("tls: drive gains ["), (
        out.stdout,
        out.stderr,
    )
    none = cli(ros_env, "identify", "--service")  # bag_dir is empty
    assert none.returncode == 2 and "no bags" in none.stderr and "\n" not in none.stderr.strip()


def test_no_node_is_a_one_line_reason(ros_env):
    out = cli(ros_env, "record", "stop", timeout=60)
    assert out.returncode == 2 and "no service" in out.stderr and "Traceback" not in out.stderr


def test_identify_service_json_is_the_offline_json(spawn_python, ros_env, tmp_path):
    """`identify --service --json FILE` writes the document an offline `identify --json` writes
    on the same bags (issue 47: it wrote nothing and exited 0)."""
    import json

    spawn_python("from orthoglide_ident.nodes.identification import main; import sys; "
                 "sys.exit(main())", "--ros-args", "-p", f"bag_dir:={tmp_path}",
                 "-p", "live:=false")
    bags = [str(ROOT / "bags/unloaded"), str(ROOT / "bags/loaded")]
    served, offline = tmp_path / "served.json", tmp_path / "offline.json"
    out = cli(ros_env, "identify", "--service", *bags, "--json", str(served))
    assert out.returncode == 0 and served.is_file(), (out.stdout, out.stderr)
    ref = cli(ros_env, "identify", *bags, "--json", str(offline), "-q")
    assert ref.returncode == 0, ref.stderr
    docs = [json.loads(f.read_text()) for f in (served, offline)]
    for d in docs:  # how long each step took is the one thing two runs do not share
        assert d["diagnostics"].pop("timings_s")["total"] > 0
    assert docs[0] == docs[1]


@pytest.mark.parametrize("flag", [["--gains", "1,2,3"], ["--r-sigma", "5"], ["--consistent"],
                                  ["--validate", "x"], ["--robot", "ur5"]])
def test_identify_service_refuses_flags_it_cannot_send(ros_env, flag):
    """No node needed: the refusal comes before any call, in one line naming the flag."""
    out = cli(ros_env, "identify", "--service", *flag, timeout=60)
    assert out.returncode == 2 and flag[0] in out.stderr, (out.stdout, out.stderr)
    assert len(out.stderr.strip().splitlines()) == 1 and "Traceback" not in out.stderr
