"""A robot file whose payload frame sits off the last joint's axis: where a weighed mass goes.

The recorder tags a loaded bag with the payload's mass only, and the identification then takes it
as a point mass at the robot's payload frame (live and offline). On a 6-axis arm that frame must
not lie on the last joint's axis (tool0 does): a mass on that axis puts no torque on the last
joint, whose gain is then not scaled by the payload (IDIM-TLS refuses: s_c / s_(c-1) near 1).

    path = write_mounted_robot(folder, "ur5", offset=(0.06, -0.04, 0.05))

writes ``<name>_mount.urdf`` (the robot's URDF with a massless link ``payload_mount`` fixed to its
payload frame at ``offset``, m) and ``<name>_mount.yaml`` (the robot's YAML naming it, the same
name, joints and nominal gains, payload_frame ``payload_mount``) into ``folder``, and returns the
YAML's path: give it as the ``robot`` of the stand-in and of the identification. A real payload
does the same with a link at its centre of mass, or with the tag's payload_com.
"""
from __future__ import annotations

from pathlib import Path

import yaml

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.model import registry

MOUNT_LINK = "payload_mount"
DEFAULT_OFFSET = (0.06, -0.04, 0.05)  # m in the payload frame: 7 cm off its z axis, 5 cm along it


def write_mounted_robot(folder: str | Path, robot: str = "ur5",
                        offset: tuple[float, float, float] = DEFAULT_OFFSET) -> Path:
    """``robot`` (a bundled name or robot YAML) with the payload mount; the new YAML's path."""
    path = registry.resolve(robot)
    if path is None or path.suffix.lower() not in (".yaml", ".yml"):
        raise ConfigError(
            f"robot {robot!r}: give a robot YAML (or a bundled name) with a URDF description"
        )
    data = registry.read_yaml(path)
    urdf_path = (path.parent / str(data.get("description", ""))).resolve()
    text = urdf_path.read_text()
    frame = data.get("payload_frame")
    end = text.rfind("</robot>")
    if not frame or end < 0:
        raise ConfigError(f"robot file {path}: needs a URDF description and a payload_frame")
    x, y, z = (float(v) for v in offset)
    mount = (f'  <link name="{MOUNT_LINK}" />\n  <joint name="{MOUNT_LINK}_joint" type="fixed">\n'
             f'    <parent link="{frame}" />\n    <child link="{MOUNT_LINK}" />\n'
             f'    <origin rpy="0 0 0" xyz="{x!r} {y!r} {z!r}" />\n  </joint>\n')
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    stem = f"{path.stem}_mount"
    (folder / f"{stem}.urdf").write_text(text[:end] + mount + text[end:])
    data.update(description=f"{stem}.urdf", payload_frame=MOUNT_LINK)
    out = folder / f"{stem}.yaml"
    out.write_text(
        f"# {path.name} with a payload mount {offset} m from {frame} "
        "(orthoglide_sim.arms.payload_mount)\n"
        + yaml.safe_dump(data, sort_keys=False)
    )
    return out
