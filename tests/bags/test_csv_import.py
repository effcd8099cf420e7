"""``orthoglide-ident import``: CSV logs to tagged bags (orthoglide_ident/bags/csv_import.py)."""
from __future__ import annotations

import gzip
import lzma
import re
from pathlib import Path

import numpy as np
import pytest

from orthoglide_ident import bags
from orthoglide_ident.bags.csv_import import ColumnMap, import_csv, read_csv
from orthoglide_ident.bags.reader import decode_messages
from orthoglide_ident.cli import main
from orthoglide_ident.errors import ConfigError, DataError

JOINTS = ("j1", "j2")


def _record(n: int = 200, seed: int = 0) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.integers(900_000, 1_100_000, n))  # ns, uneven as a real logger's
    s = t * 1e-9
    q = np.column_stack([np.sin(2 * s), 0.3 * np.cos(3 * s)]) + rng.normal(0, 1e-3, (n, 2))
    return {"t": t, "q": q, "qd": rng.normal(0, 1, (n, 2)), "e": rng.normal(0, 2, (n, 2))}


def write_csv(path: Path, columns: dict[str, np.ndarray], fmt: str = "%.17g",
              delimiter: str = ",") -> Path:
    """Columns by name (each (N,)) as a CSV with a header line."""
    names = list(columns)
    data = np.column_stack([columns[k] for k in names])
    np.savetxt(path, data, fmt=fmt, delimiter=delimiter, header=delimiter.join(names),
               comments="")
    return path


def _columns(rec: dict[str, np.ndarray], time_scale: float = 1.0) -> dict[str, np.ndarray]:
    cols = {"t": rec["t"] * time_scale}
    for k, j in enumerate(JOINTS):
        cols[f"{j}.q"] = rec["q"][:, k]
        cols[f"{j}.qd"] = rec["qd"][:, k]
        cols[f"{j}.effort"] = rec["e"][:, k]
    return cols


def recorded_velocity(bag: Path) -> np.ndarray:
    """The JointState velocity of every message of a bag, (N, n), read with the mcap library."""
    from mcap.reader import make_reader

    raw = []
    for f in sorted(bag.glob("*.mcap")):
        with open(f, "rb") as stream:
            raw += [m.data for _, _, m in make_reader(stream).iter_messages(["/joint_states"])]
    return decode_messages(raw, bags.topics.JOINT_STATE_TYPE, "velocity")[2]


def run(capsys, *args: str) -> tuple[int, str, str]:
    code = main(["import", *map(str, args)])
    out = capsys.readouterr()
    return code, out.out, out.err


# -- round trip and units ------------------------------------------------------------------------
def test_round_trip_gives_back_the_same_arrays(tmp_path, capsys):
    rec = _record()
    csv = write_csv(tmp_path / "log.csv", _columns(rec))
    code, out, err = run(capsys, csv, "--out", tmp_path / "bag", "--time-unit", "ns",
                         "--velocity", "{joint}.qd", "--effort-unit", "A")
    assert code == 0, err
    assert "wrote" in out and "200 samples" in out and "joints j1, j2" in out
    data = bags.read_bag(tmp_path / "bag")
    assert np.array_equal(data.positions.stamps_ns, rec["t"])
    assert np.array_equal(data.positions.position, rec["q"])  # %.17g reads back exactly
    assert np.array_equal(data.current.current, rec["e"])
    assert data.tags.condition == "unloaded" and data.tags.effort_unit == "A"
    assert data.sources.describe() == ("q from /joint_states position (JointState); current "
                                       "from /joint_states effort (JointState)")
    assert np.array_equal(recorded_velocity(tmp_path / "bag"), rec["qd"])


def test_time_units_give_the_same_stamps(tmp_path):
    rec = _record(50)
    for unit, scale in (("s", 1e-9), ("ms", 1e-6), ("us", 1e-3), ("ns", 1.0)):
        csv = write_csv(tmp_path / f"{unit}.csv", _columns(rec, scale))
        got = read_csv(csv, ColumnMap(time_unit=unit, effort_unit="A"))
        assert np.array_equal(got.stamps_ns, rec["t"]), unit


def test_degrees_milliamps_and_torques(tmp_path):
    rec = _record(50)
    cols = _columns(rec)
    for j in JOINTS:
        cols[f"{j}.q"] = np.degrees(cols[f"{j}.q"])
        cols[f"{j}.qd"] = np.degrees(cols[f"{j}.qd"])
    csv = write_csv(tmp_path / "deg.csv", cols)
    got = read_csv(csv, ColumnMap(time_unit="ns", angle_unit="deg", velocity="{joint}.qd",
                                  effort_unit="mA"))
    assert np.allclose(got.q, rec["q"], rtol=1e-15, atol=1e-15)
    assert np.allclose(got.qd, rec["qd"], rtol=1e-15, atol=1e-15)
    assert np.allclose(got.effort, rec["e"] * 1e-3, rtol=1e-15)
    res = import_csv([csv], tmp_path / "bag", ColumnMap(time_unit="ns", angle_unit="deg",
                                                        effort_unit="N·m"))
    tags = bags.read_bag(tmp_path / "bag").tags
    assert res.effort_unit == "torque" and tags.effort_unit == "torque"
    assert "effort a torque" in tags.describe()


def test_no_velocity_column_is_nan_in_the_bag(tmp_path):
    rec = _record(30)
    csv = write_csv(tmp_path / "log.csv", _columns(rec))
    import_csv([csv], tmp_path / "bag", ColumnMap(time_unit="ns", effort_unit="A"))
    velocity = recorded_velocity(tmp_path / "bag")
    assert velocity.shape == (30, 2) and np.isnan(velocity).all()  # a broadcaster's, without one


def test_yaml_map_and_flags_agree(tmp_path, capsys):
    rec = _record(40)
    cols = {"time_ms": rec["t"] * 1e-6}
    for k in range(len(JOINTS)):
        cols[f"pos{k}"] = rec["q"][:, k]
        cols[f"tau{k}"] = rec["e"][:, k]
        cols[f"mode{k}"] = np.zeros(len(rec["t"]))
    csv = write_csv(tmp_path / "log.csv", cols, delimiter=";")
    yaml_map = tmp_path / "map.yaml"
    yaml_map.write_text("time: time_ms\ntime_unit: ms\neffort_unit: N·m\ncondition: loaded\n"
                        "payload_mass: 1.5\npayload_com: [0, 0, 0.05]\n"
                        "joints:\n  j1: {position: pos0, effort: tau0}\n"
                        "  j2: {position: pos1, effort: tau1}\n")
    code, _, err = run(capsys, csv, "--out", tmp_path / "by_yaml", "--map", yaml_map)
    assert code == 0, err
    code, _, err = run(capsys, csv, "--out", tmp_path / "by_flags", "--time", "time_ms",
                       "--time-unit", "ms", "--joints", "j1,j2", "--position", "pos0,pos1",
                       "--effort", "tau0,tau1", "--effort-unit", "N·m", "--condition", "loaded",
                       "--payload-mass", "1.5", "--payload-com", "0 0 0.05")
    assert code == 0, err
    a, b = (bags.read_bag(tmp_path / n) for n in ("by_yaml", "by_flags"))
    assert a.tags == b.tags and a.tags.payload_com == (0.0, 0.0, 0.05)
    assert a.tags.condition == "loaded" and a.tags.payload_mass == 1.5
    assert np.array_equal(a.positions.stamps_ns, b.positions.stamps_ns)
    assert np.array_equal(a.positions.position, b.positions.position)
    assert np.array_equal(a.current.current, rec["e"])
    # a flag wins over the map
    code, _, err = run(capsys, csv, "--out", tmp_path / "mixed", "--map", yaml_map,
                       "--condition", "unloaded", "--payload-mass", "0")
    assert code == 2  # unloaded with a payload_com: refused, one line
    assert err.count("\n") == 1 and "payload_com" in err and "map.yaml" in err


def test_header_less_compressed_files_and_comments(tmp_path):
    rec = _record(30)
    body = "".join(f"{t},{q[0]:.17g},{q[1]:.17g},{e[0]:.17g},{e[1]:.17g}\n"
                   for t, q, e in zip(rec["t"], rec["q"], rec["e"]))
    text = "# exported by a controller\n\n" + body
    for name, opener in (("log.csv.gz", gzip.open), ("log.csv.xz", lzma.open)):
        with opener(tmp_path / name, "wt") as f:
            f.write(text)
        got = read_csv(tmp_path / name, ColumnMap(time="1", time_unit="ns", joints=JOINTS,
                                                  position="2,3", effort="4,5",
                                                  effort_unit="A"))
        assert got.header_line == 0
        assert np.array_equal(got.q, rec["q"]) and np.array_equal(got.stamps_ns, rec["t"])


def test_several_files_make_one_bag(tmp_path):
    rec = _record(60)
    cols = _columns(rec)
    first = write_csv(tmp_path / "a.csv", {k: v[:25] for k, v in cols.items()})
    second = write_csv(tmp_path / "b.csv", {k: v[25:] for k, v in cols.items()})
    res = import_csv([first, second], tmp_path / "bag", ColumnMap(time_unit="ns", effort_unit="A"))
    assert [n for _, n in res.files] == [25, 35]
    data = bags.read_bag(tmp_path / "bag")
    assert np.array_equal(data.positions.stamps_ns, rec["t"])
    with pytest.raises(DataError, match=r"a\.csv line 2: time .* is not after the end of b\.csv"):
        import_csv([second, first], tmp_path / "bag2", ColumnMap(time_unit="ns", effort_unit="A"))


# -- bad input: one line naming the file and the line --------------------------------------------
GOOD = "t,j1.q,j1.effort\n0.000,0.1,1.0\n0.001,0.2,1.1\n0.002,0.3,1.2\n"


@pytest.mark.parametrize("text, flags, reason", [
    (GOOD.replace("j1.effort", "j1.current"), (), r"bad\.csv line 1: no column 'j1\.effort' "
     r"\(joint j1's effort\); the header has t, j1\.q, j1\.current"),
    (GOOD.replace("0.002,", "0.001,"), (), r"bad\.csv line 4: time 0\.001 s repeats line 3's"),
    (GOOD.replace("0.002,", "0.0005,"), (), r"bad\.csv line 4: time 0\.0005 s goes back from "
     r"line 3's 0\.001 s"),
    (GOOD.replace("0.2,", "0.2x,"), (), r"bad\.csv line 3: column 'j1\.q' holds '0\.2x', not a "
     r"number"),
    (GOOD.replace(",1.1", ","), (), r"bad\.csv line 3: column 'j1\.effort' is empty"),
    (GOOD[:-5], (), r"bad\.csv line 4: the last row is truncated \(2 of 3 cells\): a log cut "
     r"short; delete that line"),
    (GOOD.replace("0.001,0.2,1.1", "0.001,0.2"), (), r"bad\.csv line 3: truncated \(2 of 3 "
     r"cells\)"),
    (GOOD.replace("0.001,0.2,1.1", "0.001,0.2,1.1,7"), (), r"bad\.csv line 3: 4 cells, the "
     r"header has 3"),
    ("", (), r"bad\.csv: empty file \(no header, no rows\)"),
    ("\n# nothing\n", (), r"bad\.csv: empty file"),
    ("t,j1.q,j1.effort\n", (), r"bad\.csv line 1: a header but no rows"),
    (GOOD.replace("0.000,", "nan,"), (), r"bad\.csv line 2: the time is nan, not a finite"),
    (GOOD.replace("0.000,", "-0.5,"), (), r"bad\.csv line 2: time -0\.5 s is negative"),
    (GOOD, ("--time-unit", "sec"), r"the flags: unknown time_unit 'sec'; use one of s, ms, us, "
     r"ns"),
    (GOOD, ("--angle-unit", "grad"), r"unknown angle_unit 'grad'; use one of rad, deg"),
    (GOOD, ("--effort-unit", "kNm"), r"unknown effort_unit 'kNm'; use A or mA \(a current\), "
     r"N·m \(Nm\) or N"),
    (GOOD, ("--effort-unit", ""), r"say what the effort columns hold: effort_unit A or mA"),
    (GOOD, ("--position", "{joint}_pos"), r"no column matches the position template "
     r"'\{joint\}_pos'"),
    (GOOD.replace("0.001,", "1000000,").replace("0.002,", "2000000,").replace("0.000,", "0.5,"),
     ("--time-unit", "ns"), r"bad\.csv line 2: time '0\.5' in ns is not a whole number"),
    (GOOD, ("--condition", "loaded"), r"the flags: condition 'loaded' needs a positive "
     r"payload_mass"),
])
def test_bad_csv_is_one_line_naming_the_file_and_line(tmp_path, capsys, text, flags, reason):
    bad = tmp_path / "bad.csv"
    bad.write_text(text)
    args = ["--effort-unit", "A", *flags] if "--effort-unit" not in flags else list(flags)
    code, out, err = run(capsys, bad, "--out", tmp_path / "bag", *args)
    assert code == 2 and out == "" and "Traceback" not in err
    assert err.count("\n") == 1, err
    assert err.startswith("orthoglide-ident: error: ")
    assert re.search(reason, err), err
    assert not (tmp_path / "bag").exists()  # nothing half-written


def test_an_existing_bag_is_not_overwritten(tmp_path, capsys):
    good = tmp_path / "good.csv"
    good.write_text(GOOD)
    (tmp_path / "bag").mkdir()
    code, _, err = run(capsys, good, "--out", tmp_path / "bag", "--effort-unit", "A")
    assert code == 2 and "exists already" in err and err.count("\n") == 1


def test_unknown_map_key_names_the_yaml(tmp_path, capsys):
    good = tmp_path / "good.csv"
    good.write_text(GOOD)
    m = tmp_path / "map.yaml"
    m.write_text("effort_units: A\n")
    code, _, err = run(capsys, good, "--out", tmp_path / "bag", "--map", m)
    assert code == 2 and f"{m}: unknown key 'effort_units'" in err


def test_help_has_an_example(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["import", "--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    assert "example" in out and "--effort-unit" in out and "orthoglide-ident identify" in out


def test_column_map_errors_are_config_errors(tmp_path):
    with pytest.raises(ConfigError, match="joints .* name a joint twice"):
        ColumnMap().with_values(joints="a,a")
    with pytest.raises(ConfigError, match="have no effort column"):
        ColumnMap.from_mapping({"joints": {"a": {"position": "x", "effort": "y"},
                                           "b": {"position": "z"}}}, "m.yaml")


def test_a_role_without_columns_is_refused(tmp_path):
    good = tmp_path / "good.csv"
    good.write_text(GOOD)
    with pytest.raises(ConfigError, match="give the effort columns"):
        read_csv(good, ColumnMap(effort="", effort_unit="A"))
