"""The PUB socket: frames and scene messages out, never waiting for anyone.

A subscriber that is slow, paused in a debugger or gone must not slow the
100 Hz loop, so sends never block: the high-water mark bounds each
subscriber's queue and ZeroMQ drops for that subscriber alone when it is full.

The socket is an XPUB, which behaves as a PUB for sending but also hands the
daemon each subscription as it arrives: `wait_subscribers` uses that so a
virtual-clock replay can hold its first tick until its readers are
subscribed (a PUB silently drops what it sends before a subscription lands).

`Sink` is what the loop needs of a publisher. The daemon builds this ZeroMQ
one unless it is given another: a test gives it a `Recorder` and reads the
exact payloads the loop published, with no socket and no patching.
"""

from __future__ import annotations

import contextlib
from collections.abc import Mapping
from typing import Any, Protocol

import zmq

from stiction import protocol
from stiction.daemon.security import Guard


class Sink(Protocol):
    """What the daemon's loop publishes through.

    A sink may also have ``warm(topic, message)``: the send path run on a
    message that goes nowhere, which the loop calls during its spin before a
    deadline (stiction.daemon.warm). It is optional; a sink without it is
    simply not warmed. Likewise optional: ``send_payload(topic, payload)``
    and ``warm_payload(topic, payload)``, the same with a message encoded
    before, which the loop's prepared tick (stiction.daemon.prepare) uses;
    without them it sends the message through ``send``."""

    endpoint: str
    sent: int
    dropped: int

    def send(self, topic: bytes, message: Mapping[str, Any]) -> bytes: ...
    def wait_subscribers(self, n: int, timeout: float) -> int: ...
    def close(self) -> None: ...


class Publisher:
    """The ZeroMQ XPUB publisher (the daemon's default Sink)."""

    def __init__(self, ctx: zmq.Context[Any], endpoint: str, guard: Guard, hwm: int) -> None:
        self.sock = ctx.socket(zmq.XPUB)
        self.sock.setsockopt(zmq.XPUB_VERBOSE, 1)  # every subscriber's, not just the first
        self.sock.sndhwm = hwm
        self.sock.linger = 0
        try:
            guard.bind(self.sock, endpoint, "pub")
        except BaseException:
            self.sock.close(linger=0)  # a leaked socket would block the context's term()
            raise
        self.endpoint = self.sock.last_endpoint.decode() if self.sock.last_endpoint else endpoint
        self.sent = 0
        self.dropped = 0
        # A PUB socket with no peer: libzmq drops what it is given, after
        # running the same send path as the real socket's.
        self._void = ctx.socket(zmq.PUB)
        self._void.linger = 0

    def send(self, topic: bytes, message: Mapping[str, Any]) -> bytes:
        """Publish one message; returns the payload (kept for snapshots and tests)."""
        payload = protocol.encode(message)
        self.send_payload(topic, payload)
        return payload

    def send_payload(self, topic: bytes, payload: bytes) -> None:
        """Publish a message encoded before (the loop's prepared tick)."""
        try:
            self.sock.send_multipart((topic, payload), flags=zmq.DONTWAIT, copy=True)
            self.sent += 1
        except zmq.Again:
            self.dropped += 1

    def warm(self, topic: bytes, message: Mapping[str, Any]) -> None:
        """Encode and send `message` to no one: brings the send path's code
        and data into the caches before a deadline; counts nothing."""
        self.warm_payload(topic, protocol.encode(message))

    def warm_payload(self, topic: bytes, payload: bytes) -> None:
        """Send an encoded message to no one (`warm` without the encoding)."""
        with contextlib.suppress(zmq.Again):  # a PUB drops rather than blocks; in case
            self._void.send_multipart((topic, payload), flags=zmq.DONTWAIT, copy=True)

    def wait_subscribers(self, n: int, timeout: float) -> int:
        """Block until `n` frame subscribers are in, or `timeout` seconds pass; returns how many.

        A subscription counts when frames match it (its topic is empty or
        starts with "frame"): a client's scene-only subscription does not.
        """
        import time

        seen = 0
        deadline = time.monotonic() + timeout
        while seen < n:
            left = deadline - time.monotonic()
            if left <= 0 or not self.sock.poll(int(left * 1000) + 1):
                break
            note = self.sock.recv()
            topic = note[1:]
            # b"\x01" + topic subscribes (b"\x00" + topic unsubscribes)
            frames = protocol.TOPIC_FRAME.startswith(topic) or topic.startswith(
                protocol.TOPIC_FRAME
            )
            if note[:1] == b"\x01" and frames:
                seen += 1
        return seen

    def close(self) -> None:
        self.sock.close(linger=0)
        self._void.close(linger=0)


class Recorder:
    """A Sink that keeps every (topic, payload) it is given, in order.

    The payload is the encoded message, byte for byte what the ZeroMQ
    publisher would have sent. Subscribers are taken as present at once.
    """

    def __init__(self, endpoint: str = "recorder") -> None:
        self.endpoint = endpoint
        self.sent = 0
        self.dropped = 0
        self.messages: list[tuple[bytes, bytes]] = []
        self.warmed = 0

    def warm(self, topic: bytes, message: Mapping[str, Any]) -> None:
        """Encode and keep nothing (only count): the ZeroMQ publisher's warm."""
        protocol.encode(message)
        self.warmed += 1

    def warm_payload(self, topic: bytes, payload: bytes) -> None:
        self.warmed += 1

    def send(self, topic: bytes, message: Mapping[str, Any]) -> bytes:
        payload = protocol.encode(message)
        self.send_payload(topic, payload)
        return payload

    def send_payload(self, topic: bytes, payload: bytes) -> None:
        """Keep a payload encoded before: the ZeroMQ publisher's send_payload."""
        self.messages.append((topic, payload))
        self.sent += 1

    def wait_subscribers(self, n: int, timeout: float) -> int:
        return n

    def close(self) -> None:
        pass
