"""``excite design`` with its defaults on arms it never saw (example-robot-data) and on the
bundled UR5 and five-bar.

    PYTHONPATH=. .venv/bin/python bench/excite_unseen.py [--robots ur10,panda,...] [--restarts R]
                                                         [--steps S] [--collision mesh|skip]
                                                         [--search walk|gradient]

Times: the design's wall time and this process's CPU time (the machine is shared: the CPU
time compares runs made under different loads). Each unseen arm is used as its URDF comes
(a copy: the Panda's fingers made fixed joints by hand, the only edit), with a 1 kg payload on
its last link and nothing else: no acceleration limits (the derived default; ``--acceleration``
gives every joint one, as a joint_limits file would), no start pose (the file's, else
mid-range out of self-collision). Per
robot: design time, the predicted worst gain σ and κ of the design against the median of the
random feasible shapes, the smallest slack to the margins on the 1 ms grid, or the refusal.
"""
from __future__ import annotations

import argparse
import os
import re
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from orthoglide_ident.errors import OrthoglideError  # noqa: E402
from orthoglide_ident.excite.collision import CollisionModel  # noqa: E402
from orthoglide_ident.excite.design import DesignOptions, design  # noqa: E402
from orthoglide_ident.excite.limits import read_limits  # noqa: E402
from orthoglide_ident.model.robot import Payload  # noqa: E402
from orthoglide_ident.model.robots import load_robot  # noqa: E402

SHARE = Path(sys.prefix) / "lib/python3.11/site-packages/cmeel.prefix/share"
ERD = SHARE / "example-robot-data/robots"
UNSEEN = {"ur10": "ur_description/urdf/ur10_robot.urdf",
          "ur3": "ur_description/urdf/ur3_robot.urdf",
          "panda": "panda_description/urdf/panda.urdf",
          "xarm7": "xarm_description/urdf/xarm7.urdf",
          "z1": "z1_description/urdf/z1.urdf"}
BUNDLED = {"ur5": Payload(2.0, "tool0", (0.035, -0.025, 0.06), (4e-3, 0, 0, 4e-3, 0, 2.5e-3)),
           "five_bar": Payload(1.0, "tip", (0.01, 0.0, 0.02), (1e-4, 0, 0, 1e-4, 0, 1e-4))}
UNSEEN_PAYLOAD_KG = 1.0


def unseen_copy(name: str, folder: Path) -> Path:
    """The arm's URDF copied to ``folder``, a gripper's joints fixed by hand (Panda's fingers)."""
    text = (ERD / UNSEEN[name]).read_text()
    text = re.sub(r'(<joint name="panda_finger_joint\d"\s+type=")prismatic"', r'\1fixed"', text)
    text = re.sub(r"<mimic[^>]*/>", "", text) if name == "panda" else text
    out = folder / f"{name}.urdf"
    out.write_text(text)
    return out


def _limits_file(robot, acceleration: float | None, folder: Path) -> Path | None:
    """A ros2_control joint_limits file giving every joint ``acceleration`` (as a user would
    write before this work), or None (the derived default)."""
    if acceleration is None:
        return None
    path = folder / f"{robot.name}_limits.yaml"
    path.write_text("joint_limits:\n" + "".join(
        f"  {j}:\n    has_acceleration_limits: true\n    max_acceleration: {acceleration}\n"
        for j in robot.joint_names))
    return path


def _kappa(p) -> float:
    """κ of the directions a design excites (the code before: κ of all)."""
    return p.condition_kept if hasattr(p, "condition_kept") else p.condition


def _worst(p) -> float:
    """The worst determined gain's σ (the code before this bench had only ``worst_gain``)."""
    return p.worst_determined_gain() if hasattr(p, "worst_determined_gain") else p.worst_gain


def run(name: str, args, folder: Path) -> None:
    if name in BUNDLED:
        robot, payload = load_robot(name), BUNDLED[name]
    else:
        robot = load_robot(str(unseen_copy(name, folder)))
        payload = Payload(UNSEEN_PAYLOAD_KG)
    t0, c0 = time.perf_counter(), time.process_time()
    try:
        limits = read_limits(robot, _limits_file(robot, args.acceleration, folder)
                             if name not in BUNDLED else None)
        collision = CollisionModel(robot, args.collision, [str(SHARE)])
        extra = {"time_limit_s": args.time_limit} if args.time_limit else {}
        opt = DesignOptions(payload, np.full(robot.n_joints, 0.02), restarts=args.restarts,
                            steps=args.steps, search=args.search, **extra)
        d = design(robot, limits, collision, opt,
                   progress=lambda s: print(f"  {name}: {s}", file=sys.stderr))
    except OrthoglideError as exc:
        print(f"{name:<9} refused after {time.perf_counter() - t0:.1f} s: {exc}")
        return
    rand = [e.prediction for e in d.random if e.prediction is not None]
    med_s = np.median([_worst(p) for p in rand]) if rand else np.nan
    med_k = np.median([_kappa(p) for p in rand]) if rand else np.nan
    slack = min(s.value - s.required for k, s in d.check.by_kind().items() if k != "at_rest")
    gone = [u.to_text().split(" (")[0] for u in getattr(d.prediction, "unexcited", ())]
    coll = d.check.by_kind().get("collision")
    cpu = time.process_time() - c0  # the load of the shared machine aside
    print(f"{name:<9} {robot.n_joints} joints  {d.seconds:6.1f} s (cpu {cpu:5.1f} s)  worst gain σ "
          f"{100 * _worst(d.prediction):.3g} % (random median {100 * med_s:.3g} %)  κ "
          f"{_kappa(d.prediction):.3g} (median {med_k:.3g})  min slack {slack:.3g}  "
          f"collision {coll.value if coll else float('nan'):.3g} m  "
          f"{len(rand)} random feasible"
          + (f"  not excited: {'; '.join(gone)}" if gone else ""))


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--robots", default="ur5,five_bar,ur10,panda")
    ap.add_argument("--restarts", type=int, default=20)
    ap.add_argument("--steps", type=int, default=None)
    ap.add_argument("--time-limit", type=float, default=None)
    ap.add_argument("--collision", default="mesh")
    ap.add_argument("--search", default="gradient", help="gradient | walk (excite/gradient.py)")
    ap.add_argument("--acceleration", type=float, default=None,
                    help="rad/s² for every joint of an unseen arm (default: derived)")
    args = ap.parse_args()
    print(f"restarts {args.restarts}, steps {args.steps}, search {args.search}, "
          f"collision {args.collision}, "
          f"time limit {args.time_limit}, acceleration {args.acceleration or 'derived'}")
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.robots.split(","):
            run(name, args, Path(tmp))


if __name__ == "__main__":
    main()
