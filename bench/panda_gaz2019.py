"""A real robot against its published model: the Franka Panda record of Gaz et al. 2019.

    python bench/panda_gaz2019.py

Imports tests/fixtures/panda_gaz2019's two CSV parts (``orthoglide-ident import``), identifies
the first (14 s) by IDIM-WLS with gains 1 (the effort is the torque sensors' N·m) and prints:
the held-out part's torque residual rms per joint for the published model and ours (same states,
tests/panda_gaz2019.py), the gravity torques' agreement on the held-out configurations, and the
best-determined base parameters next to the published ones (their feasible parameters through
this product's regrouping). The README's section "A real robot" holds the latest output.
"""
from __future__ import annotations

import argparse
import contextlib
import io
import sys
import tempfile
from pathlib import Path

import numpy as np
from _figures import Figures, add_json_option

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
import panda_gaz2019 as P  # noqa: E402

from orthoglide_ident.cli import main  # noqa: E402
from orthoglide_ident.model.registry import load_robot  # noqa: E402

EMITS_JSON = True  # --json PATH: the figures for bench/write_benchmarks.py
BEFORE = "held-out torque rms 0.519 N·m (the median step as the period, sample-counted options)"


def main_bench() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_json_option(ap)
    args = ap.parse_args()
    figs = Figures(before=BEFORE)
    with tempfile.TemporaryDirectory() as d, contextlib.redirect_stdout(io.StringIO()):
        doc = P.run(Path(d), main)
    robot = load_robot(str(P.URDF))
    chi = np.array([p["value"] for p in doc["parameters"]])
    rms = P.held_out_rms(robot, chi)
    s = P.states(P.FIXTURE / "traj1_b.csv.gz")
    names = [p["name"] for p in doc["parameters"]]
    inertial = np.array([n.split("_")[0] not in ("fv", "fs", "tauoff", "ia") for n in names])
    published = robot.base_values(P.published_standard(robot))
    zero = np.zeros_like(s.q)
    W = robot.regressor(s.q, zero, zero)
    g_o, g_p = ((W @ (x * inertial)).reshape(7, -1).T for x in (chi, published))
    g_rms = np.sqrt(np.mean(g_p ** 2, axis=0))
    g_rel = np.sqrt(np.mean((g_o - g_p) ** 2, axis=0)) / np.where(g_rms > 0, g_rms, np.nan)
    print("held-out torque (traj1_b, 7 s), residual rms in N·m")
    held = figs.table("held-out torque (traj1_b, 7 s), residual rms", [
        "joint", ("measured", "N·m"), ("published", "N·m"), ("ours", "N·m"), ("gravity", "N·m"),
        ("gravity, ours vs published", "%")])
    print(
        f"{'joint':<14}{'measured':>10}{'published':>11}{'ours':>8}{'gravity':>10}"
        f"{'ours vs pub':>13}"
    )
    for j, name in enumerate(P.JOINTS):
        print(f"{name:<14}{rms['measured'][j]:10.3f}{rms['published'][j]:11.3f}"
              f"{rms['identified'][j]:8.3f}{g_rms[j]:10.3f}"
              + (f"{100 * g_rel[j]:12.1f}%" if g_rms[j] > 0.5 else f"{'-':>13}"))
        held.row(name, *(f"{rms[k][j]:.3f}" for k in ("measured", "published", "identified")),
                 f"{g_rms[j]:.3f}", f"{100 * g_rel[j]:.1f}" if g_rms[j] > 0.5 else "-")
    tot = {k: float(np.sqrt(np.mean(v ** 2))) for k, v in rms.items()}
    print(
        f"{'all joints':<14}{tot['measured']:10.3f}{tot['published']:11.3f}{tot['identified']:8.3f}"
    )
    held.row("all joints", *(f"{tot[k]:.3f}" for k in ("measured", "published", "identified")),
             "", "")
    base = figs.table("base parameters with %σ < 6 % (ours) next to the published ones",
                      ["name", "ours", ("σ", "%"), "published", ("diff", "%")])
    print("\nbase parameters with %σ < 6 % (ours) next to the published ones")
    print(f"{'name':<10}{'ours':>10}{'%σ':>7}{'published':>11}{'diff':>8}")
    for p, b in zip(doc["parameters"], published):
        if p["rel_std"] < 0.06 and abs(p["value"]) > 0.01:
            print(f"{p['name']:<10}{p['value']:10.4f}{100 * p['rel_std']:7.1f}{b:11.4f}"
                  f"{100 * (p['value'] - b) / abs(b):7.1f}%")
            base.row(p["name"], f"{p['value']:.4f}", f"{100 * p['rel_std']:.1f}", f"{b:.4f}",
                     f"{100 * (p['value'] - b) / abs(b):.1f}")
    figs.write(args.json)


if __name__ == "__main__":
    main_bench()
