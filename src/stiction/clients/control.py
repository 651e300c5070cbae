"""Talking to the daemon's control endpoint without ever hanging.

A REQ socket that loses its reply is stuck for good (ZeroMQ's "lazy pirate"
problem), so every request uses a fresh socket, a bounded wait and linger 0:
a daemon that is down costs the caller one timeout, nothing more.
"""

from __future__ import annotations

import asyncio
from typing import Any

import zmq
import zmq.asyncio

from stiction import protocol
from stiction.clients.curve import CurveKeys
from stiction.errors import StictionError


class ControlUnavailable(StictionError):
    """Nothing answered on the control endpoint in time."""


def _socket(
    ctx: zmq.Context[Any], endpoint: str, curve: CurveKeys | None, timeout: float
) -> zmq.Socket[Any]:
    sock: zmq.Socket[Any] = ctx.socket(zmq.REQ)
    sock.setsockopt(zmq.LINGER, 0)
    # A REQ socket whose CURVE handshake was refused has no peer to send to,
    # and send() then blocks for ever: bound the send as well as the reply.
    sock.setsockopt(zmq.SNDTIMEO, max(1, int(timeout * 1000)))
    if curve is not None:
        curve.apply(sock)
    sock.connect(endpoint)
    return sock


def request(
    endpoint: str,
    op: protocol.ControlOp,
    *,
    timeout: float = 1.0,
    context: zmq.Context[Any] | None = None,
    curve: CurveKeys | None = None,
    **args: Any,
) -> dict[str, Any]:
    """Send one request and return the decoded reply.

    Raises ControlUnavailable when nothing answers within ``timeout`` seconds and
    ProtocolError when the daemon answers with an error.
    """
    ctx = context or zmq.Context.instance()
    sock = _socket(ctx, endpoint, curve, timeout)
    try:
        try:
            sock.send(protocol.make_request(op, **args))
        except zmq.Again:
            raise ControlUnavailable(_unsent(op, endpoint, timeout, curve)) from None
        if not sock.poll(int(timeout * 1000)):
            raise ControlUnavailable(f"no reply to {op!r} from {endpoint} within {timeout:g} s")
        return protocol.parse_reply(sock.recv())
    finally:
        sock.close()


def _unsent(op: str, endpoint: str, timeout: float, curve: CurveKeys | None) -> str:
    why = " (is the server key right, and is this client's key authorised?)" if curve else ""
    return f"could not send {op!r} to {endpoint} within {timeout:g} s{why}"


async def request_async(
    endpoint: str,
    op: protocol.ControlOp,
    *,
    timeout: float = 1.0,
    context: zmq.asyncio.Context | None = None,
    curve: CurveKeys | None = None,
    **args: Any,
) -> dict[str, Any]:
    """The asyncio form of `request`, for the web bridge and AsyncSubscriber."""
    ctx = context or zmq.asyncio.Context.instance()
    sock = ctx.socket(zmq.REQ)
    sock.setsockopt(zmq.LINGER, 0)
    if curve is not None:
        curve.apply(sock)
    sock.connect(endpoint)
    try:
        try:
            await asyncio.wait_for(sock.send(protocol.make_request(op, **args)), timeout)
        except (TimeoutError, zmq.Again):
            raise ControlUnavailable(_unsent(op, endpoint, timeout, curve)) from None
        if not await sock.poll(int(timeout * 1000)):
            raise ControlUnavailable(f"no reply to {op!r} from {endpoint} within {timeout:g} s")
        return protocol.parse_reply(await sock.recv())
    finally:
        sock.close()
