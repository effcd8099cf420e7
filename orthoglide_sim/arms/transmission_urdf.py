"""A drive chain of one motor per joint written as ros2_control describes it: a ``<ros2_control>``
block in the URDF with one ``transmission_interface/SimpleTransmission`` per joint (issue 33).

ros2_control's SimpleTransmission (Jazzy, transmission_interface): with reduction n and joint
offset x,

    q_j = q_a / n + x,   q̇_j = q̇_a / n,   τ_j = n τ_a          (n may be negative)

so the truth's q_m = n q_j + off_m gives n = N[j, j] and x = -off_m / n. The actuators carry the
joints' names (the bags report each motor under its joint's name).

    urdf, yaml_path = write_simple_transmission_robot(folder, simple_transmission_truth())
    N, motor_offset = read_simple_transmissions(urdf.read_text(), joint_names)   # back again
"""
from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Protocol

import numpy as np
import yaml

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.model import registry
from orthoglide_sim.arms.description import ArmDescription

SIMPLE = "transmission_interface/SimpleTransmission"


class DriveChainTruth(Protocol):
    """What is read of a drive chain's truth (coupled.truth.CoupledTruth): q_m = N q + offset."""

    arm: ArmDescription
    reduction: np.ndarray  # N (n, n)
    motor_offset: np.ndarray  # (n,) rad
    actuators: tuple[str, ...]

    def motor_array(self, key: str) -> np.ndarray: ...


def ros2_control_block(truth: DriveChainTruth, name: str) -> str:
    """The ``<ros2_control>`` element of ``truth``'s drive chain; ConfigError unless N is
    diagonal (a coupled chain is not a set of SimpleTransmissions)."""
    N = truth.reduction
    if np.count_nonzero(N - np.diag(np.diag(N))):
        raise ConfigError("a SimpleTransmission per joint needs a diagonal reduction matrix")
    lines = [f'  <ros2_control name="{name}" type="system">',
             "    <hardware><plugin>mock_components/GenericSystem</plugin></hardware>"]
    for j in truth.arm.joint_names:
        lines += [
            f'    <joint name="{j}">',
            '      <command_interface name="effort"/>',
            *(f'      <state_interface name="{s}"/>' for s in ("position", "velocity", "effort")),
            "    </joint>",
        ]
    for k, j in enumerate(truth.arm.joint_names):
        n = float(N[k, k])
        x = -float(truth.motor_offset[k]) / n
        lines += [f'    <transmission name="{j}_transmission">', f"      <plugin>{SIMPLE}</plugin>",
                  f'      <actuator name="{truth.actuators[k]}" role="actuator1"/>',
                  f'      <joint name="{j}" role="joint1">',
                  f"        <mechanical_reduction>{n!r}</mechanical_reduction>",
                  f"        <offset>{x!r}</offset>", "      </joint>", "    </transmission>"]
    return "\n".join(lines + ["  </ros2_control>", ""])


def read_simple_transmissions(
    urdf_text: str, joint_names: tuple[str, ...]
) -> tuple[np.ndarray, np.ndarray]:
    """(N, motor offsets) of a URDF's SimpleTransmissions, one per joint of ``joint_names``
    (defaults n = 1, offset 0, as ros2_control's)."""
    root = ET.fromstring(urdf_text)
    n, x = {}, {}
    for tr in root.iter("transmission"):
        if (tr.findtext("plugin") or "").strip() != SIMPLE:
            raise ConfigError(f"transmission {tr.get('name')}: not a SimpleTransmission")
        joint = tr.find("joint")
        n[joint.get("name")] = float(joint.findtext("mechanical_reduction") or 1.0)
        x[joint.get("name")] = float(joint.findtext("offset") or 0.0)
    missing = [j for j in joint_names if j not in n]
    if missing:
        raise ConfigError(f"no SimpleTransmission for {', '.join(missing)}")
    red = np.array([n[j] for j in joint_names])
    return np.diag(red), -red * np.array([x[j] for j in joint_names])


def write_simple_transmission_robot(folder: str | Path, truth: DriveChainTruth,
                                    stem: str = "ur5_simple_transmission") -> tuple[Path, Path]:
    """``<stem>.urdf`` (the UR5's URDF with the ``<ros2_control>`` block) and ``<stem>.yaml``
    (ur5.yaml naming it; ``nominal_gains`` per motor, N·m/A at the shaft) in ``folder``."""
    src = registry.resolve("ur5")
    data = registry.read_yaml(src)
    text = (src.parent / str(data["description"])).resolve().read_text()
    end = text.rfind("</robot>")
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    urdf = folder / f"{stem}.urdf"
    urdf.write_text(text[:end] + ros2_control_block(truth, stem) + text[end:])
    data.update(
        name=stem, description=urdf.name, nominal_gains=truth.motor_array("nominal_gain").tolist()
    )
    out = folder / f"{stem}.yaml"
    out.write_text(
        "# The UR5 with one SimpleTransmission per joint in its URDF's <ros2_control> block\n"
        "# (orthoglide_sim.arms.transmission_urdf); nominal_gains per motor (N·m/A at the motor "
        "shaft)\n"
        + yaml.safe_dump(data, sort_keys=False, allow_unicode=True, default_flow_style=None)
    )
    return urdf, out

