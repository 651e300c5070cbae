"""The PUB socket: frames and scene messages out, never waiting for anyone.

A subscriber that is slow, paused in a debugger or gone must not slow the
100 Hz loop, so sends never block: the high-water mark bounds each
subscriber's queue and ZeroMQ drops for that subscriber alone when it is full.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import zmq

from stiction import protocol
from stiction.daemon.security import Guard


class Publisher:
    def __init__(self, ctx: zmq.Context[Any], endpoint: str, guard: Guard, hwm: int) -> None:
        self.sock = ctx.socket(zmq.PUB)
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

    def send(self, topic: bytes, message: Mapping[str, Any]) -> bytes:
        """Publish one message; returns the payload (kept for snapshots and tests)."""
        payload = protocol.encode(message)
        try:
            self.sock.send_multipart((topic, payload), flags=zmq.DONTWAIT, copy=True)
            self.sent += 1
        except zmq.Again:
            self.dropped += 1
        return payload

    def close(self) -> None:
        self.sock.close(linger=0)
