"""The house rules of docs/design/architecture.md "Layout", read from the code's own imports and
calls.

- the Orthoglide is one robot package: no product module outside ``model/orthoglide/`` imports it,
  but the robot registry (``model/registry.py``);
- no ``isinstance`` on a robot class in identify/, view/ or nodes/: what differs between robots is
  a ``RobotModel`` method (``forward_model``, ``identified_urdf``, ``joint_labels``, ``gravity``);
- the robot is passed, never defaulted: ``load_robot`` is called at the edges only (the CLI, the
  nodes' ``robot`` parameter) and the registry;
- no module imports a private name (``_x``) of another package;
- the product's rooms stand in layers (``LAYERS``, low to high): no import reaches up a layer, but
  the few listed in ``KNOWN_UPWARD`` with their reason (the list only shrinks: a listed import that
  is gone fails too);
- no import goes round a circle, in the product or the simulator, between modules nor between
  the simulator's rooms; the simulator's rooms stand in layers too (``SIM_LAYERS``);
- the product never imports the simulator.
Imports inside functions count as much as those at the top.
"""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PRODUCT = ROOT / "orthoglide_ident"
ORTHOGLIDE_PACKAGE = "orthoglide_ident.model.orthoglide"
REGISTRY = "orthoglide_ident/model/registry.py"
# the excite run command's handler
EDGES = ("orthoglide_ident/cli.py", "orthoglide_ident/excite/run_command.py",
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


ROBOT_NAMES = {"robot", "model", "jm", "arm"}  # what the product calls a RobotModel


def test_the_robot_is_never_probed_for_an_attribute():
    """RobotModel declares every attribute the product reads (None or () where a robot has
    none): a getattr(robot, "x", default) would hide a robot that lacks it."""
    offenders = []
    for p in _modules(PRODUCT):
        for node in ast.walk(ast.parse(p.read_text())):
            if (isinstance(node, ast.Call) and getattr(node.func, "id", None) in (
                    "getattr", "hasattr") and node.args
                    and isinstance(node.args[0], ast.Name) and node.args[0].id in ROBOT_NAMES):
                offenders.append(f"{_rel(p)}:{node.lineno}: {node.func.id}({node.args[0].id}, …)")
    assert not offenders, "\n".join(offenders)


def test_the_robot_is_resolved_at_the_edges_only():
    offenders = []
    for p in _modules(PRODUCT):
        rel = _rel(p)
        for node in ast.walk(ast.parse(p.read_text())):
            if isinstance(node, ast.Call) and getattr(node.func, "id", None) == "load_robot":
                if rel != REGISTRY and not rel.startswith(EDGES):
                    offenders.append(f"{rel}:{node.lineno}: load_robot below the edges")
                if (
                    node.args
                    and isinstance(node.args[0], ast.Constant)
                    and node.args[0].value is None
                ):
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
            if dotted[0] not in ("orthoglide_ident", "orthoglide_sim") or not any(
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
    live = {m for f in ("live/session.py", "live/recording.py") for m, _, _ in _imports(ident / f)}
    assert not {m for m in offline if m.startswith("orthoglide_ident.identify.live")}
    assert "orthoglide_ident.identify.pipeline" not in live
    shared = {"orthoglide_ident.identify.solve.methods", "orthoglide_ident.identify.diagnostics"}
    assert shared <= offline and shared <= live
    # the observation: observe/rows.py (offline) and live/recording.py run the same SegmentStream
    rows = {m for m, _, _ in _imports(ident / "observe" / "rows.py")}
    assert "orthoglide_ident.identify.observe.stream" in rows
    assert "orthoglide_ident.identify.observe.stream" in live


# The product's rooms, low to high: a module may import its own layer and those below it. A room
# is a package or a module; the longest matching name decides (``identify.observe.rows`` sits
# above ``identify.columns``, the rest of ``identify.observe`` below it).
LAYERS = [
    ["orthoglide_ident.__init__", "orthoglide_ident.errors", "orthoglide_ident.ticks",
     "orthoglide_ident.yaml_files", "orthoglide_ident.flags", "orthoglide_ident.progress"],
    ["orthoglide_ident.model"],
    ["orthoglide_ident.bags", "orthoglide_ident.results"],
    ["orthoglide_ident.identify.options"],
    ["orthoglide_ident.identify.records"],
    ["orthoglide_ident.identify.observe"],
    ["orthoglide_ident.identify.columns"],
    ["orthoglide_ident.identify.observe.rows"],  # the rows of [W | extra columns, v_tau]
    ["orthoglide_ident.identify.consistency"],
    ["orthoglide_ident.identify.solve"],
    ["orthoglide_ident.identify.validate", "orthoglide_ident.identify.diagnostics"],
    ["orthoglide_ident.identify.pipeline"],
    ["orthoglide_ident.identify.live"],
    ["orthoglide_ident.identify.__init__"],  # the identify face
    ["orthoglide_ident.report", "orthoglide_ident.control", "orthoglide_ident.excite",
     "orthoglide_ident.feedforward_schedule", "orthoglide_ident.import_command",
     "orthoglide_ident.ros", "orthoglide_ident.ros_client"],
    ["orthoglide_ident.view"],
    ["orthoglide_ident.nodes", "orthoglide_ident.cli", "orthoglide_ident._install_ament"],
]
# Imports that still reach up a layer, each with why and what removes it: none left (the drive
# terms' fit moved to solve/drive_fit.py, issue 44).
KNOWN_UPWARD: set[tuple[str, str]] = set()


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    return ".".join(parts)


def _import_graph(*roots: Path) -> dict[str, set[str]]:
    """Module -> the project modules it imports (``from pkg import module`` counts as the module;
    a package's ``__init__`` is the package's face)."""
    paths = {_module_name(p): p for p in _modules(*roots)}
    names = set(paths) | {m[: -len(".__init__")] for m in paths if m.endswith(".__init__")}

    def resolve(name: str) -> str | None:
        if name in paths:
            return name
        return name + ".__init__" if name + ".__init__" in paths else None

    graph: dict[str, set[str]] = {}
    for mod, p in paths.items():
        targets = set()
        for imported, name, _ in _imports(p):
            full = f"{imported}.{name}" if name else imported
            target = resolve(full) if full in names else resolve(imported)
            if target and target != mod:
                targets.add(target)
        graph[mod] = targets
    return graph


def _layer(module: str, layers: list[list[str]] = LAYERS) -> int:
    best, best_len = -1, -1
    for i, rooms in enumerate(layers):
        for room in rooms:
            hit = module == room or module.startswith(room + ".")
            if hit and len(room) > best_len:
                best, best_len = i, len(room)
    assert best >= 0, f"{module} is in no layer of LAYERS: give it one"
    return best


def test_no_import_reaches_up_a_layer():
    graph = _import_graph(PRODUCT)
    upward = {(a, b) for a, targets in graph.items() for b in targets if _layer(b) > _layer(a)}
    new = sorted(upward - KNOWN_UPWARD)
    assert not new, "imports that reach up a layer:\n" + "\n".join(f"{a} -> {b}" for a, b in new)
    gone = sorted(KNOWN_UPWARD - upward)
    assert not gone, f"no longer there, strike them from KNOWN_UPWARD: {gone}"


def _circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan, iterative)."""
    index, low, on, stack, out, counter = {}, {}, set(), [], [], [0]
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = counter[0]
        counter[0] += 1
        stack.append(root)
        on.add(root)
        while work:
            v, it = work[-1]
            w = next(it, None)
            if w is None:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[v])
                if low[v] == index[v]:
                    comp = []
                    while True:
                        x = stack.pop()
                        on.discard(x)
                        comp.append(x)
                        if x == v:
                            break
                    if len(comp) > 1:
                        out.append(sorted(comp))
            elif w not in index:
                index[w] = low[w] = counter[0]
                counter[0] += 1
                stack.append(w)
                on.add(w)
                work.append((w, iter(sorted(graph.get(w, ())))))
            elif w in on:
                low[v] = min(low[v], index[w])
    return out


def test_circles_are_found():
    """The circle finder itself, on a graph with one circle and a tail."""
    assert _circles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert _circles({"a": {"b"}, "b": set()}) == []


@pytest.mark.parametrize("package", ["orthoglide_ident", "orthoglide_sim"])
def test_no_import_goes_round_a_circle(package):
    circles = _circles(_import_graph(ROOT / package))
    assert not circles, "\n".join(" -> ".join(c) for c in circles)


def test_the_product_never_imports_the_simulator():
    offenders = [f"{_rel(p)}:{line} imports {mod}" for p in _modules(PRODUCT)
                 for mod, _, line in _imports(p) if mod.split(".")[0] == "orthoglide_sim"]
    assert not offenders, "\n".join(offenders)


SIM_ROBOT_ROOMS = ("orthoglide", "arms", "chains", "coupled")
# The simulator's rooms, low to high (the same rule as LAYERS): a closed chain and the coupled
# wrists build on the serial arm; choosing between an arm and a chain by a robot's name sits
# above both (arm_or_chain/), so that arms/ never imports chains/ (issue 44).
SIM_LAYERS = [
    ["orthoglide_sim.__init__", "orthoglide_sim.common"],
    ["orthoglide_sim.orthoglide", "orthoglide_sim.arms"],
    ["orthoglide_sim.chains", "orthoglide_sim.coupled"],
    ["orthoglide_sim.arm_or_chain"],
    ["orthoglide_sim.nodes"],
    ["orthoglide_sim.demos"],
]


def _room(module: str) -> str:
    """A module's room: ``orthoglide_sim.arms.plant`` -> ``orthoglide_sim.arms``."""
    return ".".join(module.split(".")[:2])


def test_no_import_goes_round_a_circle_between_the_simulators_rooms():
    rooms: dict[str, set[str]] = {}
    for a, targets in _import_graph(ROOT / "orthoglide_sim").items():
        rooms.setdefault(_room(a), set()).update(_room(b) for b in targets if _room(b) != _room(a))
    assert {"orthoglide_sim.arms", "orthoglide_sim.chains"} <= set(rooms)
    circles = _circles(rooms)
    assert not circles, "\n".join(" -> ".join(c) for c in circles)


def test_no_import_reaches_up_a_layer_of_the_simulator():
    graph = _import_graph(ROOT / "orthoglide_sim")
    upward = sorted((a, b) for a, targets in graph.items() for b in targets
                    if _layer(b, SIM_LAYERS) > _layer(a, SIM_LAYERS))
    assert not upward, "imports that reach up a layer:\n" + "\n".join(f"{a} -> {b}"
                                                                       for a, b in upward)


def test_the_simulators_common_room_imports_no_robot_room():
    """orthoglide_sim/common/ (the closed loop, PID, quantiser, drive model every robot runs)
    sits below the robot rooms: a robot's session reaches it through a protocol."""
    offenders = [f"{_rel(p)}:{line} imports {mod}"
                 for p in _modules(ROOT / "orthoglide_sim" / "common")
                 for mod, _, line in _imports(p)
                 if mod.split(".")[:1] == ["orthoglide_sim"]
                 and mod.split(".")[1:2] and mod.split(".")[1] in SIM_ROBOT_ROOMS]
    assert not offenders, "\n".join(offenders)


# tests and bench go through the public faces (issue 44): a private bags module only from its
# own unit test (tests/bags/test_<module>.py), or where a test must reach inside, with the reason
PRIVATE_ON_PURPOSE = {
    "tests/bags/test_ros2_control_interop.py": "takes the embedded definitions away (an install "
    "without them) and counts the one-by-one decoder's messages",
}


def _face(package: Path) -> set[str]:
    """The names a package's ``__init__`` hands on (its ``__all__``), read, not imported."""
    for node in ast.parse((package / "__init__.py").read_text()).body:
        if isinstance(node, ast.Assign) and any(getattr(t, "id", "") == "__all__"
                                                for t in node.targets):
            return set(ast.literal_eval(node.value))
    return set()


def _private_bags_uses(path: Path) -> list[tuple[str, int]]:
    """(private bags module, line) of each import of one and each ``bags._x`` attribute."""
    out = []
    for mod, name, line in _imports(path):
        dotted = mod.split(".") + ([name] if name else [])
        if dotted[:2] == ["orthoglide_ident", "bags"] and dotted[2:3] and \
                dotted[2].startswith("_") and not dotted[2].startswith("__"):
            out.append((dotted[2], line))
    out += [(n.attr, n.lineno) for n in ast.walk(ast.parse(path.read_text()))
            if isinstance(n, ast.Attribute) and isinstance(n.value, ast.Name)
            and n.value.id == "bags" and n.attr.startswith("_") and not n.attr.startswith("__")]
    return out


def test_tests_and_bench_use_the_public_faces():
    identify_face = _face(PRODUCT / "identify")
    offenders = []
    for p in _modules(ROOT / "tests", ROOT / "bench"):
        rel = _rel(p)
        offenders += [f"{rel}:{line} uses bags.{mod}: use the bags face or its submodules"
                      for mod, line in _private_bags_uses(p)
                      if rel != f"tests/bags/test{mod}.py" and rel not in PRIVATE_ON_PURPOSE]
        offenders += [f"{rel}:{line} imports {name} from identify.pipeline: the identify face has "
                      "it" for mod, name, line in _imports(p)
                      if mod == "orthoglide_ident.identify.pipeline" and name in identify_face]
    assert not offenders, "\n".join(offenders)
