"""The ROS 2 layout of orthoglide_ident, and its installation into a prefix.

`ros2 run orthoglide_ident <exec>` finds `<prefix>/lib/orthoglide_ident/<exec>` in a prefix on
AMENT_PREFIX_PATH that holds `share/ament_index/resource_index/packages/orthoglide_ident`. This
module lists those files once:

- ``setup.py`` hands :func:`data_files` to setuptools, so a regular ``pip install .`` or a colcon
  build on a full ROS 2 install puts them in place;
- an editable install (``pip install -e .``, what ``make setup`` does) skips data_files, so
  ``make setup`` then runs ``python -m orthoglide_ident._install_ament``, which copies the same
  files into ``sys.prefix`` (the venv) and adds a ``.pth`` that defaults AMENT_PREFIX_PATH to the
  venv, so ament lookups work without sourcing anything.

Standard library only: setup.py loads this file before anything is installed.
"""
from __future__ import annotations

import argparse
import os
import shutil
import sys
import sysconfig
from pathlib import Path

PACKAGE = "orthoglide_ident"
ROOT = Path(__file__).resolve().parent.parent
"""The source tree (repository root) this file belongs to."""

EXECUTABLES: dict[str, str] = {
    "driver": "orthoglide_sim.nodes.driver",
    "recorder": "orthoglide_ident.nodes.recorder",
    "identification": "orthoglide_ident.nodes.identification",
    "ctc": "orthoglide_ident.nodes.ctc",
    "viewer": "orthoglide_ident.nodes.viewer",
    "excitation": "orthoglide_ident.nodes.excitation",
}
"""`ros2 run orthoglide_ident <exec>` -> module whose ``main()`` it runs
(resource/launchers/<exec>)."""

CONFIG_FILES = (
    "driver",
    "recorder",
    "identification",
    "ctc",
    "viewer",
    "plant",
    "ros2_control",
    "arm_plant",
)
"""config/<name>.yaml, installed under share/orthoglide_ident/config (the launch file loads
them)."""

LAUNCH_FILES = ("orthoglide", "ros2_control")
"""launch/<name>.launch.py, installed under share/orthoglide_ident/launch (ros2 launch finds
them)."""

FOXGLOVE_LAYOUT = "resource/orthoglide_layout.json"
"""The Foxglove layout of the viewer's (and a report MCAP's) channels:
share/orthoglide_ident/foxglove."""

PTH_FILE = "orthoglide_ident_ament_prefix.pth"


def data_files() -> list[tuple[str, list[str]]]:
    """(install directory relative to the prefix, [source files relative to ROOT]) pairs."""
    return [
        ("share/ament_index/resource_index/packages", [f"resource/{PACKAGE}"]),
        (f"share/{PACKAGE}", ["package.xml"]),
        (f"lib/{PACKAGE}", [f"resource/launchers/{name}" for name in EXECUTABLES]),
        (f"share/{PACKAGE}/launch", [f"launch/{name}.launch.py" for name in LAUNCH_FILES]),
        (f"share/{PACKAGE}/config", [f"config/{name}.yaml" for name in CONFIG_FILES]),
        (f"share/{PACKAGE}/foxglove", [FOXGLOVE_LAYOUT]),
    ]


def install(prefix: Path, site_packages: Path | None = None) -> list[Path]:
    """Copy the ROS 2 layout into ``prefix`` and the AMENT_PREFIX_PATH ``.pth`` into
    ``site_packages`` (skipped when None). Returns the installed paths. Idempotent."""
    installed: list[Path] = []
    for directory, sources in data_files():
        target_dir = prefix / directory
        target_dir.mkdir(parents=True, exist_ok=True)
        for source in sources:
            target = target_dir / Path(source).name
            shutil.copy2(ROOT / source, target)  # keeps the launchers' executable bit
            installed.append(target)
    if site_packages is not None:
        target = site_packages / PTH_FILE
        shutil.copy2(ROOT / "resource" / PTH_FILE, target)
        installed.append(target)
    return installed


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m orthoglide_ident._install_ament",
        description="Install the ament index entry, package.xml and `ros2 run` launchers of "
        "orthoglide_ident into a prefix (default: this interpreter's, i.e. the venv).",
    )
    parser.add_argument("--prefix", type=Path, default=Path(sys.prefix),
                        help="install prefix (default: %(default)s)")
    args = parser.parse_args(argv)
    prefix = args.prefix.resolve()
    site_packages = (
        Path(sysconfig.get_paths()["purelib"]) if prefix == Path(sys.prefix).resolve() else None
    )
    for path in install(prefix, site_packages):
        print(f"installed {os.path.relpath(path, prefix)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
