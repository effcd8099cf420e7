"""The node set live, as `make demo` runs it: record through the services, identify live and from
the bags, feed a CTC started late, close the loop over DDS (paper Table 4's point)."""
from __future__ import annotations

import time

import numpy as np
import pytest

from orthoglide_sim.demos.graph import Graph  # noqa: E402
from orthoglide_sim.demos.node_set import identify, record, tracking_errors  # noqa: E402

G_TRUE = np.array([2170.0, 2100.0, 2070.0])


def _record_ticks(g, name: str, ticks: int) -> str:
    """A loaded recording of ``ticks`` ticks written (robot time, whatever the machine's load),
    as node_set.record's service calls; its bag path."""
    from std_srvs.srv import Trigger

    from orthoglide_msgs.srv import StartRecording

    res = g.call(
        StartRecording,
        "orthoglide/recorder/start",
        condition="loaded",
        payload_mass=1.983,
        name=name,
    )
    assert res.success, res.message
    g.wait_for_status(
        lambda s: s.recording and s.bag_path == res.bag_path and s.ticks_written >= ticks,
        timeout=120.0,
    )
    stop = g.call(Trigger, "orthoglide/recorder/stop")
    assert stop.success, stop.message
    return res.bag_path


def _rel(a, b) -> float:
    a, b = np.asarray(a, float), np.asarray(b, float)
    return float(np.max(np.abs(a - b) / np.maximum(np.abs(b), 1e-12)))


@pytest.mark.slow
def test_record_identify_live_and_control_over_ros(tmp_path):
    from orthoglide_ident._install_ament import ROOT

    with Graph(tmp_path / "logs") as g:
        g.start("orthoglide_driver", "driver", {"trajectory": "exciting", "controller": "pid"})
        g.start("orthoglide_recorder", "recorder", {"output_dir": str(tmp_path / "bags")},
                params_file=ROOT / "config/recorder.yaml")
        # live = offline to 1e-6 for the same equations: without the lag columns, whose live
        # instrument averages only the previous periods (tests/identify/live/test_live.py: within σ)
        g.start("orthoglide_identification", "identification",
                {"bag_dir": str(tmp_path / "bags"), "lag_model": "off"})
        g.wait_for_ticks(timeout=120.0)  # the driver is publishing (a hang bound, not a figure)
        # live identification gets only what is published after its subscription matched: a
        # recording started before that begins without it (the feed says so)
        for topic in ("orthoglide/joint_states", "orthoglide/current_reference"):
            g.wait_for_subscriber(topic, "orthoglide_identification")
            g.wait_for_log("orthoglide_identification", f"live identification: receiving /{topic}")
        bags = [record(g, "unloaded", "unloaded", 0.0, 12.0, quiet=True)]
        g.set_params("orthoglide_driver", payload="1.983", trajectory="exciting2")
        g.wait_for_robot_time(3.0)  # the new trajectory blends in (2 s of robot time)
        bags.append(record(g, "loaded", "loaded", 1.983, 12.0, quiet=True))
        # live identification has folded in the loaded recording (its feed says so when done)
        g.wait_for_log("orthoglide_identification", f": {bags[-1]} done;")

        # the live estimate went out while recording, and says what it lacked before the payload
        statuses = [m.status for m in g.live]
        assert any(s.startswith("unloaded only") for s in statuses), statuses
        assert g.live[-1].drive_gains and g.live[-1].loaded_seconds > 8, g.live[-1]

        live = identify(g, []).parameters  # no bag named: the live data
        offline = identify(g, bags).parameters
        assert _rel(live.drive_gains, G_TRUE) < 0.01
        assert _rel(live.drive_gains, offline.drive_gains) < 1e-6
        values = dict(zip(offline.names, offline.values))
        assert _rel(live.values, [values[n] for n in live.names]) < 1e-6

        # a ctc node started now gets the latched parameters and feeds the driver's CTC
        g.start("orthoglide_ctc", "ctc")
        g.wait_for_feedforward()
        g.set_params("orthoglide_driver", trajectory="test2", controller="pid")
        g.wait_for_robot_time(3.0)  # the trajectory blends in, the PID settles
        e_pid = tracking_errors(_record_ticks(g, "pid", 2000))
        g.set_params("orthoglide_driver", controller="ctc")
        g.wait_for_robot_time(1.0)  # the CTC takes over and settles
        before = g.driver_counters()
        e_ctc = tracking_errors(_record_ticks(g, "ctc", 2000))
        after = g.driver_counters()
    rms_pid, rms_ctc = (np.sqrt(np.mean(e**2, axis=0)) for e in (e_pid, e_ctc))
    assert len(e_ctc) > 1500
    fresh, held = (
        int(after[k]) - int(before[k]) for k in ("feedforward_fresh", "feedforward_missing")
    )
    # Table 4's point, CTC over DDS as good as in-process (>20x better than the PID), holds
    # when the feed-forward comes in time; on a machine too loaded for the ctc to keep up at
    # 1 kHz the driver holds stale ones (it counts them) and the CTC is still far better than
    # the PID (measured 10x with 2 other test runs on 2 cores): the bar follows the count, not
    # the machine's speed
    bar = 20 if held <= 0.01 * (fresh + held) else 4
    assert np.all(rms_pid / rms_ctc > bar), (rms_pid * 1e6, rms_ctc * 1e6, fresh, held)


def test_ctc_without_parameters_publishes_nothing_and_says_so(tmp_path):
    from orthoglide_ident.nodes.ctc import CTCNode  # noqa: F401  (importable: a module-level class)
    from orthoglide_sim.demos.graph import GraphError

    with Graph(tmp_path / "logs") as g:
        g.start("orthoglide_driver", "driver", {"trajectory": "test1"})
        g.start("orthoglide_ctc", "ctc")
        g.wait_for_ticks()
        with pytest.raises(GraphError):
            g.wait_for_feedforward(ticks=1, timeout=4.0)
        log = (tmp_path / "logs" / "orthoglide_ctc.log").read_text()
    assert "no feed-forward until they arrive" in log


@pytest.mark.slow
def test_each_node_stopped_for_a_second_while_recording_loses_nothing(tmp_path):
    """SIGSTOP of the driver, the recorder, the identification and the ctc, 1 s each in turn, while
    recording under the CTC: the bag has every tick from its first to its last on both topics,
    the stop says 0 missing; the driver's counters show its own stall (late ticks) and the ctc's
    (feed-forwards held); live identification gets every tick (no lost-tick warning) and ends
    with the recording."""
    import signal

    from orthoglide_ident import bags
    from orthoglide_ident._install_ament import ROOT

    with Graph(tmp_path / "logs") as g:
        g.start("orthoglide_driver", "driver", {"trajectory": "exciting", "controller": "pid"})
        g.start("orthoglide_recorder", "recorder", {"output_dir": str(tmp_path / "bags")},
                params_file=ROOT / "config/recorder.yaml")
        g.start("orthoglide_identification", "identification", {"bag_dir": str(tmp_path / "bags"),
                                                                "lag_model": "off"})
        g.wait_for_ticks()
        # latched for the ctc
        identify(g, [str(ROOT / "bags" / "unloaded"), str(ROOT / "bags" / "loaded")])
        g.start("orthoglide_ctc", "ctc", params_file=ROOT / "config/ctc.yaml")
        g.wait_for_feedforward()
        g.wait_for_subscriber("orthoglide/joint_states", "orthoglide_identification")
        g.set_params("orthoglide_driver", controller="ctc")
        before = g.driver_counters()
        n_live = len(g.live)
        from std_srvs.srv import Trigger

        from orthoglide_msgs.srv import StartRecording

        res = g.call(
            StartRecording,
            "orthoglide/recorder/start",
            condition="unloaded",
            payload_mass=0.0,
            name="stalls",
        )
        assert res.success, res.message
        for name in (
            "orthoglide_driver",
            "orthoglide_recorder",
            "orthoglide_identification",
            "orthoglide_ctc",
        ):
            # a second of the recording going on, then this node stopped for a second: the
            # durations are the experiment's (a stall), not a wait for something
            time.sleep(1.0)
            g.procs[name].send_signal(signal.SIGSTOP)
            time.sleep(1.0)
            g.procs[name].send_signal(signal.SIGCONT)
        # the recording goes on after the last stall: a second more of ticks written
        written = g.wait_for_status(lambda s: s.recording).ticks_written
        g.wait_for_status(
            lambda s: s.recording and s.ticks_written >= written + 1000, timeout=120.0
        )
        stop = g.call(Trigger, "orthoglide/recorder/stop")
        after = g.driver_counters()
        assert stop.success, stop.message
        data = bags.read_bag(res.bag_path)
        seconds = len(data.joint_states.stamps_ns) / 1000
        t_end = time.monotonic() + 30  # live identification folds in the recording's last ticks
        while not (g.live[n_live:] and g.live[-1].unloaded_seconds > 0.9 * seconds):
            assert time.monotonic() < t_end, [
                (m.unloaded_seconds, m.status) for m in g.live[n_live:]
            ]
            time.sleep(0.2)
        g.check_alive()  # every node went on
        live = g.live[n_live:]
    js, cr = data.joint_states.stamps_ns, data.current_reference.stamps_ns
    np.testing.assert_array_equal(js, cr)
    # every tick first to last; and the bag spans the recording: the driver's tick count moved
    # by len(js) plus at most the two counter reads' delays (diagnostics once a second, <= 1000
    # ticks each) and the calls' — whatever the machine's speed (a loaded one ticks late)
    published = int(after["ticks"]) - int(before["ticks"])
    assert bags.info.find_gaps(js).missing == 0 and published - 3000 <= len(js) <= published, (
        len(js),
        published,
    )
    assert "0 missing on /orthoglide/current_reference" in stop.message, stop.message
    assert "0 missing on /orthoglide/joint_states" in stop.message, stop.message
    assert (
        f"wrote {len(js)} /orthoglide/current_reference, {len(js)} /orthoglide/joint_states"
        in stop.message
    )
    assert int(after["late"]) - int(before["late"]) >= 500  # the driver's own second
    # the ctc's second
    assert int(after["feedforward_missing"]) - int(before["feedforward_missing"]) >= 500
    warnings = [w for m in live for w in m.warnings]
    assert not [w for w in warnings if "lost" in w or "missing" in w], warnings
