"""The arm tick by tick (the ros2_control stand-in's simulation) is simulate_arm's run, and its
payload can change while it runs."""
from __future__ import annotations

import numpy as np
import pytest

from orthoglide_ident.errors import ConfigError
from orthoglide_sim.arm_or_chain.session import POINT_RADIUS, ArmSession, resolve_payload
from orthoglide_sim.arms.record import simulate_arm

SECONDS = 1.5


@pytest.mark.parametrize("payload", [None, "2.0"])
def test_ticks_reproduce_simulate_arm(payload):
    """Same plant, PID, noise stream (drawn in blocks) and encoder: positions equal, currents to
    round-off (the reference is evaluated in blocks of 256 ticks instead of all at once)."""
    rec = simulate_arm(SECONDS, "ur5", payload=payload, trajectory="exciting1", seed=3)
    s = ArmSession("ur5", payload=payload, trajectory="exciting1", seed=3, noise_window_s=SECONDS)
    ticks = [s.tick() for _ in range(rec.q.shape[0])]
    assert [t.k for t in ticks] == list(range(rec.q.shape[0]))
    np.testing.assert_array_equal(np.array([t.position for t in ticks]), rec.q)
    np.testing.assert_allclose(np.array([t.current for t in ticks]), rec.v_tau, rtol=0, atol=1e-12)
    assert s.saturated == rec.saturated_ticks and s.fault is None


def test_payload_mounted_while_running_keeps_the_motion():
    s = ArmSession("ur5", trajectory="exciting1", seed=0)
    for _ in range(300):
        s.tick()
    q, qd = s.plant.q, s.plant.qd
    s.set_payload(2.5)
    np.testing.assert_array_equal(s.plant.q, q)
    np.testing.assert_array_equal(s.plant.qd, qd)
    assert s.payload.mass == 2.5 and s.payload.frame == "tool0"
    before = s.tick().current
    after = [s.tick().current for _ in range(200)]
    assert s.fault is None and np.all(np.isfinite(after))
    # the PID carries the extra weight: the currents move off the unloaded ones, smoothly
    assert np.abs(after[0] - before).max() < 0.5


def test_payload_names_and_point_masses():
    truth = ArmSession("ur5").truth
    assert resolve_payload(truth, "none") is None and resolve_payload(truth, 0) is None
    assert resolve_payload(truth, "2.0") is truth.payloads["2.0"]  # the off-centre body
    point = resolve_payload(truth, 2)  # any other mass: a point mass at the payload frame
    assert point.mass == 2.0 and point.frame == truth.arm.payload_frame
    np.testing.assert_array_equal(point.body.com, np.zeros(3))
    np.testing.assert_allclose(np.diag(point.body.inertia), 0.4 * 2.0 * POINT_RADIUS**2)
    for bad in ("heavy", -1, 50):
        with pytest.raises(ConfigError, match="payload") as e:
            resolve_payload(truth, bad)
        assert "\n" not in str(e.value)


def test_unknown_trajectory_is_a_one_line_reason():
    s = ArmSession("ur5")
    with pytest.raises(ConfigError, match="no trajectory 'zigzag' for robot ur5"):
        s.set_trajectory("zigzag", 10)


def test_a_closed_chain_runs_in_the_session_too():
    """The driver's stand-in runs the five-bar (a robot file with loops: ChainPlant, MuJoCo's
    equality-constrained loop) as it runs the UR5: tracking, no fault, the 1 kg payload mounted."""
    import numpy as np

    from orthoglide_sim.arm_or_chain.session import ArmSession
    from orthoglide_sim.chains.plant import ChainPlant

    s = ArmSession("five_bar", payload="1.0", seed=1)
    assert isinstance(s.plant, ChainPlant) and s.joint_names == ("joint_1", "joint_2")
    ticks = [s.tick() for _ in range(1500)]
    assert s.fault is None and all(t is not None for t in ticks)
    q = np.array([t.position for t in ticks])
    ref = np.array([s.reference.at(k)[0] for k in range(1500)])
    assert np.sqrt(np.mean((q - ref) ** 2)) < 1e-3  # rad: tracked
