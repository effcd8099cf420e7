"""A real browser as the viewer's client: a headless Chromium page connects with the foxglove.sdk.v1
subprotocol, subscribes, and receives the live gains while the simulated robot is recorded."""
from __future__ import annotations

import re
import time

import numpy as np
import pytest
from headless_browser import FOXGLOVE_PAGE_JS, HeadlessPage, find_browser

G_TRUE = np.array([2170.0, 2100.0, 2070.0])  # N/A, the simulator's drive gains


def _viewer_url(g, timeout: float = 60.0) -> str:
    t_end = time.monotonic() + timeout
    while time.monotonic() < t_end:
        g.check_alive()
        m = re.search(
            r"Foxglove view on (ws://[\d.]+:\d+)", (g.log_dir / "orthoglide_viewer.log").read_text()
        )
        if m:
            return m.group(1)
        time.sleep(0.1)
    raise AssertionError("the viewer never printed its URL")


def _wait(page: HeadlessPage, expression: str, timeout: float = 30.0):
    t_end = time.monotonic() + timeout
    while time.monotonic() < t_end:
        value = page.evaluate(expression)
        if value:
            return value
        time.sleep(0.2)
    raise AssertionError(
        f"never true in the page: {expression}; page state: {page.evaluate('window.fx')}"
    )


@pytest.mark.slow
def test_a_browser_page_receives_the_live_gains_during_a_recording(tmp_path):
    binary = find_browser()
    if binary is None:
        pytest.skip(
            "chromium-headless-shell is not installed (apt-get install -y chromium-headless-shell; "
            ".ci/run installs it when apt can reach Debian's packages)"
        )
    from orthoglide_sim.demos.graph import Graph
    from orthoglide_sim.demos.node_set import record

    with Graph(tmp_path / "logs") as g:
        g.start("orthoglide_driver", "driver", {"trajectory": "exciting", "controller": "pid"})
        g.start("orthoglide_recorder", "recorder", {"output_dir": str(tmp_path / "bags")})
        g.start("orthoglide_identification", "identification", {"bag_dir": str(tmp_path / "bags")})
        g.start("orthoglide_viewer", "viewer", {"port": 0})
        url = _viewer_url(g)
        g.wait_for_ticks()
        for node in ("orthoglide_identification", "orthoglide_viewer"):
            g.wait_for_subscriber("orthoglide/joint_states", node)
            g.wait_for_subscriber("orthoglide/current_reference", node)
        page = HeadlessPage(binary)
        try:
            page.evaluate(f"({FOXGLOVE_PAGE_JS})({url!r})")
            _wait(page, "fx.open && fx.topics.includes('/orthoglide/identification/live')")
            # the server speaks only foxglove.sdk.v1: a client of the older subprotocol is refused
            page.evaluate(f"window.old = new WebSocket({url!r}, ['foxglove.websocket.v1']); "
                          "old.onerror = () => { window.oldRefused = true; }; true")
            record(g, "unloaded", "unloaded", 0.0, 10.0, quiet=True)
            g.set_params("orthoglide_driver", payload="1.983", trajectory="exciting2")
            time.sleep(3.0)
            record(g, "loaded", "loaded", 1.983, 12.0, quiet=True)
            _wait(page, "fx.live.some((m) => m.gains.length > 0)", timeout=20.0)
            fx = page.evaluate("window.fx")
            assert page.evaluate("window.oldRefused === true")
        finally:
            page.close()
    assert fx["protocol"] == "foxglove.sdk.v1" and fx["bad"] == 0
    counts = fx["counts"]
    assert counts["/orthoglide/joint_states"] > 20 * 25  # ~50 Hz over the 25 s recorded
    assert counts["/orthoglide/recorder/status"] >= 20  # ~1 Hz while recording
    solved = [m for m in fx["live"] if m["gains"]]
    assert any(m["status"].startswith("unloaded only") for m in fx["live"])  # before the payload
    last = solved[-1]
    stamp = last["stamp"]
    # exact: BigInt, not a double
    assert int(last["log_time"]) == stamp["sec"] * 10**9 + stamp["nanosec"]
    gains = np.array([x["value"] for x in last["gains"]])
    assert [x["joint"] for x in last["gains"]] == ["q11", "q12", "q13"]
    assert np.all(np.abs(gains / G_TRUE - 1) < 0.02), gains
    for x in last["gains"]:
        assert 0 < x["sigma"] and x["low"] < x["value"] < x["high"]
        assert x["high"] - x["low"] == pytest.approx(2 * x["sigma"])
