"""The control endpoint: one REP socket, answered between ticks.

A small thread owns the REP socket and blocks on it, so an idle daemon
spends no wake-ups on control. Each request is handed to the loop through a
queue and answered there at the next tick boundary (`serve_pending`), so a
request sees a consistent state and never races the tick. Every request gets
exactly one reply (the REP rule); anything malformed gets an error reply and
is counted, and the daemon carries on.

What is slow or touches the file system -- reading and compiling a scene for
`set_scene`, compiling the changed scene of `set_params` -- is done on the
control thread before the request is queued (`_prepare`), checked completely
(including that every message it will cause can be encoded); the loop thread
only swaps the ready pipeline in. A request larger than
protocol.MAX_MESSAGE_BYTES still gets a reply naming the limit; only one
larger than TRANSPORT_MAX_BYTES is cut off by ZeroMQ before it is read.
"""

from __future__ import annotations

import logging
import queue
import threading
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import zmq

from stiction import protocol
from stiction.daemon.security import Guard
from stiction.errors import ProtocolError, StictionError

if TYPE_CHECKING:
    from stiction.daemon.service import Daemon

log = logging.getLogger("stiction.daemon.control")

TRANSPORT_MAX_BYTES = 64 * protocol.MAX_MESSAGE_BYTES
"""ZeroMQ drops a peer whose message exceeds this without a reply; between
MAX_MESSAGE_BYTES and this a request is received and refused in words."""


class ControlServer:
    def __init__(
        self,
        ctx: zmq.Context[Any],
        endpoint: str,
        guard: Guard,
        daemon: Daemon,
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
        self.daemon = daemon
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
            if op == "set_scene":
                return self._prepare_scene(args)
            if op == "set_params":
                return self._prepare_params(args)
        except StictionError as exc:
            return _Prepared(error=str(exc))
        except Exception as exc:  # a bug must not take the control thread down
            log.exception("control_prepare_failed")
            return _Prepared(error=f"internal error: {type(exc).__name__}: {exc}")
        return None

    def _prepare_scene(self, args: dict[str, Any]) -> _Prepared:
        d = self.daemon
        _only(args, {"toml", "path"}, "set_scene")
        if ("toml" in args) == ("path" in args):
            raise ProtocolError("set_scene needs exactly one of 'toml' or 'path'")
        if "toml" in args:
            text = args["toml"]
            if not isinstance(text, str):
                raise ProtocolError("set_scene 'toml' must be a string")
            scene = d.load_scene_text(text, "<control>")
        else:
            path = args["path"]
            if not isinstance(path, str):
                raise ProtocolError("set_scene 'path' must be a string")
            scene = d.load_scene_file(Path(path))
        pipeline = d.prepare_scene(scene)

        def apply() -> protocol.Reply:
            d.apply_pipeline(pipeline)
            return protocol.scene_reply(d.pipeline.wire())

        return _Prepared(apply=apply)

    def _prepare_params(self, args: dict[str, Any]) -> _Prepared:
        d = self.daemon
        material = args.pop("material", None)
        if material is not None and not isinstance(material, str):
            raise ProtocolError("set_params 'material' must be a string")
        base = d.pipeline
        pipeline, defaults = d.prepare_params(args, material)

        def apply() -> protocol.Reply:
            if d.pipeline is base:
                d.apply_pipeline(pipeline, defaults)
            else:  # the scene changed meanwhile: apply the change to the new one
                d.apply_pipeline(*d.prepare_params(args, material))
            log.info("params_set material=%s values=%s", material, args)
            return d.params_reply()

        return _Prepared(apply=apply)

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
            return protocol.encode(self._dispatch(op, args))
        except StictionError as exc:
            self.errors += 1
            log.warning("control_error error=%s", exc)
            return protocol.error_reply(str(exc))
        except Exception as exc:  # a bug must not take the endpoint down
            self.errors += 1
            log.exception("control_failed")
            return protocol.error_reply(f"internal error: {type(exc).__name__}: {exc}")

    def _dispatch(self, op: str, args: dict[str, Any]) -> protocol.Reply:
        d = self.daemon
        if op == "ping":
            return d.ping()
        if op == "get_scene":
            return protocol.scene_reply(d.pipeline.wire(), d.pipeline.scene.text)
        if op == "get_params":
            _only(args, set(), op)
            return d.params_reply()
        if op == "devices":
            return protocol.devices_reply(d.devices())
        if op == "stats":
            return protocol.stats_reply(d.stats())
        if op == "snapshot":
            return d.snapshot()
        raise ProtocolError(f"op {op!r} is not served")

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


def _only(args: dict[str, Any], allowed: set[str], op: str) -> None:
    extra = sorted(set(args) - allowed)
    if extra:
        raise ProtocolError(f"{op} does not take {', '.join(extra)}")
