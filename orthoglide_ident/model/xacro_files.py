"""xacro robot descriptions expanded in-process: ``--robot FILE.xacro``, a robot file's
``description: FILE.xacro``.

Vendors publish ``*.urdf.xacro`` (nested ``$(find pkg)`` includes, ``xacro:arg`` such as a robot
type, parameters read through ``xacro.load_yaml``); this expands one with the ``xacro`` package
(pinned in requirements.txt) into a URDF kept in the description cache, so that the rest of the
product reads a plain URDF. Packages (``$(find pkg)``, ``package://pkg/...``) are looked for in
the ``--package-dir`` folders, then ``ROS_PACKAGE_PATH``, then the ament index
(``AMENT_PREFIX_PATH``); mesh references are rewritten to the absolute paths found, so the
expanded file stands on its own. A missing package, file or argument, and an argument the file
does not declare (a typo would silently give the default robot), is a ConfigError naming it.
"""
from __future__ import annotations

import contextlib
import hashlib
import io
import os
import re
import threading
import xml.etree.ElementTree as ET
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path

from orthoglide_ident.errors import ConfigError

XACRO_SUFFIX = ".xacro"
_LOCK = threading.Lock()  # xacro keeps its state (file stack, arguments) in module globals
_PACKAGE_URI = "package://"


def is_xacro(path: str | Path) -> bool:
    return str(path).lower().endswith(XACRO_SUFFIX)


def parse_xacro_args(items: Sequence[str], what: str = "--xacro-arg") -> dict[str, str]:
    """``NAME:=VALUE`` items (xacro's own command-line form) as a mapping."""
    out = {}
    for item in items:
        name, sep, value = str(item).partition(":=")
        if not sep or not re.fullmatch(r"[A-Za-z_][\w.-]*", name.strip()):
            raise ConfigError(f"{what} {item!r}: expected NAME:=VALUE (e.g. ur_type:=ur10e)")
        out[name.strip()] = value
    return out


class PackageNotFound(ConfigError):
    """A ``$(find pkg)`` or ``package://pkg`` no folder holds."""


def _ament_prefixes() -> list[str]:
    return [p for p in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]


def search_places(package_dirs: Sequence[str | Path]) -> list[str]:
    """Where packages are looked for, in order, as said in the messages."""
    places = [f"--package-dir {d}" for d in package_dirs]
    places += [f"ROS_PACKAGE_PATH {d}" for d in _ros_package_path()]
    places += [f"ament index {p}" for p in _ament_prefixes()]
    return places or ["no --package-dir, ROS_PACKAGE_PATH or AMENT_PREFIX_PATH"]


def _ros_package_path() -> list[str]:
    return [d for d in os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep) if d]


def find_package(name: str, package_dirs: Sequence[str | Path] = ()) -> Path:
    """The folder of package ``name``: a searched folder that is the package (its name) or holds
    it (``DIR/name``, ``DIR/*/name``, a workspace's ``src``), else the ament index's share."""
    for d in [Path(p).expanduser() for p in [*package_dirs, *_ros_package_path()]]:
        if d.name == name and d.is_dir():
            return d.resolve()
        for cand in [d / name, *sorted(d.glob(f"*/{name}"))]:
            if cand.is_dir():
                return cand.resolve()
    for prefix in _ament_prefixes():  # ament_index_python's own rule, without importing ROS
        if (Path(prefix) / "share/ament_index/resource_index/packages" / name).is_file():
            return Path(prefix) / "share" / name
    raise PackageNotFound(f"package {name!r} not found (searched: "
                          f"{'; '.join(search_places(package_dirs))}): give --package-dir DIR, "
                          "the folder holding it")


def _one_line(text: str) -> str:
    return " ".join(str(text).split())


def _reason(exc: BaseException) -> str:
    """The first cause in xacro's chain of wrapped exceptions that says what is missing."""
    seen = exc
    while seen is not None:
        if isinstance(seen, PackageNotFound):
            return str(seen)
        if type(seen).__name__ == "ArgException":
            return (f"xacro argument {seen.args[0]!r} is not given and has no default: give "
                    f"--xacro-arg {seen.args[0]}:=VALUE or xacro_args: {{{seen.args[0]}: "
                    "VALUE} in the robot file")
        if isinstance(seen, FileNotFoundError):
            return f"no such file {seen.filename}"
        seen = getattr(seen, "exc", None) or seen.__cause__ or seen.__context__
    text = _one_line(exc)
    match = re.search(r'filename spec "(.*)" matched no files|No such file or directory: (.*)',
                      text)
    if match or "No such file" in text:
        return f"no such file {(match and (match.group(1) or match.group(2))) or text}"
    return text


class _DeclaredArgs(dict):
    """The given arguments; records the names the files declare (``xacro:arg`` asks
    ``name in args`` before setting its default)."""

    def __init__(self, given: Mapping[str, str]):
        super().__init__(given)
        self.declared: set[str] = set()

    def __contains__(self, name: object) -> bool:
        self.declared.add(str(name))
        return super().__contains__(name)


@contextlib.contextmanager
def _xacro_finding(package_dirs: Sequence[str | Path]) -> Iterator[object]:
    """The xacro module with ``$(find pkg)`` answered by :func:`find_package`, quiet."""
    import xacro
    from xacro import substitution_args

    with _LOCK:
        saved = substitution_args._eval_find
        substitution_args._eval_find = lambda pkg: str(find_package(pkg, package_dirs))
        try:
            with contextlib.redirect_stderr(io.StringIO()):  # its warnings: deprecations
                yield xacro
        finally:
            substitution_args._eval_find = saved


def expand(path: Path, args: Mapping[str, str] | None = None,
           package_dirs: Sequence[str | Path] = ()) -> str:
    """The URDF text of xacro file ``path`` with ``args``; ConfigError with a one-line reason
    naming the file at fault (the included file for a failure inside an include)."""
    if not path.is_file():
        raise ConfigError(f"robot description {path}: no such file")
    given = _DeclaredArgs({str(k): str(v) for k, v in (args or {}).items()})
    with _xacro_finding(package_dirs) as xacro:
        try:
            doc = xacro.process_file(str(path), mappings=given)
        except Exception as exc:  # xacro raises anything its expressions raise
            where = next((f for f in reversed(xacro.filestack or []) if f), str(path))
            raise ConfigError(f"robot description {path}: xacro: {_reason(exc)}"
                              + (f" (in {where})" if str(where) != str(path) else "")) from None
        text = doc.toxml()
    unused = sorted(set(given) - given.declared)
    if unused:
        raise ConfigError(f"robot description {path}: xacro argument(s) {unused} are not "
                          f"declared by it (its arguments: {', '.join(sorted(given.declared))})")
    return with_absolute_meshes(text, path, package_dirs)


def with_absolute_meshes(urdf: str, source: Path, package_dirs: Sequence[str | Path]) -> str:
    """Mesh references (``package://``, relative) as absolute paths where the files are found:
    the expanded URDF lives in the cache, away from its package."""
    root = ET.fromstring(urdf)
    for mesh in root.iter("mesh"):
        name = mesh.get("filename", "")
        if name.startswith(_PACKAGE_URI):
            pkg, _, rel = name[len(_PACKAGE_URI):].partition("/")
            try:
                found = find_package(pkg, package_dirs) / rel
            except PackageNotFound:
                continue  # needed only by the collision check, which says so
        elif name and not name.startswith("file://") and not Path(name).is_absolute():
            found = source.parent / name
        else:
            continue
        if found.is_file():
            mesh.set("filename", str(found.resolve()))
    return ET.tostring(root, encoding="unicode")


def description_cache() -> Path:
    """Where robot descriptions made or received as text (an expanded xacro, the
    ``robot_description`` topic's URDF) are kept as files ($XDG_CACHE_HOME/orthoglide_ident)."""
    root = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(root) / "orthoglide_ident" / "robot_description"


def expanded_file(path: Path, args: Mapping[str, str] | None = None,
                  package_dirs: Sequence[str | Path] = (), cache_dir: Path | None = None) -> Path:
    """The expanded URDF of ``path`` as a file ``<cache>/<name>-<sha256>.urdf`` (written once,
    whole or not at all): what the URDF readers (Pinocchio, the mimic and transmission readers,
    the collision model) open."""
    text = expand(path, args, package_dirs)
    folder = cache_dir or description_cache()
    stem = path.name[:-len(XACRO_SUFFIX)].removesuffix(".urdf")
    out = folder / f"{stem}-{hashlib.sha256(text.encode()).hexdigest()[:16]}.urdf"
    if not out.exists():
        try:
            folder.mkdir(parents=True, exist_ok=True)
            tmp = out.with_suffix(f".{os.getpid()}.tmp")
            tmp.write_text(text)
            tmp.replace(out)
        except OSError as exc:
            raise ConfigError(f"cannot keep the expanded {path.name} in {folder}: "
                              f"{exc.strerror}") from None
    return out
