"""An imported CSV log identifies exactly as the recorded bag it came from (the simulated UR5)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from orthoglide_ident import bags
from orthoglide_ident.bags.csv_import import ColumnMap, import_csv
from orthoglide_ident.identify import identify
from orthoglide_ident.model.registry import load_robot
from orthoglide_sim.arm_or_chain.bags import write_record
from orthoglide_sim.arms.record import simulate_arm

RUNS = (("unloaded", None, "exciting1", 0), ("loaded_2kg", "2.0", "exciting2", 1))


@pytest.fixture(scope="module")
def recorded(tmp_path_factory) -> tuple[Path, list[Path]]:
    d = tmp_path_factory.mktemp("ur5")
    return d, [write_record(d / name, simulate_arm(12.0, "ur5", payload=payload,
                                                    trajectory=traj, seed=seed))
               for name, payload, traj, seed in RUNS]


def export_csv(bag: Path, path: Path, effort_scale: np.ndarray | float = 1.0) -> Path:
    """A bag's stamps (ns), positions and efforts as the CSV a logger would write."""
    data = bags.read_bag(bag)
    assert np.array_equal(data.positions.stamps_ns, data.current.stamps_ns)
    names = data.positions.names
    cols = [data.positions.stamps_ns.astype(float), *data.positions.position.T,
            *(data.current.current * effort_scale).T]
    header = ["t"] + [f"{j}.q" for j in names] + [f"{j}.effort" for j in names]
    with open(path, "w") as f:
        f.write(",".join(header) + "\n")
        np.savetxt(f, np.column_stack(cols), fmt="%.17g", delimiter=",")
    return path


def imported(src: Path, csv: Path, out: Path, unit: str) -> Path:
    tags = bags.read_bag(src).tags
    cmap = ColumnMap(time_unit="ns", effort_unit=unit, condition=tags.condition,
                     payload_mass=tags.payload_mass, payload_frame=tags.payload_frame,
                     payload_com=tags.payload_com, payload_inertia=tags.payload_inertia)
    return import_csv([csv], out, cmap).bag


def summary(res) -> tuple[np.ndarray, np.ndarray]:
    return (np.array([g.value for g in res.drive_gains]),
            np.array([p.value for p in res.parameters]))


def test_an_imported_record_identifies_as_the_recorded_bag(recorded, tmp_path):
    d, recs = recorded
    robot = load_robot("ur5")
    gains, chi = summary(identify([str(b) for b in recs], model=robot))
    amps = [imported(b, export_csv(b, tmp_path / f"{b.name}.csv"), tmp_path / f"{b.name}_A", "A")
            for b in recs]
    g_a, chi_a = summary(identify([str(b) for b in amps], model=robot))
    # the same numbers, bit for bit
    assert np.array_equal(g_a, gains) and np.array_equal(chi_a, chi)
    # the same log in N·m (current x nominal gain), tagged a torque: the same gains
    torques = [imported(b, export_csv(b, tmp_path / f"{b.name}_nm.csv", robot.nominal_gains),
                        tmp_path / f"{b.name}_Nm", "N·m") for b in recs]
    g_t, chi_t = summary(identify([str(b) for b in torques], model=robot))
    assert np.allclose(g_t, gains, rtol=1e-9) and np.allclose(chi_t, chi, rtol=1e-6, atol=1e-9)
