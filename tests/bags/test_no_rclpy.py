"""The numerical core and the CLI import and work where rclpy cannot be imported
(docs/design/architecture.md §2):
every module of bags, identify and model, plus control, results and cli, in a fresh interpreter
whose import system refuses rclpy; then the CLI runs."""

from __future__ import annotations

import sys

from orthoglide_ident.ros import processes as children  # children end with this process

CODE = r"""
import sys

class NoRclpy:
    def find_spec(self, name, path=None, target=None):
        if name == "rclpy" or name.startswith("rclpy."):
            raise ImportError(f"{name} is made unimportable by this test")
        return None

sys.meta_path.insert(0, NoRclpy())
try:
    import rclpy  # noqa: F401
except ImportError:
    pass
else:
    raise SystemExit("the finder did not hide rclpy")

import importlib
import pkgutil

import orthoglide_ident.bags
import orthoglide_ident.cli
import orthoglide_ident.control
import orthoglide_ident.identify
import orthoglide_ident.model
import orthoglide_ident.results
from orthoglide_ident.cli import main

for pkg in (orthoglide_ident.bags, orthoglide_ident.identify, orthoglide_ident.model):
    for info in pkgutil.walk_packages(pkg.__path__, pkg.__name__ + "."):
        importlib.import_module(info.name)  # every module of the package, not only __init__

assert not [m for m in sys.modules if m == "rclpy" or m.startswith("rclpy.")]
sys.exit(main(["model", "--base-parameters"]))
"""


def test_core_imports_without_rclpy() -> None:
    done = children.run([sys.executable, "-c", CODE], capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    assert "rclpy" not in done.stderr
