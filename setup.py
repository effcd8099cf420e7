"""The part of the build that pyproject.toml cannot say: the ROS 2 layout as data_files.

Metadata, packages and the console script are in pyproject.toml. The ament index marker,
share/orthoglide_ident/package.xml and the `ros2 run` launchers in lib/orthoglide_ident/ are
listed once, in orthoglide_ident/_install_ament.py, and installed here by a regular
`pip install .` or a colcon build. Editable installs skip data_files; `make setup` copies them.
"""
import runpy
import sys
from pathlib import Path

from setuptools import setup

layout = runpy.run_path(str(Path(__file__).parent / "orthoglide_ident" / "_install_ament.py"))
data_files = layout["data_files"]()
# Defaults AMENT_PREFIX_PATH to the venv when installed into one (inert on a colcon install,
# where this directory is on PYTHONPATH, not a site directory).
data_files.append((f"lib/python{sys.version_info.major}.{sys.version_info.minor}/site-packages",
                   [f"resource/{layout['PTH_FILE']}"]))

setup(data_files=data_files)
