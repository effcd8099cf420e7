"""What ``identify``'s progress line costs (issue 45): the same identification with ``progress``
None (piped) and with a terminal's progress.Stages (drawn into a fake terminal), in-process.

    PYTHONPATH=. .venv/bin/python bench/identify_progress.py [BAG ...] [--seconds 60] [--repeat 2]

Without BAGs, --seconds of the simulated UR5 unloaded and 60 s with its 2 kg payload are written
as bags first (1 kHz: --seconds 1000 is a 10^6-row record). Prints the wall time of each run
(IDIM-TLS with the consistency step), the stages the line went through, and their number of
redraws.
"""
from __future__ import annotations

import argparse
import io
import tempfile
import time
from pathlib import Path

from orthoglide_ident import progress
from orthoglide_ident.identify import IdentifyOptions, identify
from orthoglide_ident.model.registry import load_robot


class FakeTerminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def simulated_bags(folder: Path, seconds: float) -> list[str]:
    from orthoglide_sim.arm_or_chain.bags import write_record
    from orthoglide_sim.arms.record import simulate_arm

    out = []
    for i, (d, p, t, s) in enumerate(((seconds, None, "exciting1", 0),
                                      (60.0, "2.0", "exciting2", 1))):
        out.append(str(write_record(folder / f"r{i}", simulate_arm(d, "ur5", payload=p,
                                                                   trajectory=t, seed=s))))
    return out


def timed(bags: list[str], stages) -> float:
    t0 = time.perf_counter()
    identify(bags, options=IdentifyOptions.of(consistent=True), model=load_robot("ur5"),
             progress=stages)
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("bags", nargs="*")
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--repeat", type=int, default=2)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        bags = args.bags or simulated_bags(Path(tmp), args.seconds)
        for k in range(args.repeat):
            piped = timed(bags, None)
            tty = FakeTerminal()
            stages = progress.Stages(stream=tty)
            shown = timed(bags, stages)
            stages.close()
            names = list(dict.fromkeys(x.split(":")[0].split(" ...")[0]
                                       for x in tty.getvalue().split("\r") if x.strip()))
            print(f"run {k + 1}: piped {piped:.2f} s, with the progress line {shown:.2f} s "
                  f"({shown / piped - 1:+.1%}); {tty.getvalue().count(chr(13))} writes; stages: "
                  + "; ".join(names))


if __name__ == "__main__":
    main()
