"""The house rules of docs/architecture.md "Layout", read from the code's own imports and calls.

- the Orthoglide is one robot package: no product module outside ``model/orthoglide/`` imports it,
  but the robot registry (``model/robots.py``);
- no ``isinstance`` on a robot class in identify/, view/ or nodes/: what differs between robots is
  a ``RobotModel`` method (``forward_model``, ``identified_urdf``, ``joint_labels``, ``gravity``);
- the robot is passed, never defaulted: ``load_robot`` is called at the edges only (the CLI, the
  nodes' ``robot`` parameter) and the registry;
- no module imports a private name (``_x``) of another package.
Imports inside functions count as much as those at the top.
"""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PRODUCT = ROOT / "orthoglide_ident"
ORTHOGLIDE_PACKAGE = "orthoglide_ident.model.orthoglide"
REGISTRY = "orthoglide_ident/model/robots.py"
EDGES = ("orthoglide_ident/cli.py", "orthoglide_ident/excite/run_cli.py",  # the excite run command's handler
         "orthoglide_ident/nodes/")  # where "which robot" is resolved


def _modules(*roots: Path) -> list[Path]:
    return sorted(p for r in roots for p in r.rglob("*.py") if "__pycache__" not in p.parts)


def _rel(path: Path) -> str:
    return path.relative_to(ROOT).as_posix()


def _package(path: Path) -> str:
    """The dotted package a module belongs to (its folder)."""
    return ".".join(path.relative_to(ROOT).parent.parts)


def _imports(path: Path) -> list[tuple[str, str | None, int]]:
    """(module, name or None, line) of every import in the file, top level or not, resolved
    to absolute module names."""
    out = []
    pkg = _package(path)
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            out += [(a.name, None, node.lineno) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            mod = node.module or ""
            if node.level:
                base = pkg.split(".")[:len(pkg.split(".")) - node.level + 1]
                mod = ".".join(base + ([mod] if mod else []))
            out += [(mod, a.name, node.lineno) for a in node.names]
    return out


def _imports_orthoglide(module: str, name: str | None) -> bool:
    full = f"{module}.{name}" if name else module
    return full == ORTHOGLIDE_PACKAGE or full.startswith(ORTHOGLIDE_PACKAGE + ".") or \
        module.startswith(ORTHOGLIDE_PACKAGE)


def test_only_the_robot_registry_imports_the_orthoglide_package():
    inside = PRODUCT / "model" / "orthoglide"
    offenders = [f"{_rel(p)}:{line} imports {mod}{'.' + name if name else ''}"
                 for p in _modules(PRODUCT) if inside not in p.parents and _rel(p) != REGISTRY
                 for mod, name, line in _imports(p) if _imports_orthoglide(mod, name)]
    assert not offenders, "\n".join(offenders)
    # and the registry does: the rule is not passed by an empty tree
    assert any(_imports_orthoglide(m, n) for m, n, _ in _imports(ROOT / REGISTRY))


def _robot_classes() -> set[str]:
    """Names of the classes that implement RobotModel anywhere in the product."""
    names = {"RobotModel"}
    for p in _modules(PRODUCT):
        for node in ast.walk(ast.parse(p.read_text())):
            if isinstance(node, ast.ClassDef) and any(
                    getattr(b, "id", getattr(b, "attr", None)) == "RobotModel" for b in node.bases):
                names.add(node.name)
    return names


@pytest.mark.parametrize("room", ["identify", "view", "nodes"])
def test_no_isinstance_on_a_robot_class(room):
    robots = _robot_classes()
    assert {"BaseModel", "PinocchioRobot"} <= robots
    offenders = []
    for p in _modules(PRODUCT / room):
        for node in ast.walk(ast.parse(p.read_text())):
            if isinstance(node, ast.Call) and getattr(node.func, "id", None) == "isinstance":
                kinds = node.args[1]
                elts = kinds.elts if isinstance(kinds, ast.Tuple) else [kinds]
                named = {getattr(e, "id", getattr(e, "attr", None)) for e in elts}
                if named & robots:
                    offenders.append(f"{_rel(p)}:{node.lineno}: isinstance(..., {named & robots})")
    assert not offenders, "\n".join(offenders)


def test_the_robot_is_resolved_at_the_edges_only():
    offenders = []
    for p in _modules(PRODUCT):
        rel = _rel(p)
        for node in ast.walk(ast.parse(p.read_text())):
            if isinstance(node, ast.Call) and getattr(node.func, "id", None) == "load_robot":
                if rel != REGISTRY and not rel.startswith(EDGES):
                    offenders.append(f"{rel}:{node.lineno}: load_robot below the edges")
                if node.args and isinstance(node.args[0], ast.Constant) and node.args[0].value is None:
                    offenders.append(f"{rel}:{node.lineno}: load_robot(None): say which robot")
    assert not offenders, "\n".join(offenders)


def _owner_package(dotted: list[str]) -> str:
    """The package that owns the first private part of ``dotted`` (a module's: its folder)."""
    k = next(i for i, x in enumerate(dotted) if x.startswith("_") and not x.startswith("__"))
    owner = dotted[:k]
    if (ROOT.joinpath(*owner).with_suffix(".py")).exists():  # a module's private name
        owner = owner[:-1]
    return ".".join(owner)


def test_no_private_name_is_imported_across_packages():
    offenders = []
    for p in _modules(PRODUCT, ROOT / "orthoglide_sim"):
        for mod, name, line in _imports(p):
            dotted = mod.split(".") + ([name] if name else [])
            if not dotted[0] in ("orthoglide_ident", "orthoglide_sim") or not any(
                    x.startswith("_") and not x.startswith("__") for x in dotted):
                continue
            if _owner_package(dotted) != _package(p):
                offenders.append(f"{_rel(p)}:{line} imports {'.'.join(dotted)}")
    assert not offenders, "\n".join(offenders)


def test_offline_and_live_share_rooms_but_not_orchestration():
    """pipeline.py (bags) and live.py / live_recording.py (topics) both use observation, solving
    and diagnostics; neither imports the other."""
    ident = PRODUCT / "identify"
    offline = {m for m, _, _ in _imports(ident / "pipeline.py")}
    live = {m for f in ("live.py", "live_recording.py") for m, _, _ in _imports(ident / f)}
    assert not {m for m in offline if m.startswith("orthoglide_ident.identify.live.session")}
    assert "orthoglide_ident.identify.pipeline" not in live
    shared = {"orthoglide_ident.identify.solve.methods", "orthoglide_ident.identify.diagnostics"}
    assert shared <= offline and shared <= live
    # the observation: observe.py (offline) and live_recording.py run the same SegmentStream
    assert "orthoglide_ident.identify.observe.stream" in {m for m, _, _ in _imports(ident / "observe.py")}
    assert "orthoglide_ident.identify.observe.stream" in live
