"""Each demo's last line: `verdict: pass` or `verdict: FAIL: <causes>` against its stated bars."""
from __future__ import annotations

from collections.abc import Sequence

# An identified gain's bars (docs/benchmarks.md, and the product's honest σ): within
# 0.5 % of the plant's truth and within 3 of its own σ.
GAIN_BAR = 0.005
SIGMA_BAR = 3.0
GAIN_BARS = f"gains within {100 * GAIN_BAR:.1f} % and {SIGMA_BAR:.0f} σ of the plant's"


def gain_causes(names: Sequence[str], values: Sequence[float], rel_std: Sequence[float],
                truth: Sequence[float]) -> list[str]:
    """One cause per gain outside its bars."""
    causes = []
    for name, g_id, rel, g_true in zip(names, values, rel_std, truth):
        err = g_id / g_true - 1
        if abs(err) > GAIN_BAR or abs(err) > SIGMA_BAR * rel:
            causes.append(f"gain {name} {100 * err:+.3f} % from the plant's ({err / rel:+.1f} σ; "
                          f"bars {100 * GAIN_BAR:.1f} %, {SIGMA_BAR:.0f} σ)")
    return causes


def verdict_line(causes: Sequence[str], *bars: str) -> tuple[str, int]:
    """The verdict line and the demo's exit code (1 when it failed); ``bars``: the demo's own,
    said after the gains' (GAIN_BARS)."""
    if not causes:
        return f"verdict: pass ({', '.join((GAIN_BARS, *bars))})", 0
    return "verdict: FAIL: " + "; ".join(causes), 1
