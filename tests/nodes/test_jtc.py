"""The ctc node's outlet to a joint_trajectory_controller: the JointTrajectory bytes rclpy would
send, the feed-forward in the controller's units, one update ahead, messages that start in the
past."""
from __future__ import annotations

import numpy as np
import pytest

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.nodes._jtc import TrajectoryOutlet, encode_joint_trajectory

NAMES = ("shoulder_pan_joint", "b", "elbow", "wrist_1", "w2", "wrist_3_joint")
T0 = 1_796_000_000 * 10**9 + 123_456_000


def _deserialize(raw: bytes):
    from rclpy.serialization import deserialize_message
    from trajectory_msgs.msg import JointTrajectory

    return deserialize_message(raw, JointTrajectory)


@pytest.mark.parametrize("n", [1, 2, 7, 60])
def test_encoding_is_what_rclpy_serialises(n):
    from rclpy.serialization import serialize_message

    rng = np.random.default_rng(n)
    arrays = rng.normal(size=(4, n, len(NAMES)))
    times = np.arange(n) * 1_000_000 + (n > 1) * 999_999_000  # crosses a second
    raw = encode_joint_trajectory(T0, NAMES, times, *arrays)
    msg = _deserialize(raw)
    assert (
        msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec == T0 and msg.header.frame_id == ""
    )
    assert tuple(msg.joint_names) == NAMES and len(msg.points) == n
    for k, p in enumerate(msg.points):
        for field, arr in zip(("positions", "velocities", "accelerations", "effort"), arrays):
            np.testing.assert_array_equal(getattr(p, field), arr[k])
        assert p.time_from_start.sec * 10**9 + p.time_from_start.nanosec == times[k]
    theirs = serialize_message(msg)  # same layout; rclpy leaves the padding bytes uninitialised
    assert len(theirs) == len(raw) and _deserialize(theirs) == msg


def _feed(outlet: TrajectoryOutlet, first: int, n: int, gains):
    stamps = T0 + (first + np.arange(n)) * 1_000_000
    ref = (
        np.stack([np.full((n, 6), k, float) for k in range(3)], axis=1)
        + (first + np.arange(n))[:, None, None]
    )
    v_ff = 0.1 * (first + np.arange(n))[:, None] * np.ones(6)
    return outlet.message(stamps, ref, v_ff, gains), stamps, ref, v_ff


def test_effort_units_and_the_one_update_shift():
    nominal, gains = (
        np.array([13.0, 13, 13, 9.3, 9.3, 9.3]),
        np.array([13.5, 12.6, 13.4, 8.9, 9.7, 9.1]),
    )
    for effort, scale in (("nominal", nominal), ("torque", gains), ("current", np.ones(6))):
        outlet = TrajectoryOutlet(NAMES, effort, nominal, overlap=100)
        raw, stamps, ref, v_ff = _feed(outlet, 0, 10, gains)
        msg = _deserialize(raw)
        assert len(msg.points) == 10
        eff = np.array([p.effort for p in msg.points])
        # point k carries tick k - 1's feed-forward: the JTC adds the trajectory sampled one
        # update ahead (command_next_) to the command of the update it runs
        np.testing.assert_allclose(eff[1:], v_ff[:-1] * scale)
        np.testing.assert_allclose(eff[0], v_ff[0] * scale)
        np.testing.assert_array_equal(np.array([p.positions for p in msg.points]), ref[:, 0])
        np.testing.assert_array_equal(np.array([p.accelerations for p in msg.points]), ref[:, 2])


def test_a_transmission_sends_the_motors_efforts_as_joint_efforts():
    """Per-motor feed-forward, per-joint points: e_j = Nᵀ (scale x v_m), which a hardware's
    transmission (τ_m = N⁻ᵀ τ_j) turns back into each motor's effort; the coupled wrist."""
    from orthoglide_ident.model.transmission import Transmission

    N = np.array([[32, 0, 0, 0, 0, 0], [0, 32, 0, 0, 0, 0], [0, 0, 45, 0, 0, 0],
                  [0, 0, 0, -48, 0, 0], [0, 0, 0, 0, 45, 0], [0, 0, 0, 0, 32, 32]], float)
    t = Transmission(NAMES, tuple(f"m{k}" for k in range(6)), N, np.zeros(6))
    nominal, gains = np.array([0.13, 0.13, 0.1, 0.1, 0.1, 0.1]), np.full(6, 0.11)
    outlet = TrajectoryOutlet(NAMES, "nominal", nominal, overlap=100,
                              to_joint_effort=t.to_joint_effort)
    raw, _, _, v_ff = _feed(outlet, 0, 10, gains)
    eff = np.array([p.effort for p in _deserialize(raw).points])
    np.testing.assert_allclose(eff[1:], (v_ff[:-1] * nominal) @ N, rtol=1e-12)
    np.testing.assert_allclose(t.to_actuator_effort(eff[1:]) / nominal, v_ff[:-1], rtol=1e-12)
    assert eff[1, 4] == pytest.approx(45 * v_ff[0, 4] * 0.1 + 32 * v_ff[0, 5] * 0.1)


def test_messages_repeat_what_was_sent_so_they_start_in_the_past():
    outlet = TrajectoryOutlet(NAMES, "nominal", np.ones(6), overlap=25)
    _feed(outlet, 0, 10, np.ones(6))
    _feed(outlet, 10, 10, np.ones(6))
    raw, stamps, _, v_ff = _feed(outlet, 20, 10, np.ones(6))
    msg = _deserialize(raw)
    assert len(msg.points) == 25  # the newest 25 ticks: 15 already sent, 10 new
    assert msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec == T0 + 5 * 1_000_000
    t = [p.time_from_start.nanosec for p in msg.points]
    assert t == [k * 1_000_000 for k in range(25)]
    assert msg.points[15].effort[0] == pytest.approx(v_ff[0, 0] - 0.1)  # tick 19's, across messages
    # a gap in the setpoints: the old points do not lead into the new ones, they are not repeated
    raw, stamps, _, _ = _feed(outlet, 40, 10, np.ones(6))
    assert len(_deserialize(raw).points) == 10


def test_bad_outlet_parameters():
    with pytest.raises(ConfigError, match="trajectory_effort: nominal | torque | current"):
        TrajectoryOutlet(NAMES, "newton", np.ones(6))
    with pytest.raises(ConfigError, match="trajectory_overlap"):
        TrajectoryOutlet(NAMES, "torque", np.ones(6), overlap=0)
