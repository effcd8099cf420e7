"""W's smooth columns at the decimated rows against every column at every sample (issue 35's bar).

    PYTHONPATH=. .venv/bin/python bench/rows_vs_samples.py [--robot R] BAG... [--method wls]
    PYTHONPATH=. .venv/bin/python bench/rows_vs_samples.py --ur5 DIR      # MuJoCo UR5, 2 x 60 s
    PYTHONPATH=. .venv/bin/python bench/rows_vs_samples.py --panda        # Gaz et al.'s record
    PYTHONPATH=. .venv/bin/python bench/rows_vs_samples.py [--json PATH]  # both (a temporary DIR)

Runs `orthoglide-ident identify` twice on the same records, with config/identification.yaml's
``regressor_at: rows`` (the default) and ``samples`` (the exact path, eqs. 19-20 as written), and
prints each answer's difference in units of the samples path's σ: the reported one (``rel_std``,
the largest of eqs. (38)-(39) and the sandwiches) and eqs. (38)-(39)'s (``rel_std_paper``): the
worst gain, the worst base parameters and their names. Issue 35's bar: 0.1 σ on every record.
``--ur5 DIR``: the bags of bench/identify_speed.py --robot ur5 (written there when missing);
coupled-wrist records: bench/coupled_wrist_records.py --out DIR [--chain simple], then
``--robot DIR/ur5_coupled_wrist.yaml DIR/joint/*`` (DIR/ur5_simple_transmission.yaml).

Latest figures: README "How the identification works", step 4.
"""
from __future__ import annotations

import argparse
import contextlib
import io
import json
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))

from _figures import Figures, add_json_option  # noqa: E402

from orthoglide_ident.cli import main as cli_main  # noqa: E402

CONFIG = ROOT / "config" / "identification.yaml"
EMITS_JSON = True  # --json PATH: the figures for bench/write_benchmarks.py
BEFORE = ("q̈'s spread along its slope (gains / parameters): UR5 0.016 / 0.035 σ, Panda 0.015 σ "
          "(0.029 σ in eqs. (38)-(39)'s)")
FIGS = Figures(before=BEFORE)
TABLE = FIGS.table("regressor_at: rows against samples, the answers apart in the samples path's σ",
                   ["records", "gains, reported σ", "parameters, reported σ",
                    "gains, eqs. (38)-(39)'s σ", "parameters, eqs. (38)-(39)'s σ"])


def identify(argv: list[str], where: str, work: Path) -> dict:
    """``identify argv`` with regressor_at: ``where``; its --json document."""
    cfg, out = work / f"{where}.yaml", work / f"{where}.json"
    text = CONFIG.read_text()
    assert "regressor_at: rows" in text
    cfg.write_text(text.replace("regressor_at: rows", f"regressor_at: {where}"))
    with contextlib.redirect_stdout(io.StringIO()):
        rc = cli_main(["identify", *argv, "--config", str(cfg), "--json", str(out), "-q"])
    if rc != 0:
        raise SystemExit(f"identify {' '.join(argv)} ({where}) exited {rc}")
    return json.loads(out.read_text())


def in_sigma(exact: list[dict], approx: list[dict], key: str,
             sigma: str) -> list[tuple[float, str]]:
    """|approx - exact| / σ of each entry (σ: exact's ``sigma``, a relative std), with its name."""
    out = []
    for x, y in zip(exact, approx):
        s = x.get(sigma)
        if s is None or x["value"] is None or not s > 0:
            continue
        out.append((abs(y["value"] - x["value"]) / (abs(x["value"]) * s), x[key]))
    return sorted(out, reverse=True)


def worst(exact: dict, rows: dict, sigma: str, cells: list[str] | None = None) -> str:
    """The worst gain and parameters apart, printed; their cells appended to ``cells``."""
    g = in_sigma(exact["drive_gains"], rows["drive_gains"], "joint", sigma) or [(0.0, "-")]
    p = in_sigma(exact["parameters"], rows["parameters"], "name", sigma)
    if cells is not None:
        cells += [f"{g[0][0]:.4f} ({g[0][1]})", f"{p[0][0]:.4f} ({p[0][1]})"]
    return (f"gains {g[0][0]:.4f} ({g[0][1]}), parameters {p[0][0]:.4f} ({p[0][1]}; next "
            f"{', '.join(f'{n} {v:.4f}' for v, n in p[1:3])})")


def compare(argv: list[str], label: str) -> None:
    with tempfile.TemporaryDirectory() as d:
        exact = identify(argv, "samples", Path(d))
        rows = identify(argv, "rows", Path(d))
    cells = [label]
    print(f"{label}\n  in the reported σ: {worst(exact, rows, 'rel_std', cells)}\n"
          f"  in eqs. (38)-(39)'s σ: {worst(exact, rows, 'rel_std_paper', cells)}")
    TABLE.row(*cells)


def ur5_bags(d: Path) -> list[str]:
    from identify_speed import arm_bags

    d.mkdir(parents=True, exist_ok=True)
    paths, _ = arm_bags(d, "ur5", 60.0)
    return ["--robot", "ur5", *map(str, paths)]


def panda_args(d: Path) -> list[str]:
    """Gaz et al.'s first part imported as tests/panda_gaz2019.run does, identified alike."""
    import importlib.util  # tests/panda_gaz2019.py: bench/ has a module of that name

    spec = importlib.util.spec_from_file_location("panda_fixture",
                                                  ROOT / "tests" / "panda_gaz2019.py")
    P = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(P)
    bag = d / "traj1_a"
    if not bag.exists():
        with contextlib.redirect_stdout(io.StringIO()):
            rc = cli_main(["import", str(P.FIXTURE / "traj1_a.csv.gz"), "--map",
                           str(P.FIXTURE / "map.yaml"), "--out", str(bag)])
        assert rc == 0, "import failed"
    return ["--robot", str(P.URDF), "--method", "wls", str(bag)]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--ur5", type=Path, help="the MuJoCo UR5's 2 x 60 s bags here")
    ap.add_argument("--panda", action="store_true", help="the Panda record of Gaz et al. 2019")
    add_json_option(ap)
    args, rest = ap.parse_known_args()
    with tempfile.TemporaryDirectory() as tmp:
        label = f"UR5 {args.ur5}"
        if not (args.ur5 or args.panda or rest):  # neither named: both
            args.ur5, args.panda, label = Path(tmp) / "ur5", True, "UR5 (MuJoCo, 2 x 60 s)"
        if args.ur5:
            compare(ur5_bags(args.ur5), label)
    if args.panda:
        with tempfile.TemporaryDirectory() as d:
            compare(panda_args(Path(d)), "Panda (Gaz et al. 2019)")
    if rest:
        compare(rest, " ".join(rest))
    FIGS.write(args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
