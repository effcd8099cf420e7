"""TLS and IV side by side on small distal gains under current noise (issue 43).

    PYTHONPATH=.:tests .venv/bin/python bench/tls_vs_iv.py [--seconds 40] [--seed 0]

The 7-axis Panda of tests/panda_arm.py (example-robot-data URDF, fingers fixed; torques from
Pinocchio's RNEA with rotor inertia, viscous and Coulomb friction; gains 9.2 ... 1.6 N·m/A, the
distal three small), --seconds unloaded + --seconds with a 1 kg payload of unknown CoM tagged with
its mass, 1 kHz, white current noise of 0.5/1/2/5 % of each joint's rms current. Per noise level
and gain: the error in % and in σ of the paper's TLS (eqs. 33-39, unchecked: the number it would
give), of the TLS with per-joint current noise (tls_noisy_columns: per-joint) and of IDIM-IV;
then what the identification answers with the paper's TLS and with the default (per-joint) TLS,
checked and cross-checked by IV ("-": not determined).
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
from _figures import Figures, add_json_option

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

import panda_arm as P  # noqa: E402

from orthoglide_ident.errors import OrthoglideError  # noqa: E402
from orthoglide_ident.identify import IdentifyOptions, identify_records  # noqa: E402
from orthoglide_ident.model.registry import load_robot  # noqa: E402

NOISE_LEVELS = (0.005, 0.01, 0.02, 0.05)
EMITS_JSON = True  # --json PATH: the figures for bench/write_benchmarks.py
VARIANTS = (("TLS paper", "tls", dict(tls_noisy_columns="all", check_excitation=False,
                                       cross_check="none")),
            ("TLS per-joint", "tls", dict(tls_noisy_columns="per-joint", cross_check="none")),
            ("IV", "iv", {}))


def errors(res) -> tuple[np.ndarray, np.ndarray]:
    """Per gain: error (fraction) and error / σ."""
    g = np.array([x.value for x in res.drive_gains])
    e = g / P.GAINS - 1
    return e, e / np.array([x.rel_std for x in res.drive_gains])


def checked_answer(recs, model, noisy_columns: str) -> str:
    """What ``orthoglide-ident identify`` answers with that TLS (checked, cross-checked by IV):
    per gain its error (% and σ), "-" where not determined."""
    try:
        res = identify_records(recs, model=model,
                               options=IdentifyOptions.of(tls_noisy_columns=noisy_columns))
    except OrthoglideError as exc:
        return f"refused: {str(exc)[:90]}"
    e, z = errors(res)
    out = [f"{j[-1]}: {'-' if not g.determined else f'{100 * x:+.2f} % ({k:+.1f} σ)'}"
           for j, g, x, k in zip(P.JOINTS, res.drive_gains, e, z)]
    return ", ".join(out)


def one_level(figs: Figures, noise: float, seconds: float, seed: int, model) -> None:
    recs = P.records(seconds, noise, seed)
    cols = {}
    for name, method, kw in VARIANTS:
        t0 = time.perf_counter()
        try:
            res = identify_records(recs, model=model, method=method,
                                   options=IdentifyOptions.of(**kw))
            cols[name] = (*errors(res), time.perf_counter() - t0)
        except OrthoglideError as exc:
            cols[name] = None
            print(f"  {name}: refused: {exc}")
    print(f"\ncurrent noise {100 * noise:g} % of each joint's rms current")
    print(f"  {'joint':<13}" + "".join(f"{name:>22}" for name, _, _ in VARIANTS))
    table = figs.table(f"current noise {100 * noise:g} % of each joint's rms current: gain error "
                       "% and error / σ", ["joint", *(name for name, _, _ in VARIANTS)])
    for j, joint in enumerate(P.JOINTS):
        cells = [f"{100 * c[0][j]:+9.3f} % {c[1][j]:+6.1f} σ" if c else f"{'-':>20}"
                 for c in (cols[name] for name, _, _ in VARIANTS)]
        print(f"  {joint:<13}" + "".join(f"{x:>22}" for x in cells))
        table.row(joint, *(" ".join(x.split()) for x in cells))
    worst = [f"{name} max |z| {np.max(np.abs(c[1])):.1f} ({c[2]:.1f} s)"
             for name, c in cols.items() if c]
    print("  " + "; ".join(worst))
    figs.note(f"{100 * noise:g} %: " + "; ".join(worst))
    for noisy, what in (("all", "paper's TLS"), ("per-joint", "default: per-joint TLS")):
        line = f"{what}, checked, cross-checked by IV: {checked_answer(recs, model, noisy)}"
        print(f"  {line}")
        figs.note(f"{100 * noise:g} %, {line}")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=40.0)
    ap.add_argument("--seed", type=int, default=0)
    add_json_option(ap)
    args = ap.parse_args()
    model = load_robot(str(P.URDF))
    print(f"Panda (example-robot-data, fingers fixed), {args.seconds:g} s + {args.seconds:g} s at "
          f"1 kHz, 1 kg payload of unknown CoM; gains {', '.join(f'{g:g}' for g in P.GAINS)} "
          "N·m/A; error % and error / σ")
    figs = Figures()
    for noise in NOISE_LEVELS:
        one_level(figs, noise, args.seconds, args.seed, model)
    figs.write(args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
