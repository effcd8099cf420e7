"""excite run against the ros2_control stand-in's follow_joint_trajectory action and the recorder:
a run that succeeds leaves a complete bag; a tolerance violation aborts the goal and leaves the bag
tagged incomplete with the reason; Ctrl-C cancels; a goal with other joints is rejected. Short
trajectories (2 s); nothing here depends on the machine's speed (the stand-in's time is its
ticks)."""
from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import yaml

sys.path.insert(0, str(Path(__file__).parent))
from trajectories import write_small  # noqa: E402

from orthoglide_ident import bags  # noqa: E402
from orthoglide_ident._install_ament import ROOT  # noqa: E402
from orthoglide_ident.bags.tags import CONDITION_KEY, FRAME_KEY, INCOMPLETE_KEY, MASS_KEY
from orthoglide_ident.excite import plan as plan  # noqa: E402
from orthoglide_sim.demos.graph import Graph  # noqa: E402

STANDIN = "ros2_control_standin"
CLI = Path(sys.prefix) / "bin" / "orthoglide-ident"
ACTION = "joint_trajectory_controller/follow_joint_trajectory"


@pytest.fixture(scope="module")
def graph(tmp_path_factory):
    from sensor_msgs.msg import JointState

    tmp = tmp_path_factory.mktemp("standin")
    config = ROOT / "config" / "ros2_control.yaml"
    with Graph(tmp / "logs") as g:
        g.start(
            STANDIN,
            "driver",
            {"robot": "ur5", "trajectory": "hold", "drop_rate": 0.0, "rt_priority": 0},
            params_file=config,
        )
        g.start(
            "orthoglide_recorder", "recorder", {"output_dir": str(tmp / "bags")}, params_file=config
        )
        g.wait_for_messages(JointState, "joint_states", 1, timeout=60)
        g.wait_for_subscriber("/joint_states", "orthoglide_recorder")
        g.tmp = tmp
        yield g


def _excite(g, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [str(CLI), "excite", "run", *args], capture_output=True, text=True, timeout=300, env=g.env
    )


def _tags(bag_path: str) -> dict:
    return yaml.safe_load((Path(bag_path) / "metadata.yaml").read_text())[
        "rosbag2_bagfile_information"
    ]["custom_data"]


def test_a_run_that_succeeds_leaves_a_complete_bag(graph):
    traj = write_small(graph.tmp / "t.yaml")
    out = _excite(graph, str(traj), "--condition", "loaded", "--name", "ok")
    assert out.returncode == 0, out.stderr
    assert "moving to the start pose" in out.stderr and "loaded run complete" in out.stderr
    custom = _tags(graph.tmp / "bags" / "ok")
    assert custom[CONDITION_KEY] == "loaded" and custom[MASS_KEY] == "2"
    assert custom[FRAME_KEY] == "tool0" and INCOMPLETE_KEY not in custom
    data = bags.read_bag(graph.tmp / "bags" / "ok")
    assert data.tags.condition == "loaded"


def test_a_tolerance_violation_aborts_and_tags_the_bag_incomplete(graph):
    traj = write_small(graph.tmp / "t2.yaml", seed=1)
    out = _excite(
        graph, str(traj), "--condition", "unloaded", "--path-tolerance", "1e-5", "--name", "bad"
    )
    assert out.returncode == 1, out.stderr
    assert "PATH_TOLERANCE_VIOLATED" in out.stderr and "Traceback" not in out.stderr
    reason = _tags(graph.tmp / "bags" / "bad")[INCOMPLETE_KEY]
    assert (
        reason.startswith("unloaded run aborted: PATH_TOLERANCE_VIOLATED")
        and "violated its path tolerance" in reason
    )
    assert bags.bag_info(graph.tmp / "bags" / "bad").incomplete == reason  # read back, kept
    assert any("tagged incomplete" in w for w in bags.read_bag(graph.tmp / "bags" / "bad").warnings)


def test_a_trajectory_for_another_robot_is_refused_before_anything_moves(graph):
    five = write_small(
        graph.tmp / "five.yaml", robot="five_bar", joints=("joint_1", "joint_2"), centre=(2.1, 1.04)
    )
    out = _excite(graph, str(five), "--condition", "unloaded", "--robot", "ur5")
    assert out.returncode == 2 and "is for robot 'five_bar', not 'ur5'" in out.stderr
    assert len(out.stderr.strip().splitlines()) == 1


def test_other_joints_are_rejected_and_ctrl_c_cancels(graph):
    from orthoglide_ident.excite.action_client import goal_message, send_goal
    from orthoglide_ident.excite.trajectory import load_trajectory

    traj = load_trajectory(write_small(graph.tmp / "t3.yaml"))
    pts = plan.excitation_points(traj, "unloaded")
    wrong = plan.Points(tuple(f"j{i}" for i in range(6)), pts.times, pts.q, pts.qd, pts.qdd)
    # graph spins it
    out = send_goal(graph.node, ACTION, goal_message(wrong), pts.duration, spin=time.sleep)
    assert out.status == "rejected"
    from orthoglide_ident.excite.runner import ExcitationRunner, RunOptions

    q_now = ExcitationRunner(graph.node, time.sleep, print, RunOptions()).current_position(
        pts.joint_names
    )
    # a long, slow move
    slow = plan.approach_points(q_now, pts.q[0], np.full(6, 0.01), pts.joint_names)
    state = {"accepted": False, "cancelled": False, "pressed": False}

    def spin(t):  # one Ctrl-C once the goal runs (its first feedback)
        time.sleep(t)
        if state["accepted"] and not state["pressed"]:
            state["pressed"] = True
            raise KeyboardInterrupt

    out = send_goal(graph.node, ACTION, goal_message(slow), slow.duration, spin=spin,
                    on_feedback=lambda fb: state.update(accepted=True),
                    on_interrupt=lambda: state.update(cancelled=True))
    assert out.status == "interrupted" and state["cancelled"]
    log_path = graph.tmp / "logs" / f"{STANDIN}.log"
    t_end = time.monotonic() + 60  # the stand-in logs the cancel it acknowledged (a hang bound)
    while "goal canceled" not in (log := log_path.read_text()) and time.monotonic() < t_end:
        time.sleep(0.05)
    assert "goal rejected: goal joints" in log and "goal canceled" in log


def test_the_excitation_node_runs_and_cancels_as_a_service(graph):
    from std_srvs.srv import Trigger

    from orthoglide_msgs.srv import RunExcitation

    traj = write_small(graph.tmp / "t4.yaml", periods=3, seed=4)
    graph.start("orthoglide_excitation", "excitation", {"robot": "ur5"})
    res = graph.call(
        RunExcitation,
        "orthoglide/excitation/run",
        trajectory=str(traj),
        condition="unloaded",
        payload_mass=0.0,
        name="by_service",
    )
    assert res.success, res.message
    assert res.bag_path.endswith("by_service") and INCOMPLETE_KEY not in _tags(res.bag_path)
    bad = graph.call(
        RunExcitation,
        "orthoglide/excitation/run",
        trajectory=str(graph.tmp / "none.yaml"),
        condition="unloaded",
        payload_mass=0.0,
        name="",
    )
    assert not bad.success and "none.yaml" in bad.message and "\n" not in bad.message
    # a run cancelled by the service: started from a second client while the first waits
    import threading

    answers: list = []
    t = threading.Thread(target=lambda: answers.append(graph.call(
        RunExcitation, "orthoglide/excitation/run", trajectory=str(traj), condition="loaded",
        payload_mass=1.0, name="cancelled")))
    t.start()
    bag = graph.tmp / "bags" / "cancelled"
    # until the recording has begun (after the move to the start pose) and half a second of it
    # is written: the cancel comes mid-run
    graph.wait_for_status(lambda s: s.recording and s.bag_path.endswith("cancelled")
                          and s.ticks_written >= 500, timeout=120.0)
    assert graph.call(Trigger, "orthoglide/excitation/cancel").success
    t.join(timeout=120)
    assert answers and not answers[0].success and "cancel requested" in answers[0].message
    assert _tags(bag)[INCOMPLETE_KEY].startswith("loaded run interrupted: cancel requested")
