"""What the stand-in publishes per update is what joint_state_broadcaster publishes: both messages
from one update with one stamp, the hardware's order, an extra joint without current; its drops."""
from __future__ import annotations

import numpy as np
import pytest

from orthoglide_ident import bags
from orthoglide_ident.errors import ConfigError
from orthoglide_sim.arm_or_chain.session import ArmTick
from orthoglide_sim.common.broadcaster import BroadcasterLayout, TickDropper

ARM = ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint",
       "wrist_3_joint")
GRIPPER = "gripper_finger_joint"


def _tick() -> ArmTick:
    rng = np.random.default_rng(7)
    return ArmTick(42, rng.normal(size=6), rng.normal(size=6), rng.normal(size=6))


def test_hardware_order_is_shuffled_with_the_extra_joint_inside():
    lay = BroadcasterLayout.of(ARM, [GRIPPER], "shuffled", seed=0)
    assert sorted(lay.names) == sorted(ARM + (GRIPPER,))
    assert lay.names[:6] != ARM[:6] and lay.names[-1] != GRIPPER  # no URDF order, gripper not last
    assert BroadcasterLayout.of(ARM, [GRIPPER], "shuffled", seed=0).names == lay.names  # seeded
    assert BroadcasterLayout.of(ARM, [GRIPPER], "urdf").names == ARM + (GRIPPER,)
    given = ",".join(reversed(ARM + (GRIPPER,)))
    assert BroadcasterLayout.of(ARM, [GRIPPER], given).names == tuple(reversed(ARM + (GRIPPER,)))
    for order, extra in (("elbow_joint,wrist_1_joint", [GRIPPER]), ("shuffled", ["elbow_joint"])):
        with pytest.raises(ConfigError):
            BroadcasterLayout.of(ARM, extra, order)


def test_one_update_two_messages_one_stamp():
    lay = BroadcasterLayout.of(ARM, [GRIPPER], "shuffled", seed=1)
    tick, stamp = _tick(), 1_796_000_000_123_000_000
    js, djs = lay.encode(stamp, tick)
    store = bags.topics.typestore()
    m = store.deserialize_cdr(js, bags.topics.JOINT_STATE_TYPE)
    d = store.deserialize_cdr(djs, bags.topics.DYNAMIC_JOINT_STATE_TYPE)
    for msg in (m, d):
        assert msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec == stamp
        assert msg.header.frame_id == ""
    assert tuple(m.name) == lay.names == tuple(d.joint_names)
    for slot, name in enumerate(lay.names):
        iv = d.interface_values[slot]
        # at rest, no current interface: effort NaN, as the broadcaster fills it
        if name == GRIPPER:
            assert (m.position[slot], m.velocity[slot]) == (0.0, 0.0) and np.isnan(m.effort[slot])
            assert list(iv.interface_names) == ["position", "velocity"]
            continue
        j = ARM.index(name)
        assert (m.position[slot], m.velocity[slot], m.effort[slot]) == (
            tick.position[j], tick.velocity[j], tick.current[j])
        assert list(iv.interface_names) == ["position", "velocity", "current"]
        assert list(iv.values) == [tick.position[j], tick.velocity[j], tick.current[j]]


def test_per_update_bytes_equal_the_bulk_encoders():
    """The stand-in's fast single-message path writes what the bag writer's encoders write."""
    lay = BroadcasterLayout.of(ARM, [GRIPPER], "shuffled", seed=2)
    tick, stamp = _tick(), 5 * 10**9 + 17
    js, djs = lay.encode(stamp, tick)
    col = lay.arm_column

    def slots(v, extra):
        return np.array([[v[c] if c >= 0 else extra for c in col]])

    st = np.array([stamp])
    p, v, c = slots(tick.position, 0.0), slots(tick.velocity, 0.0), slots(tick.current, np.nan)
    assert js == bags.encoding.encode_joint_states(lay.names, st, p, v, c)[0].tobytes()
    assert djs == bags.encoding.encode_dynamic_joint_states(lay.names, lay.interfaces, st, {
        "position": p, "velocity": v, "current": c})[0].tobytes()


def test_drops_are_seeded_per_topic_and_counted():
    d = TickDropper(0.02, seed=3)
    keeps = np.array([d.keep() for _ in range(5000)])
    lost = (~keeps).sum(axis=0)
    assert list(lost) == [d.dropped["joint_states"], d.dropped["dynamic_joint_states"]]
    assert 50 < lost.min() and lost.max() < 150  # 2 % of 5000, each topic on its own
    assert np.count_nonzero(~keeps[:, 0] & ~keeps[:, 1]) < lost.min()
    again = TickDropper(0.02, seed=3)
    assert all(again.keep() == tuple(k) for k in keeps)
    assert not (~np.array([TickDropper(0.0).keep() for _ in range(1000)])).any()
    with pytest.raises(ConfigError, match="drop_rate"):
        TickDropper(1.0)
