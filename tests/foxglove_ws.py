"""A Foxglove WebSocket client (subprotocol foxglove.sdk.v1) for the viewer's tests and bench.

Speaks what a Foxglove app does: reads serverInfo and advertise (JSON text), subscribes to channels
by topic, and decodes message-data frames (binary: opcode 0x01, u32 subscription id, u64 log time
ns, payload — JSON here).
"""
from __future__ import annotations

import json
import struct
import time
from dataclasses import dataclass

import websocket

SUBPROTOCOL = "foxglove.sdk.v1"
_FRAME = struct.Struct("<BIQ")


@dataclass
class Frame:
    topic: str
    log_time: int  # ns
    message: dict


class FoxgloveClient:
    """One connection; ``subscribe(topics)`` then ``frames(seconds)``."""

    def __init__(self, url: str, timeout: float = 10.0) -> None:
        self.ws = websocket.create_connection(url, subprotocols=[SUBPROTOCOL], timeout=timeout)
        self.channels: dict[str, dict] = {}  # topic -> advertised channel
        self.subscriptions: dict[int, str] = {}  # subscription id -> topic
        self.status: list[dict] = []  # the server's status messages (e.g. about our garbage)
        self.server_info = json.loads(self.ws.recv())
        assert self.server_info["op"] == "serverInfo", self.server_info
        self.pending: list[Frame] = []
        t_end = time.monotonic() + timeout
        while not self.channels and time.monotonic() < t_end:
            self._receive(t_end - time.monotonic())

    def _receive(self, timeout: float) -> None:
        self.ws.settimeout(max(timeout, 0.01))
        try:
            data = self.ws.recv()
        except websocket.WebSocketTimeoutException:
            return
        if isinstance(data, str):
            msg = json.loads(data)
            if msg["op"] == "advertise":
                self.channels.update({c["topic"]: c for c in msg["channels"]})
            elif msg["op"] == "status":
                self.status.append(msg)
            return
        op, sub, log_time = _FRAME.unpack_from(data)
        if op == 0x01 and sub in self.subscriptions:
            self.pending.append(
                Frame(self.subscriptions[sub], log_time, json.loads(data[_FRAME.size :]))
            )

    def subscribe(self, topics: list[str] | None = None) -> None:
        """Subscribe to ``topics`` (all advertised when None)."""
        subs = []
        for topic in topics or list(self.channels):
            sid = len(self.subscriptions) + 1
            self.subscriptions[sid] = topic
            subs.append({"id": sid, "channelId": self.channels[topic]["id"]})
        self.ws.send(json.dumps({"op": "subscribe", "subscriptions": subs}))

    def frames(self, seconds: float, until=None) -> list[Frame]:
        """Frames received for ``seconds`` (or until ``until(frames)`` is true)."""
        t_end = time.monotonic() + seconds
        while time.monotonic() < t_end and not (until and until(self.pending)):
            self._receive(t_end - time.monotonic())
        out, self.pending = self.pending, []
        return out

    def close(self) -> None:
        self.ws.close()
