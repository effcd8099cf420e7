"""The designed runs sampled at 1 kHz as CSV (``excite design --samples FILE.csv``), for any tool
that checks or replays them: header ``run,t,<joint>.q,<joint>.qd,<joint>.qdd`` per actuated
joint, one row per sample from t = 0 to the run's duration, ``run`` = unloaded | loaded; SI units
(s; m or rad, per s, per s²)."""
from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.excite.trajectory import ExcitationTrajectory

SAMPLE_RATE_HZ = 1000


def header(joints) -> str:
    return ",".join(["run", "t"] + [f"{j}.{k}" for j in joints for k in ("q", "qd", "qdd")])


def write_samples(traj: ExcitationTrajectory, path: str | Path) -> int:
    """Write every run of ``traj`` at SAMPLE_RATE_HZ; returns the number of rows."""
    rows = 0
    try:
        with open(path, "w", newline="") as fh:
            fh.write(header(traj.joints) + "\n")
            for name in traj.runs:
                n = int(round(traj.duration * SAMPLE_RATE_HZ)) + 1
                t = np.arange(n) / SAMPLE_RATE_HZ
                q, qd, qdd = traj.evaluate(name, t)
                table = np.empty((n, 1 + 3 * q.shape[1]))
                table[:, 0] = t
                table[:, 1::3], table[:, 2::3], table[:, 3::3] = q, qd, qdd
                buf = io.StringIO()
                np.savetxt(buf, table, fmt="%.10g", delimiter=",")
                fh.write("".join(f"{name},{line}\n" for line in buf.getvalue().splitlines()))
                rows += n
    except OSError as exc:
        raise ConfigError(f"cannot write {path}: {exc.strerror or exc}") from None
    return rows
