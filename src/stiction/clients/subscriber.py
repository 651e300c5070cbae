"""Subscribe to a running stictiond and read its frames as Python objects.

ZeroMQ already reconnects a SUB socket when the daemon comes back; what the
caller must not see is everything else a restart brings: ticks starting from
zero again, a half-sent queue, a few malformed messages. This class absorbs
those (and counts them in ``stats``) so a restart shows up only as a gap.

Conflation is done here, not with ZMQ_CONFLATE: that option cannot carry
multipart messages and keeps one message for *all* topics, so two devices
would overwrite each other. Here the latest frame is kept per device.
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Iterable, Iterator, Sequence
from typing import TYPE_CHECKING, Any, TypeVar

import zmq
from zmq.utils.monitor import parse_monitor_message

from stiction import protocol
from stiction.clients import control as control_mod
from stiction.clients.curve import CurveKeys
from stiction.clients.messages import Frame, Message
from stiction.clients.stream import StreamState, SubscriberStats, normalise_kinds, subscriptions
from stiction.errors import StictionError

if TYPE_CHECKING:
    from stiction.clients.columns import ContactTable

S = TypeVar("S", bound="zmq.Socket[Any]")

DRAIN_LIMIT = 100_000
"""Most messages read in one go when conflating, so a flood cannot starve the caller."""


def configure_sub(sock: zmq.Socket[Any], hwm: int, heartbeat: float) -> None:
    """Socket options every stiction subscriber wants, sync or async."""
    sock.setsockopt(zmq.LINGER, 0)
    sock.setsockopt(zmq.RCVHWM, hwm)
    # Reconnect quickly after a daemon restart, back off if it stays away.
    sock.setsockopt(zmq.RECONNECT_IVL, 100)
    sock.setsockopt(zmq.RECONNECT_IVL_MAX, 2000)
    # ZMTP heartbeats notice a daemon whose machine vanished without closing TCP.
    if heartbeat > 0:
        sock.setsockopt(zmq.HEARTBEAT_IVL, int(heartbeat * 1000))
        sock.setsockopt(zmq.HEARTBEAT_TIMEOUT, int(heartbeat * 3000))
    # Refuse absurd messages in the transport, before they are buffered.
    sock.setsockopt(zmq.MAXMSGSIZE, 4 * protocol.MAX_MESSAGE_BYTES)


def open_sub(
    ctx: zmq.Context[S],
    endpoints: Sequence[str],
    topics: Iterable[bytes],
    *,
    hwm: int,
    heartbeat: float,
    curve: CurveKeys | None,
) -> tuple[S, S]:
    """A configured SUB socket connected to ``endpoints``, and its monitor socket.

    Shared by Subscriber and AsyncSubscriber: an asyncio context gives asyncio
    sockets, a plain one plain sockets. Raises StictionError (socket closed)
    when an endpoint cannot be connected.
    """
    sock = ctx.socket(zmq.SUB)
    configure_sub(sock, hwm, heartbeat)
    if curve is not None:
        curve.apply(sock)
    for topic in topics:
        sock.setsockopt(zmq.SUBSCRIBE, topic)
    for ep in endpoints:
        try:
            sock.connect(ep)
        except zmq.ZMQError as exc:
            sock.close()
            raise StictionError(f"cannot connect to {ep!r}: {exc}") from exc
    return sock, sock.get_monitor_socket(zmq.EVENT_CONNECTED | zmq.EVENT_DISCONNECTED)


def close_sub(sock: zmq.Socket[Any], monitor: zmq.Socket[Any]) -> None:
    """Close a socket from open_sub and its monitor, at once (no linger)."""
    with contextlib.suppress(zmq.ZMQError):
        sock.disable_monitor()
    monitor.close(linger=0)
    sock.close(linger=0)


class Subscriber:
    """Frames (and optionally scene messages) from one or more daemons.

    ``endpoint``: a PUB endpoint or several (frames of all are merged).
    ``devices``: only these devices' frames (default: all).
    ``kinds``: ``"frame"`` and/or ``"scene"``.
    ``conflate``: deliver only the newest unread frame of each device.
    ``control``: the daemon's control endpoint; when given, the subscriber
    asks it for a snapshot after subscribing (ZeroMQ's clone pattern) so the
    current scene and frames arrive at once and no frame is seen twice.
    ``curve``: keys for a daemon that serves the network (CurveKeys.from_files).
    """

    def __init__(
        self,
        endpoint: str | Sequence[str] = protocol.DEFAULT_PUB,
        *,
        devices: Iterable[str] | None = None,
        kinds: Iterable[str] = ("frame",),
        conflate: bool = False,
        control: str | None = None,
        context: zmq.Context[Any] | None = None,
        hwm: int = 10_000,
        heartbeat: float = 1.0,
        snapshot_timeout: float = 1.0,
        curve: CurveKeys | None = None,
    ) -> None:
        kinds_t = normalise_kinds(kinds)
        devs = None if devices is None else tuple(devices)
        self.endpoints = [endpoint] if isinstance(endpoint, str) else list(endpoint)
        self._state = StreamState(kinds_t, devs, conflate)
        self._ctx = context or zmq.Context.instance()
        self._sock: zmq.Socket[Any]
        self._monitor: zmq.Socket[Any]
        self._sock, self._monitor = open_sub(
            self._ctx,
            self.endpoints,
            subscriptions(kinds_t, devs),
            hwm=hwm,
            heartbeat=heartbeat,
            curve=curve,
        )
        self._ready: list[Message] = []
        if control is not None:
            reply = control_mod.request(
                control, "snapshot", timeout=snapshot_timeout, context=self._ctx, curve=curve
            )
            self._ready = self._state.snapshot_messages(reply)

    @property
    def stats(self) -> SubscriberStats:
        return self._state.stats

    @property
    def socket(self) -> zmq.Socket[Any]:
        """The underlying SUB socket, e.g. to register in your own zmq.Poller."""
        return self._sock

    def recv(self, timeout: float | None = None) -> Message | None:
        """The next message, or None when ``timeout`` seconds pass without one.

        Raises ProtocolError when the daemon speaks a newer schema.
        """
        if self._ready:
            return self._ready.pop(0)
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            msg = self._next_available()
            if msg is not None:
                return msg
            if deadline is None:
                self._sock.poll(None)
                continue
            remaining = deadline - time.monotonic()
            if remaining <= 0 or not self._sock.poll(max(1, int(remaining * 1000))):
                msg = self._next_available()
                return msg

    def _connection_events(self) -> None:
        while True:
            try:
                raw = self._monitor.recv_multipart(zmq.NOBLOCK)
            except zmq.Again:
                return
            self._state.connection_event(parse_monitor_message(raw)["event"])

    def _next_available(self) -> Message | None:
        state = self._state
        self._connection_events()
        if state.conflate:
            for _ in range(DRAIN_LIMIT):
                try:
                    parts = self._sock.recv_multipart(zmq.NOBLOCK)
                except zmq.Again:
                    break
                state.keep_latest(parts)
            return state.pop_pending()
        while True:
            try:
                parts = self._sock.recv_multipart(zmq.NOBLOCK)
            except zmq.Again:
                return None
            msg = state.accept(parts)
            if msg is not None:
                return msg

    def __iter__(self) -> Iterator[Message]:
        while True:
            msg = self.recv()
            if msg is not None:
                yield msg

    def frames(
        self, count: int | None = None, seconds: float | None = None, idle: float | None = None
    ) -> Iterator[Frame]:
        """Frames only, until ``count`` frames, ``seconds`` elapsed, or ``idle``
        seconds without any frame (whichever comes first; all None: forever)."""
        n = 0
        end = None if seconds is None else time.monotonic() + seconds
        while count is None or n < count:
            wait = idle
            if end is not None:
                left = end - time.monotonic()
                if left <= 0:
                    return
                wait = left if wait is None else min(wait, left)
            msg = self.recv(wait)
            if msg is None:
                if idle is not None and (end is None or time.monotonic() < end):
                    return
                continue
            if isinstance(msg, Frame):
                n += 1
                yield msg

    def collect(
        self, count: int | None = None, seconds: float | None = None, idle: float | None = None
    ) -> ContactTable:
        """Read frames as in `frames` and return them as numpy columns."""
        from stiction.clients.columns import ContactTable

        return ContactTable.from_frames(self.frames(count, seconds, idle))

    def close(self) -> None:
        close_sub(self._sock, self._monitor)

    def __enter__(self) -> Subscriber:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
