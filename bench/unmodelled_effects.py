"""The UR5's drive gains identified on plants with what the model lacks (issue 48).

For each effect of orthoglide_sim/arms/unmodelled.py (and none), an unloaded 20 s record on
exciting1 and a 2 kg one on exciting2 (tests/identify/test_on_arm.py's pair), identified by
IDIM-TLS; per joint the gain's error in its reported (honest) σ, the residual's ratio at current
reversals, and the warnings: before = without the reversal check (uncertainty.py), after = all.

    PYTHONPATH=. python bench/unmodelled_effects.py [effect ...]
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from live_helpers import as_record  # noqa: E402

from orthoglide_ident.identify import identify_records  # noqa: E402
from orthoglide_ident.model.registry import load_robot  # noqa: E402
from orthoglide_sim.arms.record import simulate_arm  # noqa: E402
from orthoglide_sim.arms.unmodelled import Unmodelled  # noqa: E402

EFFECTS = {
    "none": Unmodelled(),
    "elasticity": Unmodelled(elasticity_hz=150.0),  # a 150 Hz joint resonance, ζ 0.2
    "backlash": Unmodelled(backlash=1e-4),  # 0.1 mrad lost motion (a harmonic drive's ~0.3 arcmin)
    "current_loop": Unmodelled(current_loop_hz=1000.0),  # 1 kHz, ζ 0.7
    "stribeck": Unmodelled(stribeck=0.5),  # +50 % static friction below 0.02 rad/s
}
REVERSAL_SAID = "where its current reverses"


def identify_on(effect: Unmodelled, seconds: float = 20.0):
    """(result, true gains, model) of the pair of records on a plant with ``effect``."""
    runs = [simulate_arm(seconds, payload=None, trajectory="exciting1", seed=0, effects=effect),
            simulate_arm(seconds, payload="2.0", trajectory="exciting2", seed=1, effects=effect)]
    model = load_robot("ur5")
    res = identify_records([as_record(runs[0], "unloaded"), as_record(runs[1], "2kg")], model=model)
    truth = runs[0].truth
    return res, np.array([truth.drives[j].g_tau for j in model.joint_names]), model


def main(names: list[str]) -> None:
    print(f"{time.strftime('%Y-%m-%d')}: UR5, 20 s unloaded + 20 s with 2 kg, IDIM-TLS")
    for name in names or list(EFFECTS):
        fx = EFFECTS[name]
        t0 = time.perf_counter()
        res, g_true, model = identify_on(fx)
        g = np.array([x.value for x in res.drive_gains])
        sigma = np.array([x.rel_std * x.value for x in res.drive_gains])
        ratio = (res.uncertainty.reversal_residual_ratio if res.uncertainty else None) or {}
        after = res.warnings
        before = [w for w in after if REVERSAL_SAID not in w]
        print(f"\n{name} ({fx.describe()}), {time.perf_counter() - t0:.0f} s")
        print("  joint                 err %    σ %   err/σ  reversal ratio")
        for j, n in enumerate(model.joint_names):
            r = ratio.get(n)
            print(f"  {n:20s} {100 * (g[j] / g_true[j] - 1):7.3f} {100 * sigma[j] / g[j]:6.3f} "
                  f"{(g[j] - g_true[j]) / sigma[j]:6.2f}  {'-' if r is None else f'{r:.2f}'}")
        print(f"  warnings: {len(before)} -> {len(after)}")
        for w in after:
            if REVERSAL_SAID in w:
                print(f"    + {w}")


if __name__ == "__main__":
    main(sys.argv[1:])
