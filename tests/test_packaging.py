"""What `make setup` leaves in the venv prefix: a ROS 2 layout that `ros2 run` and ament lookups
use without sourcing anything (docs/design/interfaces.md)."""
from __future__ import annotations

import importlib.util
import os
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from orthoglide_ident.ros import processes as children  # children end with this process

ROOT = Path(__file__).resolve().parent.parent
PREFIX = Path(sys.prefix).resolve()

# `ros2 run orthoglide_ident <exec>` -> module whose main() it runs; fixed by the lead.
EXECUTABLES = {
    "driver": "orthoglide_sim.nodes.driver",
    "recorder": "orthoglide_ident.nodes.recorder",
    "identification": "orthoglide_ident.nodes.identification",
    "ctc": "orthoglide_ident.nodes.ctc",
    "viewer": "orthoglide_ident.nodes.viewer",
    "excitation": "orthoglide_ident.nodes.excitation",
}


def _module_exists(name: str) -> bool:
    try:
        return importlib.util.find_spec(name) is not None
    except ModuleNotFoundError:
        return False


def test_launcher_table_matches_install_layout() -> None:
    from orthoglide_ident._install_ament import EXECUTABLES as installed

    assert installed == EXECUTABLES
    for name, module in EXECUTABLES.items():
        assert f"from {module} import main" in (ROOT / "resource" / "launchers" / name).read_text()


@pytest.mark.parametrize("package", ["orthoglide_ident", "orthoglide_msgs"])
def test_ament_index_finds_package_in_venv_without_sourcing(package: str) -> None:
    """In a fresh interpreter with AMENT_PREFIX_PATH unset, the .pth points ament at the venv."""
    env = {k: v for k, v in os.environ.items() if k != "AMENT_PREFIX_PATH"}
    code = ("import sys; from ament_index_python.packages import get_package_prefix, "
            "get_package_share_directory; print(get_package_prefix(sys.argv[1])); "
            "print(get_package_share_directory(sys.argv[1]))")
    out = children.run([sys.executable, "-c", code, package], env=env, capture_output=True,
                         text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    prefix, share = out.stdout.split()
    assert Path(prefix).resolve() == PREFIX
    assert (PREFIX / "share/ament_index/resource_index/packages" / package).is_file()
    assert Path(share, "package.xml").is_file()


@pytest.mark.parametrize("package_xml", ["package.xml", "msg_defs/orthoglide_msgs/package.xml"])
def test_package_xml_is_valid_format_3(package_xml: str) -> None:
    from catkin_pkg.package import parse_package

    package = parse_package(ROOT / package_xml)
    package.validate()
    assert package.package_format == 3
    assert package.name == {"package.xml": "orthoglide_ident"}.get(package_xml, "orthoglide_msgs")


def test_installed_package_xml_is_the_sources() -> None:
    installed = PREFIX / "share/orthoglide_ident/package.xml"
    assert installed.read_bytes() == (ROOT / "package.xml").read_bytes(), \
        "share/orthoglide_ident/package.xml is stale: run `make setup`"
    assert ET.parse(installed).getroot().findtext("export/build_type") == "ament_python"


def _ros2_run_path(package: str, executable: str) -> Path:
    """What `ros2 run` executes: <prefix of package on AMENT_PREFIX_PATH>/lib/<package>/<exec>."""
    from ament_index_python.packages import get_package_prefix

    return Path(get_package_prefix(package)) / "lib" / package / executable


@pytest.mark.parametrize("executable", list(EXECUTABLES))
def test_ros2_run_launcher_starts_its_module(executable: str, ros_env: dict[str, str]) -> None:
    launcher = _ros2_run_path("orthoglide_ident", executable)
    assert launcher.is_file() and os.access(launcher, os.X_OK), (
        f"{launcher}: missing or not executable"
    )
    module = EXECUTABLES[executable]
    assert _module_exists(module), f"{module}: the module {executable!r} runs is missing"
    # Run as `ros2 run` does: the file itself, no venv activation, no sourced ROS.
    env = {k: v for k, v in ros_env.items() if k not in ("AMENT_PREFIX_PATH", "VIRTUAL_ENV")}
    env["PATH"] = "/usr/bin:/bin"
    out = children.run([str(launcher), "--help"], env=env, capture_output=True, text=True,
                         timeout=120)
    assert out.returncode == 0, f"{launcher} --help exited {out.returncode}:\n{out.stderr}"
    assert "usage" in out.stdout.lower(), f"{launcher} --help printed no usage:\n{out.stdout}"
    assert executable in out.stdout, (
        f"usage should name the executable {executable!r}:\n{out.stdout}"
    )


def test_console_script_orthoglide_ident() -> None:
    script = PREFIX / "bin" / "orthoglide-ident"
    assert script.is_file(), "orthoglide-ident console script not installed: run `make setup`"
    out = children.run([str(script), "--help"], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert "identify" in out.stdout


def test_make_setup_is_up_to_date() -> None:
    """A second `make setup` has nothing to rebuild (make -q: exit 0 = up to date)."""
    out = children.run(["make", "-q", "-C", str(ROOT), "VENV=" + str(PREFIX), "setup-stamps"],
                         capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, (
        "make setup would rebuild something: inputs newer than the venv's stamps (run `make setup`)"
    )


def test_launch_file_lists_the_node_set_with_installed_configs():
    """launch/orthoglide.launch.py loads as plain Python (launch_ros is not on PyPI here); its
    nodes are the four executables, each with a YAML file installed under share/.../config."""
    import importlib.util

    from orthoglide_ident._install_ament import EXECUTABLES, data_files

    path = ROOT / "launch" / "orthoglide.launch.py"
    spec = importlib.util.spec_from_file_location("orthoglide_launch", path)
    launch = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(launch)
    assert [n["executable"] for n in launch.NODES] == [
        "driver",
        "recorder",
        "identification",
        "ctc",
        "viewer",
    ]
    assert all(
        n["executable"] in EXECUTABLES and n["name"].startswith("orthoglide_") for n in launch.NODES
    )
    # a node that cannot go on exits 1 and is started again (respawn:=true), not the simulated robot
    # nor the viewer (a view, started again by hand)
    assert [n["respawn"] for n in launch.NODES] == [False, True, True, True, False]
    assert "respawn" in launch.ARGUMENTS
    installed = dict(data_files())
    assert "launch/orthoglide.launch.py" in installed["share/orthoglide_ident/launch"]
    for n in launch.NODES:
        assert f"config/{n['config']}" in installed["share/orthoglide_ident/config"]
        assert (ROOT / "config" / n["config"]).is_file()
        assert set(n["arguments"]) <= set(launch.ARGUMENTS)
        assert n["when"] is None or n["when"] in launch.ARGUMENTS
    assert launch.ARGUMENTS["viewer"][0] == "false"  # the viewer only when asked for
    assert (Path(sys.prefix) / "share/orthoglide_ident/launch/orthoglide.launch.py").is_file()
    try:
        import launch_ros  # noqa: F401  (only with the real ros2 CLI installed by hand)
    except ImportError:
        return
    description = launch.generate_launch_description()
    assert len(description.entities) == len(launch.ARGUMENTS) + 1


def test_config_files_are_the_nodes_parameter_files():
    """Every key of config/<node>.yaml is a parameter the node declares (so the file really sets
    it)."""
    import yaml

    from orthoglide_ident.nodes import ctc, identification, recorder, viewer
    from orthoglide_sim.nodes import driver as driver_node

    for module, name in (
        (driver_node, "driver"),
        (recorder, "recorder"),
        (identification, "identification"),
        (ctc, "ctc"),
        (viewer, "viewer"),
    ):
        data = yaml.safe_load((ROOT / "config" / f"{name}.yaml").read_text())
        keys = set(data["/**"]["ros__parameters"])
        declared = {p.name for p in module.PARAMETERS}
        assert keys <= declared, (name, keys - declared)


def test_foxglove_layout_is_installed():
    from orthoglide_ident._install_ament import FOXGLOVE_LAYOUT

    installed = PREFIX / "share/orthoglide_ident/foxglove" / Path(FOXGLOVE_LAYOUT).name
    assert installed.read_bytes() == (ROOT / FOXGLOVE_LAYOUT).read_bytes(), (
        "stale layout: run `make setup`"
    )
