"""Talking to the daemon's control endpoint without ever hanging.

A REQ socket that loses its reply is stuck for good (ZeroMQ's "lazy pirate"
problem), so every request uses a fresh socket, a bounded wait and linger 0:
a daemon that is down costs the caller one timeout, nothing more.
"""

from __future__ import annotations

from typing import Any

import zmq
import zmq.asyncio

from stiction import protocol
from stiction.clients.curve import CurveKeys
from stiction.errors import StictionError


class ControlUnavailable(StictionError):
    """Nothing answered on the control endpoint in time."""


def _socket(ctx: zmq.Context[Any], endpoint: str, curve: CurveKeys | None) -> zmq.Socket[Any]:
    sock: zmq.Socket[Any] = ctx.socket(zmq.REQ)
    sock.setsockopt(zmq.LINGER, 0)
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
    sock = _socket(ctx, endpoint, curve)
    try:
        sock.send(protocol.make_request(op, **args))
        if not sock.poll(int(timeout * 1000)):
            raise ControlUnavailable(f"no reply to {op!r} from {endpoint} within {timeout:g} s")
        return protocol.parse_reply(sock.recv())
    finally:
        sock.close()


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
        await sock.send(protocol.make_request(op, **args))
        if not await sock.poll(int(timeout * 1000)):
            raise ControlUnavailable(f"no reply to {op!r} from {endpoint} within {timeout:g} s")
        return protocol.parse_reply(await sock.recv())
    finally:
        sock.close()
