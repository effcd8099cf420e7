"""CSV logs to tagged bags: ``orthoglide-ident import CSV... --out BAG`` (DESIGN §9).

Public identification data sets and robot controllers' logs are CSV. A log becomes a bag in the
ros2_control layout (``/joint_states``: position, velocity, effort; header.stamp from the time
column), tagged as the recorder tags its bags, so that ``identify --robot R BAG`` reads it as it
reads a recorded one. The column map (:class:`ColumnMap`) comes from flags or a small YAML with
the same keys::

    time: t                 # the time column, in time_unit (s | ms | us | ns)
    time_unit: s
    joints: [j1, j2]        # or {j1: {position: q1, velocity: dq1, effort: tau1}, ...}
    position: "{joint}.q"   # a template, or one column per joint: "q1,q2"
    velocity: "{joint}.qd"  # optional ("" or absent: no recorded velocity, NaN in the bag)
    effort: "{joint}.tau"
    effort_unit: N·m        # A | mA (a current) or N·m | N (a torque / force)
    angle_unit: rad         # deg: positions and velocities in degrees (revolute joints only)
    prismatic: [j3]         # joints whose positions are lengths (m): never scaled by angle_unit
    condition: loaded       # and payload_mass, payload_frame, payload_com, payload_inertia

Columns are named by the header line (the first line that is not blank or a ``#`` comment);
a file whose first line holds only numbers has no header, and its columns are named 1, 2, ...
(as awk numbers them). Columns the map does not name may hold anything (a mode, a text).
Several files are joined into one bag, in the order given, as pieces of one log (a logger's
rotated files): their times must keep increasing; a jump between them is a gap the
identification splits at. Runs with different tags (loaded, unloaded) go into different bags.

Parsing is numpy's C reader (``np.loadtxt``) over the whole file; only when it fails is the
file scanned line by line, to name the line and column at fault in one line of text.
"""
from __future__ import annotations

import csv
import gzip
import lzma
import math
import re
import warnings
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from typing import IO, Any

import numpy as np

from orthoglide_ident.errors import ConfigError, DataError
from orthoglide_ident.flags import parse_vector
from orthoglide_ident.progress import ProgressLine, shown
from orthoglide_ident.yaml_files import load_yaml

TIME_UNITS = {"s": 10**9, "ms": 10**6, "us": 10**3, "ns": 1}  # ns per unit
ANGLE_UNITS = {"rad": 1.0, "deg": math.pi / 180.0}  # rad per unit (revolute joints only)
# effort unit -> (what the bag's effort then is, SI factor)
EFFORT_UNITS = {"A": ("A", 1.0), "mA": ("A", 1e-3), "N·m": ("torque", 1.0),
                "Nm": ("torque", 1.0), "N.m": ("torque", 1.0), "N": ("torque", 1.0)}
DELIMITERS = {",": ",", ";": ";", "tab": "\t", "\t": "\t", "space": None}
JOINT = "{joint}"  # the placeholder of a column template
_ROLES = ("position", "velocity", "effort")


@dataclass(frozen=True)
class ColumnMap:
    """Which columns hold what, in which unit, and the bag's tag. ``position``, ``velocity``
    and ``effort`` are each a template with ``{joint}`` or one column name per joint (a tuple);
    ``velocity`` "" means none was recorded. ``joints`` empty: every header column the position
    template matches, in header order."""

    joints: tuple[str, ...] = ()
    time: str = "t"
    time_unit: str = "s"
    position: str | tuple[str, ...] = "{joint}.q"
    velocity: str | tuple[str, ...] = ""
    effort: str | tuple[str, ...] = "{joint}.effort"
    effort_unit: str = ""
    angle_unit: str = "rad"
    prismatic: tuple[str, ...] = ()  # joints in m, m/s: angle_unit leaves them as they are
    delimiter: str = ""  # "" = from the header: the most frequent of , ; tab, else spaces
    condition: str = "unloaded"
    payload_mass: float = 0.0
    payload_frame: str | None = None
    payload_com: tuple[float, ...] | None = None
    payload_inertia: tuple[float, ...] | None = None
    current_sampling: str = "auto"  # held | sampled: tagged orthoglide.current_sampling; auto: not
    source: str = field(default="flags", compare=False)  # where the map came from, for errors

    @classmethod
    def from_mapping(cls, data: Mapping[str, Any], source: str) -> ColumnMap:
        """A map from a YAML's keys (the flags' names, ``-`` or ``_``); ConfigError on an
        unknown key or a value of the wrong kind."""
        if not isinstance(data, Mapping):
            raise ConfigError(f"{source}: a column map is a mapping of keys (time, joints, "
                              "position, effort, effort_unit, ...)")
        known = {f.name for f in fields(cls)} - {"source"}
        out: dict[str, Any] = {}
        for key, value in data.items():
            k = str(key).replace("-", "_")
            if k not in known:
                raise ConfigError(
                    f"{source}: unknown key {key!r}; known: {', '.join(sorted(known))}"
                )
            out[k] = value
        joints = out.get("joints")
        if isinstance(joints, Mapping):  # per joint: {name: {position: col, effort: col, ...}}
            out.update(_per_joint_columns(joints, source))
        return cls(source=source).with_values(**out)

    @classmethod
    def from_yaml(cls, path: str | Path) -> ColumnMap:
        return cls.from_mapping(load_yaml(path, "column map") or {}, str(path))

    def with_values(self, **values: Any) -> ColumnMap:
        """This map with the given keys replaced (None: left as it is), each checked."""
        v = {k: x for k, x in values.items() if x is not None}
        try:
            for k in ("joints", "prismatic"):
                if k in v:
                    v[k] = _names(v[k])
            for role in _ROLES:
                if role in v:
                    v[role] = _columns(v[role])
            for k, n in (("payload_com", 3), ("payload_inertia", 6)):
                if k in v:
                    v[k] = parse_vector(v[k], n, f"{self.source}: {k}")
            if "payload_mass" in v:
                v["payload_mass"] = float(v["payload_mass"])
            for k in ("time", "time_unit", "effort_unit", "angle_unit", "delimiter",
                      "condition", "payload_frame", "current_sampling"):
                if k in v:
                    v[k] = str(v[k])
        except (TypeError, ValueError) as exc:
            raise ConfigError(f"{self.source}: {exc}") from None
        out = replace(self, **v)
        out.check_units()
        return out

    def with_source(self, source: str) -> ColumnMap:
        """This map, its errors naming ``source`` (a YAML file, the flags)."""
        return replace(self, source=source)

    def check_units(self) -> None:
        """ConfigError naming the map's source for a unit or delimiter that is not known."""
        for what, unit, table in (("time_unit", self.time_unit, TIME_UNITS),
                                  ("angle_unit", self.angle_unit, ANGLE_UNITS),
                                  ("delimiter", self.delimiter, DELIMITERS)):
            if unit and unit not in table:
                raise ConfigError(f"{self.source}: unknown {what} {unit!r}; use one of "
                                  f"{', '.join(table)}")
        if self.current_sampling not in ("held", "sampled", "auto"):
            raise ConfigError(f"{self.source}: current_sampling {self.current_sampling!r}: use "
                              "held, sampled or auto")
        if self.effort_unit and self.effort_unit not in EFFORT_UNITS:
            raise ConfigError(f"{self.source}: unknown effort_unit {self.effort_unit!r}; use A or "
                              "mA (a current), N·m (Nm) or N (a torque or force)")

    def required(self) -> None:
        """ConfigError when what has no default is missing: the effort's unit."""
        if not self.effort_unit:
            raise ConfigError(f"{self.source}: say what the effort columns hold: effort_unit A or "
                              "mA (a current), N·m or N (a torque or force; the bag is tagged so "
                              "that identification divides it by the nominal gains)")


def _names(value: Any) -> tuple[str, ...]:
    items = value.split(",") if isinstance(value, str) else list(value)
    names = tuple(str(x).strip() for x in items if str(x).strip())
    if len(set(names)) != len(names):
        raise ValueError(f"joints {list(names)} name a joint twice")
    return names


def _columns(value: Any) -> str | tuple[str, ...]:
    """A template (a string holding {joint}) or one column per joint."""
    if isinstance(value, str) and (JOINT in value or not value.strip()):
        return value.strip()
    return _names(value) if isinstance(value, (str, list, tuple)) else (str(value),)


def _per_joint_columns(joints: Mapping[str, Any], source: str) -> dict[str, Any]:
    out: dict[str, Any] = {"joints": list(joints)}
    for role in _ROLES:
        cols = [(c or {}).get(role) if isinstance(c, Mapping) else None for c in joints.values()]
        if all(c is None for c in cols):
            continue
        if any(c is None for c in cols):
            missing = [j for j, c in zip(joints, cols) if c is None]
            raise ConfigError(f"{source}: joints {missing} have no {role} column (give one for "
                              "every joint or none)")
        out[role] = [str(c) for c in cols]
    return out


# -- reading one file ------------------------------------------------------------------------------
@dataclass
class CsvRecord:
    """One file's samples in SI units: ``stamps_ns (N,)`` int64, ``q``, ``qd`` (None: not
    recorded) and ``effort`` each ``(N, n)`` by ``joints`` (the file line of a row is found
    again on the error path only)."""

    path: Path
    joints: tuple[str, ...]
    stamps_ns: np.ndarray
    q: np.ndarray
    qd: np.ndarray | None
    effort: np.ndarray
    header_line: int  # the file line of the header (0: no header)


def _open(path: Path) -> IO[str]:
    """The file as text: plain, or compressed by its suffix (.gz, .xz); BOMs dropped."""
    opener = {".gz": gzip.open, ".xz": lzma.open}.get(path.suffix, open)
    return opener(path, "rt", encoding="utf-8-sig", newline="")  # type: ignore[operator]


def _raw_position(f: IO[str]):
    """A function giving how many bytes of the file on disk ``f`` has read (compressed files:
    of the compressed stream), or None where the opener does not tell."""
    buffer = getattr(f, "buffer", None)
    raw = getattr(buffer, "fileobj", None) or getattr(buffer, "_fp", None) or \
        getattr(buffer, "raw", None)
    return getattr(raw, "tell", None)


def _with_progress(f: IO[str], path: Path, every: int = 4096) -> Iterable[str]:
    """``f``'s lines; on a terminal a progress line by the bytes read (progress.py)."""
    position = _raw_position(f)
    if not shown() or position is None:
        return f

    def lines() -> Iterator[str]:
        size = max(1, path.stat().st_size)
        with ProgressLine(f"reading {path.name}", size / 1e6, "MB") as line:
            for k, text in enumerate(f):
                if k % every == 0:
                    line.update(position() / 1e6)
                yield text
    return lines()


def _is_data(line: str) -> bool:
    """The lines np.loadtxt reads: not blank once a # comment is cut off."""
    return bool(line.split("#", 1)[0].strip())


def _cells(line: str, delimiter: str | None) -> list[str]:
    """A line's cells as a CSV reader splits them (quotes respected), stripped."""
    text = line.split("#", 1)[0].strip()
    cells = next(csv.reader([text], delimiter=delimiter)) if delimiter else text.split()
    return [c.strip() for c in cells]


def _header(path: Path, delimiter: str) -> tuple[list[str], int, str | None]:
    """(column names, the header's file line or 0, the delimiter); DataError on an empty file."""
    try:
        with _open(path) as f:
            for number, line in enumerate(f, 1):  # noqa: B007  (the line number of a refusal)
                if _is_data(line):
                    break
            else:
                raise DataError(f"{path}: empty file (no header, no rows)")
    except (OSError, EOFError, lzma.LZMAError, UnicodeDecodeError) as exc:
        raise DataError(
            f"{path}: cannot read it ({getattr(exc, 'strerror', None) or exc})"
        ) from None
    if delimiter:
        delim = DELIMITERS[delimiter]
    else:
        counts = {d: line.count(d) for d in (",", ";", "\t")}
        best = max(counts, key=counts.__getitem__)
        delim = best if counts[best] else None
    cells = _cells(line, delim)
    if all(_is_number(c) for c in cells):  # no header: columns 1, 2, ...
        return [str(k) for k in range(1, len(cells) + 1)], 0, delim
    return cells, number, delim


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _resolve(cmap: ColumnMap, header: list[str], where: str) -> tuple[tuple[str, ...], dict]:
    """(joints, {role: [column index per joint]} and "time": [index]); ConfigError naming the
    column that is missing."""
    joints = cmap.joints or _joints_from_header(cmap.position, header, where)
    index = {name: k for k, name in enumerate(header)}

    def find(col: str, what: str) -> int:
        if col not in index:
            shown = ", ".join(header[:12]) + (", ..." if len(header) > 12 else "")
            raise ConfigError(f"{where}: no column {col!r} ({what}); the header has {shown}")
        return index[col]

    out = {"time": [find(cmap.time, "the time")]}
    for role in _ROLES:
        spec = _columns(getattr(cmap, role))
        if not spec and role != "velocity":
            raise ConfigError(f"{cmap.source}: give the {role} columns (a template with "
                              f"{JOINT} or one column per joint)")
        if not spec:
            continue
        cols = ([spec.replace(JOINT, j) for j in joints] if isinstance(spec, str) else list(spec))
        if len(cols) != len(joints):
            raise ConfigError(f"{cmap.source}: {len(cols)} {role} columns for {len(joints)} "
                              f"joints {list(joints)}")
        out[role] = [find(c, f"joint {j}'s {role}") for c, j in zip(cols, joints)]
    return joints, out


def _joints_from_header(template: str | tuple[str, ...], header: list[str], where: str
                        ) -> tuple[str, ...]:
    if not isinstance(template, str) or JOINT not in template:
        raise ConfigError(f"{where}: name the joints (--joints or the map's joints) when the "
                          "position columns are listed one by one")
    head, tail = template.split(JOINT, 1)
    pattern = re.compile(re.escape(head) + r"(.+)" + re.escape(tail) + r"$")
    joints = tuple(m.group(1) for m in map(pattern.match, header) if m)
    if not joints:
        raise ConfigError(f"{where}: no column matches the position template {template!r}; name "
                          "the joints and their columns (--joints, --position or a map)")
    return joints


def read_csv(path: str | Path, cmap: ColumnMap) -> CsvRecord:
    """One CSV file as SI arrays; DataError / ConfigError with the file and line at fault."""
    path = Path(path)
    header, header_line, delim = _header(path, cmap.delimiter)
    where = f"{path} line {header_line}" if header_line else f"{path} (no header)"
    joints, idx = _resolve(cmap, header, where)
    roles = ["time"] + [r for r in _ROLES if r in idx]
    usecols = [k for r in roles for k in idx[r]]
    n = len(joints)
    dtype = [("time", "i8" if cmap.time_unit == "ns" else "f8")] + [
        (r, "f8", (n,)) for r in roles[1:]]
    try:
        with _open(path) as f, warnings.catch_warnings():  # streamed: memory is the arrays
            warnings.simplefilter("ignore", UserWarning)  # "no data": said below, in one line
            for _ in range(header_line):
                f.readline()
            data = np.loadtxt(_with_progress(f, path), delimiter=delim, usecols=usecols,
                              dtype=dtype, comments="#", quotechar='"', ndmin=1)
        # every row as wide as the header (loadtxt reads only usecols); with spaces as the
        # delimiter a row wider than the header goes unnoticed
        width_ok = delim is None or _count(path, header_line, delim) == len(data) * (
            len(header) - 1)
    except (ValueError, OverflowError):
        data, width_ok = None, False
    if not width_ok:  # a refused cell, or rows wider or narrower than the header somewhere
        _diagnose(path, header, header_line, delim, usecols, cmap.time_unit == "ns")
        if data is None:
            raise DataError(f"{path}: numpy could not read it, and no line is at fault: report "
                            "this file as a bug")
    if not len(data):
        raise DataError(f"{where}: a header but no rows")
    stamps = _stamps_ns(data["time"], cmap.time_unit, path, header_line)
    unknown = sorted(set(cmap.prismatic) - set(joints))
    if unknown:
        raise ConfigError(f"{cmap.source}: prismatic joints {unknown} are not among the "
                          f"joints {list(joints)}")
    # per column: a revolute joint's angle unit, a prismatic joint's m as they are
    angle = np.array([1.0 if j in cmap.prismatic else ANGLE_UNITS[cmap.angle_unit]
                      for j in joints])
    effort_factor = EFFORT_UNITS[cmap.effort_unit][1] if cmap.effort_unit else 1.0
    return CsvRecord(path, joints, stamps, data["position"] * angle,
                     data["velocity"] * angle if "velocity" in idx else None,
                     data["effort"] * effort_factor, header_line)


def _stamps_ns(t: np.ndarray, unit: str, path: Path, header_line: int) -> np.ndarray:
    """Integer ns stamps, strictly increasing, >= 0; DataError naming the line otherwise."""
    per = TIME_UNITS[unit]
    if t.dtype.kind == "f":
        bad = np.flatnonzero(~np.isfinite(t))
        if bad.size:
            line = _data_lines(path, header_line, bad[0])
            raise DataError(f"{path} line {line}: the time is {float(t[bad[0]])!r}, not a "
                            "finite number")
        stamps = np.rint(t * per).astype(np.int64)
    else:
        stamps = t.astype(np.int64) * per
    if stamps[0] < 0:
        raise DataError(f"{path} line {_data_lines(path, header_line, 0)}: time {t[0]} {unit} is "
                        "negative; bag stamps start at 0 (shift the time column)")
    back = np.flatnonzero(np.diff(stamps) <= 0)
    if back.size:
        k = int(back[0]) + 1
        line, prev = _data_lines(path, header_line, k), _data_lines(path, header_line, k - 1)
        same = "repeats" if stamps[k] == stamps[k - 1] else "goes back from"
        raise DataError(f"{path} line {line}: time {t[k]} {unit} {same} line {prev}'s {t[k - 1]} "
                        f"{unit}; time must increase from row to row")
    return stamps


def _data_lines(path: Path, header_line: int, k: int) -> int:
    """The file line of data row ``k`` (0-based), blank and comment lines counted."""
    with _open(path) as f:
        seen = -1
        for number, line in enumerate(f, 1):
            if number > header_line and _is_data(line):
                seen += 1
                if seen == k:
                    return number
    return -1


def _count(path: Path, header_line: int, delim: str) -> int:
    """How many delimiters the rows hold (the header's left out), read in blocks: every row as
    wide as the header holds rows x (width - 1) of them."""
    total = 0
    with _open(path) as f:
        for _ in range(header_line):
            f.readline()
        while block := f.read(1 << 24):
            total += block.count(delim)
    return total


def _diagnose(path: Path, header: list[str], header_line: int, delim: str | None,
              usecols: list[int], integer_time: bool) -> None:
    """Scan the rows for the first one that is unreadable or not as wide as the header; raise
    DataError naming it (return when all are fine: a delimiter inside a comment or a quoted
    text)."""
    width, last_line, first_bad = len(header), 0, None
    with _open(path) as f:
        for number, line in enumerate(f, 1):
            if number <= header_line or not _is_data(line):
                continue
            last_line = number
            if first_bad is None:
                reason = _row_reason(_cells(line, delim), header, width, usecols, integer_time)
                if reason:
                    first_bad = (number, reason)
    if first_bad is None:
        return
    number, reason = first_bad
    if number == last_line and reason.startswith("truncated"):
        raise DataError(f"{path} line {number}: the last row is {reason}: a log cut short; "
                        "delete that line")
    raise DataError(f"{path} line {number}: {reason}")


def _row_reason(cells: list[str], header: list[str], width: int, usecols: list[int],
                integer_time: bool) -> str:
    """Why a row is unreadable ("" when it reads)."""
    if len(cells) < width:
        return f"truncated ({len(cells)} of {width} cells)"
    if len(cells) > width:
        return f"{len(cells)} cells, the header has {width}"
    for k in dict.fromkeys(usecols):
        cell = cells[k]
        if not cell:
            return f"column {header[k]!r} is empty"
        if k == usecols[0] and integer_time and not re.fullmatch(r"[+-]?\d+", cell):
            return f"time {cell!r} in ns is not a whole number"
        if not _is_number(cell):
            return f"column {header[k]!r} holds {cell!r}, not a number"
    return ""


# -- several files, one bag
# --------------------------------------------------------------------------
@dataclass
class ImportResult:
    """What ``import`` wrote: the bag, the files and rows it holds, the tag."""

    bag: Path
    files: list[tuple[Path, int]]
    joints: tuple[str, ...]
    stamps_ns: np.ndarray
    effort_unit: str
    velocity: bool
    tag: str

    def to_text(self) -> str:
        n = len(self.stamps_ns)
        span = (self.stamps_ns[-1] - self.stamps_ns[0]) * 1e-9 if n > 1 else 0.0
        step = float(np.median(np.diff(self.stamps_ns))) * 1e-9 if n > 1 else 0.0
        rate = f", median step {step * 1e3:.4g} ms ({1 / step:.4g} Hz)" if step else ""
        files = ", ".join(f"{p.name} ({rows} rows)" for p, rows in self.files)
        effort = ("a torque (N·m or N), tagged orthoglide.effort_unit: torque"
                  if self.effort_unit == "torque" else "a current (A)")
        return "\n".join([
            f"wrote {self.bag}: {n} samples, {span:.6g} s{rate}",
            f"  from {files}",
            f"  joints {', '.join(self.joints)}; effort {effort}; velocity "
            + ("recorded" if self.velocity else "not recorded (NaN)"),
            f"  tag: {self.tag}",
        ])


def read_csvs(paths: Sequence[str | Path], cmap: ColumnMap) -> list[CsvRecord]:
    """The files as one record's pieces: same joints, time increasing from file to file."""
    if not paths:
        raise ConfigError("import: give at least one CSV file")
    cmap.required()
    records: list[CsvRecord] = []
    for p in paths:
        rec = read_csv(p, cmap)
        if records:
            prev = records[-1]
            if rec.joints != prev.joints:
                raise ConfigError(f"{rec.path}: joints {list(rec.joints)} differ from "
                                  f"{prev.path}'s {list(prev.joints)}")
            if (rec.qd is None) != (prev.qd is None):
                raise ConfigError(f"{rec.path}: velocity columns in some files only")
            if rec.stamps_ns[0] <= prev.stamps_ns[-1]:
                line = _data_lines(rec.path, rec.header_line, 0)
                raise DataError(
                    f"{rec.path} line {line}: time {rec.stamps_ns[0] * 1e-9:.9g} s is not after "
                    f"the end of {prev.path.name} ({prev.stamps_ns[-1] * 1e-9:.9g} s): files are "
                    "joined into one record in the order given; import separate runs into "
                    "separate bags")
        records.append(rec)
    return records


def import_csv(paths: Sequence[str | Path], out: str | Path, cmap: ColumnMap) -> ImportResult:
    """Read the CSV files (one record, in the order given) and write one tagged bag at ``out``
    in the ros2_control layout (/joint_states with position, velocity, effort)."""
    from orthoglide_ident.bags._tags import BagTags
    from orthoglide_ident.bags.writer import write_bag

    sampling = None if cmap.current_sampling == "auto" else cmap.current_sampling
    payload = {k: v for k, v in (("payload_frame", cmap.payload_frame),
                                 ("payload_com", cmap.payload_com),
                                 ("payload_inertia", cmap.payload_inertia)) if v is not None}
    try:  # the tag before the files: a typo costs no parsing
        tag = BagTags.checked(cmap.condition, cmap.payload_mass, **payload,
                              current_sampling=sampling).describe()
    except ConfigError as exc:
        raise ConfigError(f"{cmap.source}: {exc}") from None
    if Path(out).exists():
        raise ConfigError(f"{out} exists already; choose another bag name")
    records = read_csvs(paths, cmap)
    stamps = np.concatenate([r.stamps_ns for r in records])
    q = np.concatenate([r.q for r in records])
    effort = np.concatenate([r.effort for r in records])
    qd = (np.full_like(q, np.nan) if records[0].qd is None  # as a broadcaster without velocity
          else np.concatenate([r.qd for r in records]))
    unit = EFFORT_UNITS[cmap.effort_unit][0]
    joints = records[0].joints
    origin = {"orthoglide.imported_from": ", ".join(r.path.name for r in records)}
    bag = write_bag(out, stamps, q, effort, cmap.condition, cmap.payload_mass,
                    joint_names=joints, extra=origin, layout="joint_states", qd=qd,
                    payload=payload, effort_unit=unit, current_sampling=sampling)
    return ImportResult(Path(bag), [(r.path, len(r.stamps_ns)) for r in records], joints,
                        stamps, unit, records[0].qd is not None, tag)
