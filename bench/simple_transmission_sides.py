"""Issue 33: a SimpleTransmission arm (negative reductions) gives its joint-side description's
answer, on the independent plant's records.

    PYTHONPATH=. .venv/bin/python bench/coupled_wrist_records.py --out DIR --chain simple
    PYTHONPATH=. .venv/bin/python bench/simple_transmission_sides.py DIR [--method tls|wls]

The same runs identified twice (default options):
- per motor: DIR/ur5_simple_transmission.yaml (the URDF's <ros2_control> SimpleTransmissions,
  each motor's nominal gain) on DIR/joint/* (joint-side positions, each motor's current);
- per joint: DIR/ur5_joint_side.yaml, written here (the UR5 without a transmission, nominal gains
  |n| × the motor's) on DIR/joint_torque/* (the joint torques Nᵀ g_nominal v, tagged torque: read
  as τ_j / (|n| g_nominal) = sign(n) v, each current with the sign of its reduction).
Prints the largest relative difference of the gains (|n| g_m against g_j), of the parameters
(ia, fv n², fs |n|, tauoff n; rigid ones as they are) and of the residuals (|n| ε_m against
ε_j), and the largest in units of the parameters' honest σ. WLS takes the true gains (truth.json).
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
import yaml

from orthoglide_ident.identify import identify
from orthoglide_ident.model.registry import load_robot, read_yaml, resolve

KIND_POWERS = {"ia": 2, "fv": 2, "fs": 1, "tauoff": 1}


def joint_side_yaml(folder: Path, n: np.ndarray, nominal: np.ndarray) -> Path:
    src = resolve("ur5")
    data = read_yaml(src)
    data.update(
        name="ur5_joint_side",
        description=str((src.parent / data["description"]).resolve()),
        nominal_gains=(np.abs(n) * nominal).tolist(),
    )
    path = folder / "ur5_joint_side.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def joint_name(name: str, motors: list[str], n: np.ndarray) -> tuple[str, float]:
    """A motor-side parameter's joint-side name and factor (module docstring)."""
    for kind, power in KIND_POWERS.items():
        if name.startswith(kind + "_") and name[len(kind) + 1:] in motors:
            a = motors.index(name[len(kind) + 1:])
            return f"{kind}_{a + 1}", float(n[a] ** 2 if power == 2 else
                                            (abs(n[a]) if kind == "fs" else n[a]))
    return name, 1.0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("records", type=Path, help="folder of coupled_wrist_records.py --chain simple")
    ap.add_argument("--method", choices=("tls", "wls"), default="tls")
    args = ap.parse_args(argv)
    d = args.records
    truth = json.loads((d / "truth.json").read_text())
    n = np.diag(np.array(truth["reduction"], float))
    motors_model = load_robot(d / "ur5_simple_transmission.yaml")
    nominal = np.asarray(motors_model.nominal_gains, float)
    joints_model = load_robot(joint_side_yaml(d, n, nominal))
    g = np.array(truth["motors"]["gain"], float)
    wls = args.method == "wls"
    by_m = identify(sorted(str(p) for p in (d / "joint").iterdir()), method=args.method,
                    gains=g if wls else None, model=motors_model)
    by_j = identify(sorted(str(p) for p in (d / "joint_torque").iterdir()), method=args.method,
                    gains=np.abs(n) * g if wls else None, model=joints_model)
    motors = list(motors_model.joint_names)
    gm = np.array([x.value for x in by_m.drive_gains])
    gj = np.array([x.value for x in by_j.drive_gains])
    est = {p.name: p for p in by_j.parameters}
    rel, sig = [], []
    for p in by_m.parameters:
        name, f = joint_name(p.name, motors, n)
        q = est[name]
        rel.append(abs(q.value / (f * p.value) - 1))
        sig.append(abs(q.value - f * p.value) / abs(f * p.value * p.rel_std))
    res = np.array(by_j.residual_rms) / (np.abs(n) * np.array(by_m.residual_rms)) - 1
    print(f"{args.method}: gains per motor {', '.join(f'{x:.5f}' for x in gm)} N·m/A")
    if not wls:
        print(
            "  gains |n| g_m vs the joint-side description's: max "
            f"{np.max(np.abs(gj / (np.abs(n) * gm) - 1)):.2g} relative"
        )
    print(f"  {len(rel)} parameters: max {max(rel):.2g} relative, {max(sig):.2g} σ; "
          f"residuals: max {np.max(np.abs(res)):.2g} relative")
    return 0


if __name__ == "__main__":
    sys.exit(main())
