"""A headless Chromium page driven over the DevTools protocol: the viewer's real-browser test.

Debian's ``chromium-headless-shell`` (``apt-get install chromium-headless-shell``; `.ci/run`
installs it when absent). The binary is started directly: the /usr/bin wrapper leaves the browser
running when it is killed. Results are read with ``Runtime.evaluate`` (``--dump-dom`` returns
before a page's WebSocket has received anything).
"""
from __future__ import annotations

import json
import re
import shutil
import subprocess
import tempfile
import time
import urllib.request
from pathlib import Path
from typing import Any

import websocket

CANDIDATES = ("/usr/lib/chromium/chromium-headless-shell", "chromium-headless-shell")


def find_browser() -> str | None:
    for c in CANDIDATES:
        path = c if Path(c).is_file() else shutil.which(c)
        if path:
            return path
    return None


class HeadlessPage:
    """One browser process with one blank page; ``evaluate(js)`` returns the value (JSON-able)."""

    def __init__(self, binary: str, timeout: float = 30.0) -> None:
        self.profile = tempfile.TemporaryDirectory(prefix="chromium-")
        self.proc = subprocess.Popen(
            [
                binary,
                "--headless",
                "--no-sandbox",
                "--disable-gpu",
                "--remote-debugging-port=0",
                "--remote-debugging-address=127.0.0.1",
                f"--user-data-dir={self.profile.name}",
                "about:blank",
            ],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
        )
        port = self._devtools_port(timeout)
        pages = json.loads(
            urllib.request.urlopen(f"http://127.0.0.1:{port}/json/list", timeout=timeout).read()
        )
        page = next(p for p in pages if p.get("type") == "page")
        self.ws = websocket.create_connection(page["webSocketDebuggerUrl"], timeout=timeout)
        self._id = 0

    def _devtools_port(self, timeout: float) -> int:
        t_end = time.monotonic() + timeout
        seen = []
        while time.monotonic() < t_end:
            line = self.proc.stderr.readline()
            if not line and self.proc.poll() is not None:
                break
            seen.append(line)
            m = re.search(r"DevTools listening on ws://[\d.]+:(\d+)/", line)
            if m:
                return int(m.group(1))
        self.close()
        raise RuntimeError("headless chromium did not start: " + "".join(seen)[-2000:])

    def evaluate(self, expression: str) -> Any:
        self._id += 1
        self.ws.send(json.dumps({"id": self._id, "method": "Runtime.evaluate",
                                 "params": {"expression": expression, "returnByValue": True}}))
        while True:
            reply = json.loads(self.ws.recv())
            if reply.get("id") == self._id:
                break
        result = reply["result"]
        if "exceptionDetails" in result:
            raise RuntimeError(f"page script failed: {result['exceptionDetails']}")
        return result["result"].get("value")

    def close(self) -> None:
        if getattr(self, "ws", None) is not None:
            self.ws.close()
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self.profile.cleanup()


# What a browser page runs: connect with the foxglove.sdk.v1 subprotocol, subscribe to every
# advertised channel, decode the binary message-data frames (opcode 0x01, u32 subscription id,
# u64 log time, JSON payload) and keep what the test reads.
FOXGLOVE_PAGE_JS = r"""
(url) => {
  const fx = window.fx = {open: false, protocol: null, closed: null, topics: [], subs: {}, counts:
  {},
                          bad: 0, live: [], last: {}};
  const ws = new WebSocket(url, ["foxglove.sdk.v1"]);
  ws.binaryType = "arraybuffer";
  ws.onopen = () => { fx.open = true; fx.protocol = ws.protocol; };
  ws.onclose = (e) => { fx.closed = e.code; };
  ws.onmessage = (ev) => {
    if (typeof ev.data === "string") {
      const m = JSON.parse(ev.data);
      if (m.op !== "advertise") return;
      const subscriptions = m.channels.map((c) => {
        const id = fx.topics.push(c.topic);
        fx.subs[id] = c.topic;
        return {id, channelId: c.id};
      });
      ws.send(JSON.stringify({op: "subscribe", subscriptions}));
      return;
    }
    const view = new DataView(ev.data);
    if (view.getUint8(0) !== 1) { fx.bad++; return; }
    const topic = fx.subs[view.getUint32(1, true)];
    const logTime = view.getBigUint64(5, true);
    const msg = JSON.parse(new TextDecoder().decode(new Uint8Array(ev.data, 13)));
    fx.counts[topic] = (fx.counts[topic] || 0) + 1;
    fx.last[topic] = msg;
    if (topic.endsWith("/identification/live"))
      fx.live.push({log_time: logTime.toString(), stamp: msg.header.stamp, status: msg.status,
      gains: msg.gains});
  };
  return true;
}
"""
