"""The control endpoint: one REP socket, answered between ticks.

A small thread owns the REP socket and blocks on it, so an idle daemon
spends no wake-ups on control. Each request is handed to the loop through a
queue and answered there at the next tick boundary (`serve_pending`), so a
request sees a consistent state and never races the tick. Every request gets
exactly one reply (the REP rule); anything malformed gets an error reply and
is counted, and the daemon carries on.

This module is only the transport: it decodes a request into (op, args)
and hands them to an op table (daemon/ops.py), which says what each op does.
What is slow or touches the file system -- the op table's `prepare`, e.g.
reading and compiling a scene for `set_scene` -- runs on the control thread
before the request is queued; the loop thread only runs the prepared swap or
answers a query. A request larger than
protocol.MAX_MESSAGE_BYTES still gets a reply naming the limit; only one
larger than TRANSPORT_MAX_BYTES is cut off by ZeroMQ before it is read.
"""

from __future__ import annotations

import logging
import queue
import threading
from collections.abc import Callable
from typing import Any, Protocol

import zmq

from stiction import protocol
from stiction.daemon.security import Guard
from stiction.errors import ProtocolError, StictionError

log = logging.getLogger("stiction.daemon.control")

TRANSPORT_MAX_BYTES = 64 * protocol.MAX_MESSAGE_BYTES
"""ZeroMQ drops a peer whose message exceeds this without a reply; between
MAX_MESSAGE_BYTES and this a request is received and refused in words."""


class Handler(Protocol):
    """An op table (daemon/ops.py's OpTable): what the transport hands requests to."""

    def prepare(
        self, op: protocol.ControlOp, args: dict[str, Any]
    ) -> Callable[[], protocol.Reply] | None: ...
    def answer(self, op: protocol.ControlOp, args: dict[str, Any]) -> protocol.Reply: ...


class ControlServer:
    def __init__(
        self,
        ctx: zmq.Context[Any],
        endpoint: str,
        guard: Guard,
        ops: Handler,
        on_request: Callable[[], None] = lambda: None,
    ) -> None:
        self.sock = ctx.socket(zmq.REP)
        self.sock.linger = 0
        self.sock.setsockopt(zmq.MAXMSGSIZE, TRANSPORT_MAX_BYTES)
        try:
            guard.bind(self.sock, endpoint, "control")
        except BaseException:
            self.sock.close(linger=0)
            raise
        self.endpoint = self.sock.last_endpoint.decode() if self.sock.last_endpoint else endpoint
        self.ops = ops
        self._on_request = on_request
        """Called after a request is queued: wakes an idle loop to answer it."""
        self.requests = 0
        self.errors = 0
        self._inbox: queue.SimpleQueue[_Pending] = queue.SimpleQueue()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="control", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        sock = self.sock
        try:
            while not self._stop.is_set():
                if not sock.poll(250):
                    continue
                payload = sock.recv()
                pending = _Pending(payload)
                pending.prepared = self._prepare(payload)
                self._inbox.put(pending)
                self._on_request()
                while not pending.done.wait(0.25):
                    if self._stop.is_set():
                        sock.send(protocol.error_reply("stictiond is stopping"))
                        return
                sock.send(pending.reply)
        except zmq.ContextTerminated:
            pass
        finally:
            sock.close(linger=0)

    def has_pending(self) -> bool:
        return not self._inbox.empty()

    def serve_pending(self) -> None:
        """Answer every request that has arrived (loop thread only)."""
        inbox = self._inbox
        while not inbox.empty():
            pending = inbox.get_nowait()
            pending.reply = self.handle(pending.payload, pending.prepared)
            pending.done.set()

    def _prepare(self, payload: bytes) -> _Prepared | None:
        """The slow part of a changing request, done off the tick thread; None if there is none."""
        try:
            op, args = protocol.parse_request(payload)
            apply = self.ops.prepare(op, args)
            return None if apply is None else _Prepared(apply=apply)
        except StictionError as exc:
            return _Prepared(error=str(exc))
        except Exception as exc:  # a bug must not take the control thread down
            log.exception("control_prepare_failed")
            return _Prepared(error=f"internal error: {type(exc).__name__}: {exc}")

    def handle(self, payload: bytes, prepared: _Prepared | None = None) -> bytes:
        self.requests += 1
        try:
            if prepared is None:
                prepared = self._prepare(payload)
            if prepared is not None:
                if prepared.error is not None:
                    raise ProtocolError(prepared.error)
                assert prepared.apply is not None
                return protocol.encode(prepared.apply())
            op, args = protocol.parse_request(payload)
            return protocol.encode(self.ops.answer(op, args))
        except StictionError as exc:
            self.errors += 1
            log.warning("control_error error=%s", exc)
            return protocol.error_reply(str(exc))
        except Exception as exc:  # a bug must not take the endpoint down
            self.errors += 1
            log.exception("control_failed")
            return protocol.error_reply(f"internal error: {type(exc).__name__}: {exc}")

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=2.0)


class _Prepared:
    """A change made ready off the tick thread: `apply` swaps it in, or `error` refuses it."""

    __slots__ = ("apply", "error")

    def __init__(
        self, apply: Callable[[], protocol.Reply] | None = None, error: str | None = None
    ) -> None:
        self.apply = apply
        self.error = error


class _Pending:
    __slots__ = ("done", "payload", "prepared", "reply")

    def __init__(self, payload: bytes) -> None:
        self.payload = payload
        self.prepared: _Prepared | None = None
        self.reply = b""
        self.done = threading.Event()
