"""Records of the ros2_control stand-in without ROS: the bytes it would publish, and their bags.

    recs = standin_records(seconds=20.0, drop_rate=2e-4)
    recs["unloaded"].messages       # [(stamp, joint_states bytes | None, dynamic_joint_states bytes
    | None)]
    write_record_bag(path, recs["loaded"])   # as the recorder writes them (both topics, their
    drops)
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from orthoglide_ident import bags
from orthoglide_ident.bags.topics import DYNAMIC_JOINT_STATE_TYPE, JOINT_STATE_TYPE
from orthoglide_sim.arm_or_chain.session import ArmSession
from orthoglide_sim.common.broadcaster import BroadcasterLayout, TickDropper, broadcast

ROBOT = "ur5_mount"
PAYLOAD_KG = 2.5
START_NS = 1_796_000_000 * 10**9
GRIPPER = "gripper_finger_joint"


@dataclass
class StandinRecord:
    condition: str
    payload_mass: float
    messages: list[tuple[int, bytes | None, bytes | None]]
    layout: BroadcasterLayout
    dropped: dict[str, int]
    g_tau: np.ndarray  # the plant's true gains, in the arm's joint order
    joint_names: tuple[str, ...]  # the arm's joints (the model's order)


def standin_records(seconds: float = 20.0, drop_rate: float = 2e-4) -> dict[str, StandinRecord]:
    """An unloaded run (exciting1) and one with a PAYLOAD_KG point mass at the mount (exciting2),
    each seeded on its own, 100 s apart in stamps."""
    out = {}
    for i, (name, payload, trajectory) in enumerate((("unloaded", None, "exciting1"),
                                                     ("loaded", PAYLOAD_KG, "exciting2"))):
        s = ArmSession(ROBOT, payload=payload, trajectory=trajectory, seed=i)
        layout = BroadcasterLayout.of(s.joint_names, [GRIPPER], "shuffled", seed=0)
        dropper = TickDropper(drop_rate, seed=i)
        msgs = broadcast(s, int(round(seconds * 1000)), layout, dropper, START_NS + i * 100 * 10**9)
        out[name] = StandinRecord(
            name,
            0.0 if payload is None else PAYLOAD_KG,
            msgs,
            layout,
            dict(dropper.dropped),
            s.truth.drive_array("g_tau"),
            s.joint_names,
        )
    return out


def write_record_bag(path: Path, rec: StandinRecord, dynamic: bool = True) -> Path:
    """The record's messages in a tagged bag, in publish order, with the drops (``dynamic``
    False: /joint_states only, the effort then carries the current)."""
    tags = bags.BagTags.checked(rec.condition, rec.payload_mass)
    with bags.BagWriter(path, tags) as w:
        js = w.add_topic("/joint_states", JOINT_STATE_TYPE)
        djs = (
            w.add_topic("/dynamic_joint_states", DYNAMIC_JOINT_STATE_TYPE) if dynamic else None
        )
        for stamp, a, b in rec.messages:
            if a is not None:
                w.write(js, a, stamp)
            if b is not None and djs is not None:
                w.write(djs, b, stamp)
    return path
