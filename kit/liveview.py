"""A live view of a robot's topics in Foxglove (or any client of the Foxglove WebSocket
protocol), served while the robot runs.

:class:`LiveView` starts a Foxglove WebSocket server (the ``foxglove-sdk`` package) and
publishes kit messages on it as a ROS 2 robot's bridge would: each topic a channel with
``cdr`` messages and its ``ros2msg`` schema (the ROS 2 Humble definitions, as ``rosbags``
writes them into an MCAP file), so Foxglove Studio decodes them as ROS messages and shows the
scan, the transforms, the map, the plan, the particles and the costmaps in its 3D panel.
The server advertises the ``time`` capability and sends the robot's clock (simulation time
for the simulator), so Foxglove follows it.

Latched topics (:data:`kit.bag.LATCHED_TOPICS`: ``/map``, ``/tf_static``, the costmaps, …)
are sent again to a client that subscribes after they were published, as ROS's transient
local durability would.

Open ``ws://127.0.0.1:8765`` in Foxglove Studio (Open connection → Foxglove WebSocket). The
server (foxglove-sdk 0.30) accepts the WebSocket subprotocol ``foxglove.sdk.v1`` — the same
messages as ``foxglove.websocket.v1`` under its current name, as ``foxglove_bridge`` 3.x —
and refuses a client that offers only the old name.

``foxglove`` is imported only when a view starts: ``import kit`` stays light. It comes with
the kit's ``live`` extra (``pip install -e '.[live]'``; ``make demo ARGS=--live`` installs it),
not with the labs' install: without it a view says how to get it.
"""

from __future__ import annotations

import threading
import time
from typing import Any

from kit import msgs, rosconv

__all__ = ["DEFAULT_ADDRESS", "LiveView", "parse_address"]

DEFAULT_ADDRESS = ("127.0.0.1", 8765)
"""Where the view listens by default: the loopback address and Foxglove's default port."""


def parse_address(text: str) -> tuple[str, int]:
    """``HOST:PORT``, ``:PORT`` or ``PORT`` → ``(host, port)`` (host 127.0.0.1 by default).

    Raises
    ------
    ValueError
        Not a port number from 0 to 65535 (0: any free port).
    """
    host, _, port = text.rpartition(":")
    host = host.strip("[]") or DEFAULT_ADDRESS[0]
    if not port.isdigit() or not 0 <= int(port) <= 65535:
        raise ValueError(f"a live view's address is HOST:PORT or PORT (0 to 65535, e.g. "
                         f"127.0.0.1:8765); got {text!r}")
    return host, int(port)


class _Subscriptions:
    """Subscriptions to latched topics, for :meth:`LiveView.publish` to answer; filled by the
    server's listener (on the server's thread)."""

    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.pending: set[str] = set()
        self.clients = 0


def _listener(subscriptions: _Subscriptions) -> Any:
    from foxglove.websocket import ServerListener

    class Listener(ServerListener):
        def on_subscribe(self, client: Any, channel: Any) -> None:
            with subscriptions.lock:
                subscriptions.pending.add(channel.topic)
                subscriptions.clients += 1

        def on_unsubscribe(self, client: Any, channel: Any) -> None:
            with subscriptions.lock:
                subscriptions.clients -= 1

    return Listener()


class LiveView:
    """A Foxglove WebSocket server publishing kit messages as ROS 2 CDR.

    Parameters
    ----------
    host, port
        Where to listen (port 0: any free port; :attr:`port` says which).
    name
        The server's name, shown by Foxglove.

    Examples
    --------
    >>> # view = LiveView()                   # ws://127.0.0.1:8765
    >>> # view.publish("/scan", scan, time_ns)
    >>> # view.close()
    """

    def __init__(self, host: str = DEFAULT_ADDRESS[0], port: int = DEFAULT_ADDRESS[1],
                 name: str = "kit") -> None:
        try:
            import foxglove
            from foxglove.websocket import Capability
        except ImportError:
            raise ValueError("the live view needs the kit's live extra (foxglove-sdk, 53 MB, "
                             "left out of the labs' install): in the kit's folder run "
                             "`.venv/bin/pip install -e '.[live]'`, or `make demo "
                             "ARGS=--live`, which installs it") from None
        from kit.bag import LATCHED_TOPICS

        self._foxglove = foxglove
        self._latched_topics = frozenset(LATCHED_TOPICS)
        self._context = foxglove.Context()
        self._listener = _Subscriptions()
        try:
            self.server = foxglove.start_server(
                name=name, host=host, port=port, capabilities=[Capability.Time],
                server_listener=_listener(self._listener), context=self._context)
        except RuntimeError as exc:
            raise ValueError(f"cannot serve the live view on {host}:{port}: {exc}; choose "
                             f"another address") from None
        self.host = host
        self._channels: dict[str, Any] = {}
        self._types: dict[str, str] = {}
        self._latched: dict[str, tuple[bytes, int]] = {}
        self._last_time = -1
        self.count = 0

    @property
    def port(self) -> int:
        """The port the server listens on."""
        return int(self.server.port)

    @property
    def url(self) -> str:
        """``ws://host:port``, what Foxglove Studio connects to."""
        return f"ws://{self.host}:{self.port}"

    def _channel(self, topic: str, typename: str) -> Any:
        if topic in self._channels:
            if self._types[topic] != typename:
                raise TypeError(f"topic {topic} carries {self._types[topic]}, not {typename}")
            return self._channels[topic]
        definition, _ = rosconv.typestore().generate_msgdef(typename, ros_version=2)
        schema = self._foxglove.Schema(name=typename, encoding="ros2msg",
                                       data=definition.encode("utf-8"))
        channel = self._foxglove.Channel(topic, message_encoding="cdr", schema=schema,
                                         context=self._context)
        self._channels[topic], self._types[topic] = channel, typename
        return channel

    def publish(self, topic: str, message: msgs.Message, time_ns: int) -> None:
        """Send ``message`` on ``topic`` to the subscribed clients, stamped ``time_ns`` (the
        robot's clock); the clock advances to it."""
        data = rosconv.serialize_cdr(message)
        self._channel(topic, message.ROS_TYPE).log(data, log_time=int(time_ns))
        self.count += 1
        if topic in self._latched_topics:
            self._latched[topic] = (data, int(time_ns))
        self.resend_latched()
        if time_ns > self._last_time:
            self._last_time = int(time_ns)
            self.server.broadcast_time(int(time_ns))

    def resend_latched(self) -> None:
        """Send each latched topic's last message again if a client subscribed to it since."""
        with self._listener.lock:
            pending, self._listener.pending = self._listener.pending, set()
        for topic in pending & self._latched.keys():
            data, stamp = self._latched[topic]
            self._channels[topic].log(data, log_time=stamp)

    @property
    def clients(self) -> int:
        """Subscriptions open now (a client holds one per topic it shows)."""
        with self._listener.lock:
            return self._listener.clients

    def hold(self, seconds: float | None = None) -> None:
        """Keep serving (latched topics to new clients) for ``seconds``, or until Ctrl-C."""
        end = None if seconds is None else time.monotonic() + seconds
        try:
            while end is None or time.monotonic() < end:
                self.resend_latched()
                time.sleep(0.1)
        except KeyboardInterrupt:
            pass

    def close(self) -> None:
        """Stop the server."""
        self.server.stop()

    def __enter__(self) -> LiveView:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
