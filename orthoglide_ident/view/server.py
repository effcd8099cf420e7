"""The Foxglove WebSocket server of the live view (foxglove-sdk; subprotocol ``foxglove.sdk.v1``).

foxglove-sdk's server runs on threads of its own (Rust): ``log`` serialises the message and puts
it in each subscribed client's queue, ``BACKLOG`` messages deep, dropping the oldest data when a
client does not keep up. A slow or stalled client therefore loses frames; the caller never waits
for it. A client that sends garbage gets a status message back and stays connected; one that
disconnects is forgotten. Clients connect with "Open connection" -> ``ws://host:port`` in the
Foxglove app (or Lichtblick).
"""
from __future__ import annotations

import collections
import json
import threading
from typing import Any

from foxglove.websocket import ServerListener

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.view.schemas import SCHEMAS

BACKLOG = 512  # messages queued per client: ~2 s of the viewer's ~250 msg/s, then the oldest go
SERVER_NAME = "orthoglide_ident viewer"


class _Listener(ServerListener):
    """foxglove-sdk's callbacks (on its threads): a new subscription sets ``new``, so that the
    caller sends the latched channels' last messages again. The SDK calls every callback of its
    ServerListener (an unsubscribe on each disconnect): the base class's are no-ops."""

    def __init__(self) -> None:
        super().__init__()
        self.new = threading.Event()

    def on_subscribe(self, client: Any, channel: Any) -> None:
        self.new.set()


class ViewServer:
    """JSON channels named after topics, served on ``host:port`` (port 0: any free port).

    Raises ConfigError with a one-line reason when the port cannot be had (in use, no permission,
    an address that is not this machine's).
    """

    def __init__(self, host: str, port: int, backlog: int = BACKLOG) -> None:
        import foxglove

        if not 0 <= port <= 65535:
            raise ConfigError(f"parameter port: {port} is not a TCP port (0-65535)")
        self.context = foxglove.Context()  # its own: nothing else logged in the process reaches it
        self.listener = _Listener()
        try:
            self.server = foxglove.start_server(
                name=SERVER_NAME,
                host=host,
                port=port,
                context=self.context,
                server_listener=self.listener,
                message_backlog_size=backlog,
            )
        except (RuntimeError, OSError, ValueError, TypeError) as exc:
            reason = str(exc).removeprefix("FoxgloveError: ").splitlines()[0]
            raise ConfigError(
                f"cannot serve the Foxglove view on {host}:{port}: {reason}"
                + (
                    " (another viewer or program uses it: set the port parameter)"
                    if "in use" in reason
                    else ""
                )
            ) from None
        self.host, self.port = host, self.server.port
        self.channels: dict[str, Any] = {}
        self.sent: collections.Counter[str] = collections.Counter()  # messages logged per topic

    @property
    def url(self) -> str:
        return f"ws://{self.host}:{self.port}"

    def add(self, topic: str, kind: str) -> None:
        """A channel named ``topic`` (e.g. the resolved ROS name) with the schema of ``kind`` (a
        key of ``schemas.SCHEMAS``)."""
        import foxglove

        self.channels[topic] = foxglove.Channel(topic, schema=SCHEMAS[kind], context=self.context)

    def log(self, topic: str, msg: dict[str, Any], log_time_ns: int) -> None:
        """Queue ``msg`` for every client subscribed to ``topic`` (never waits for one)."""
        self.channels[topic].log(
            json.dumps(msg, allow_nan=False).encode(), log_time=int(log_time_ns)
        )
        self.sent[topic] += 1

    def close(self) -> None:
        for ch in self.channels.values():
            ch.close()
        self.server.stop()
