"""The control endpoint: one REP socket, answered between ticks.

Requests are served from the loop thread in the idle part of each period,
so a request sees a consistent state and never races the tick. Every request
gets exactly one reply (the REP rule); anything malformed gets an error reply
and is counted, and the daemon carries on.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import TYPE_CHECKING, Any

import zmq

from stiction import protocol
from stiction.daemon.security import Guard
from stiction.errors import ProtocolError, StictionError

if TYPE_CHECKING:
    from stiction.daemon.service import Daemon

log = logging.getLogger("stiction.daemon.control")


class ControlServer:
    def __init__(self, ctx: zmq.Context[Any], endpoint: str, guard: Guard, daemon: Daemon) -> None:
        self.sock = ctx.socket(zmq.REP)
        self.sock.linger = 0
        self.sock.setsockopt(zmq.MAXMSGSIZE, protocol.MAX_MESSAGE_BYTES)
        try:
            guard.bind(self.sock, endpoint, "control")
        except BaseException:
            self.sock.close(linger=0)
            raise
        self.endpoint = self.sock.last_endpoint.decode() if self.sock.last_endpoint else endpoint
        self.daemon = daemon
        self.poller = zmq.Poller()
        self.poller.register(self.sock, zmq.POLLIN)
        self.requests = 0
        self.errors = 0

    def serve(self, timeout_s: float) -> None:
        """Answer the requests waiting now, waiting at most `timeout_s` for the first."""
        events = self.poller.poll(max(0, int(timeout_s * 1000)))
        while events:
            try:
                payload = self.sock.recv(zmq.DONTWAIT)
            except zmq.Again:
                return
            self.sock.send(self.handle(payload))
            events = self.poller.poll(0)

    def handle(self, payload: bytes) -> bytes:
        self.requests += 1
        try:
            op, args = protocol.parse_request(payload)
            return protocol.ok_reply(**self._dispatch(op, args))
        except StictionError as exc:
            self.errors += 1
            log.warning("control_error error=%s", exc)
            return protocol.error_reply(str(exc))
        except Exception as exc:  # a bug must not take the endpoint down
            self.errors += 1
            log.exception("control_failed")
            return protocol.error_reply(f"internal error: {type(exc).__name__}: {exc}")

    def _dispatch(self, op: str, args: dict[str, Any]) -> dict[str, Any]:
        d = self.daemon
        if op == "ping":
            return d.ping()
        if op == "get_scene":
            scene = d.pipeline.scene
            return {"scene": d.pipeline.wire(), "toml": scene.text}
        if op == "set_scene":
            _only(args, {"toml", "path"}, op)
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
            d.set_scene(scene)
            return {"scene": d.pipeline.wire()}
        if op == "get_params":
            _only(args, set(), op)
            return d.params_reply()
        if op == "set_params":
            material = args.pop("material", None)
            if material is not None and not isinstance(material, str):
                raise ProtocolError("set_params 'material' must be a string")
            d.set_params(args, material)
            return d.params_reply()
        if op == "devices":
            return {"devices": d.devices()}
        if op == "stats":
            return {"stats": d.stats()}
        if op == "snapshot":
            return d.snapshot()
        raise ProtocolError(f"op {op!r} is not served")

    def close(self) -> None:
        self.sock.close(linger=0)


def _only(args: dict[str, Any], allowed: set[str], op: str) -> None:
    extra = sorted(set(args) - allowed)
    if extra:
        raise ProtocolError(f"{op} does not take {', '.join(extra)}")
