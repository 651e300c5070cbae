"""`stiction replay`: publish a recording again, as a daemon would.

Paced by the frames' own tick times (``t``), so the replay runs at the pace
the daemon produced, not at the jitter with which the recorder happened to
receive it; ``speed`` scales that, ``fast`` drops the pacing. It publishes on
an XPUB socket so it can wait for the first subscriber instead of sending a
stroke into the void (PUB/SUB drops messages until a subscription arrives).
An optional control endpoint answers the read-only requests (ping,
get_scene, get_params, devices, stats, snapshot) from the recording, so
clients that use the clone pattern work against a replay unchanged.
"""

from __future__ import annotations

import contextlib
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import zmq

from stiction import __version__, protocol
from stiction.clients import recording
from stiction.errors import ProtocolError, StictionError

MAX_PAUSE = 2.0
"""Longest wait between two frames, in recorded seconds. A live daemon ticks
at least once per keep-alive (1 s by default) even while nothing happens, so
a longer gap in a recording is an outage, replayed as a jump."""


@dataclass
class ReplayState:
    """What has been published so far: enough to answer a snapshot."""

    tick: int = -1
    sent: int = 0
    subscribers: int = 0
    last_frames: dict[str, dict[str, Any]] = field(default_factory=dict)
    scene: dict[str, Any] | None = None
    ended: bool = False


def _bind(sock: zmq.Socket[Any], endpoint: str, what: str) -> None:
    # The daemon's policy: an address others can reach needs CURVE keys, and a
    # replay has none, so it serves loopback and ipc:// only.
    if not protocol.is_local_endpoint(endpoint):
        raise StictionError(
            f"{what} endpoint {endpoint} is not loopback: stiction replay serves recordings "
            "only on ipc:// or tcp://127.0.0.1 (stictiond needs CURVE keys for other addresses; "
            "replay has none)"
        )
    try:
        sock.bind(endpoint)
    except zmq.ZMQError as exc:
        hint = (
            " (is stictiond or another replay running there?)"
            if exc.errno == zmq.EADDRINUSE
            else ""
        )
        raise StictionError(f"cannot bind the {what} endpoint {endpoint}: {exc}{hint}") from exc


class Replayer:
    def __init__(
        self,
        rec: recording.Recording,
        pub: str = protocol.DEFAULT_PUB,
        control: str | None = None,
        context: zmq.Context[Any] | None = None,
    ) -> None:
        self.rec = rec
        scene = rec.meta.get("scene")  # the file's metadata: a scene is a table or nothing
        self.state = ReplayState(scene=scene if isinstance(scene, dict) else None)
        self._ctx = context or zmq.Context.instance()
        self.pub = self._ctx.socket(zmq.XPUB)
        self.pub.setsockopt(zmq.SNDHWM, 100_000)
        self.pub.setsockopt(zmq.LINGER, 2000)  # let the tail of the stream reach its readers
        self.rep: zmq.Socket[Any] | None = None
        try:
            _bind(self.pub, pub, "publisher")
            if control is not None:
                self.rep = self._ctx.socket(zmq.REP)
                self.rep.setsockopt(zmq.LINGER, 0)
                _bind(self.rep, control, "control")
        except StictionError:
            self.close()
            raise
        self._poller = zmq.Poller()
        self._poller.register(self.pub, zmq.POLLIN)
        if self.rep is not None:
            self._poller.register(self.rep, zmq.POLLIN)

    def close(self) -> None:
        self.pub.close()
        if self.rep is not None:
            self.rep.close(0)

    # -- sockets ---------------------------------------------------------------

    def service(self, timeout: float) -> None:
        """Handle subscriptions and control requests for up to ``timeout`` seconds."""
        for sock, _ in self._poller.poll(max(0, int(timeout * 1000))):
            if sock is self.pub:
                while True:
                    try:
                        note = self.pub.recv(zmq.NOBLOCK)
                    except zmq.Again:
                        break
                    if note[:1] == b"\x01":
                        self.state.subscribers += 1
            elif self.rep is not None and sock is self.rep:
                payload = self.rep.recv()
                try:
                    reply = self._answer(payload)
                except ProtocolError as exc:  # metadata msgpack cannot carry (an int > 2**64)
                    reply = protocol.error_reply(str(exc))
                self.rep.send(reply)

    def _answer(self, payload: bytes) -> bytes:
        try:
            op, _args = protocol.parse_request(payload)
        except ProtocolError as exc:
            return protocol.error_reply(str(exc))
        st = self.state
        meta = self.rec.meta
        if op == "ping":
            return protocol.ok_reply(tick=st.tick, version=__version__, replay=True)
        if op == "get_scene":
            if st.scene is None:
                return protocol.error_reply("the recording holds no scene")
            return protocol.ok_reply(scene=st.scene, toml=meta.get("scene_toml") or "")
        if op == "get_params":
            params = meta.get("params")
            if not isinstance(params, dict):
                return protocol.error_reply("the recording holds no parameters")
            # The metadata is the file's: its keys must not replace the reply's own.
            return protocol.ok_reply(
                **{k: v for k, v in params.items() if isinstance(k, str) and k not in ("v", "ok")}
            )
        if op == "devices":
            return protocol.ok_reply(devices=self._devices())
        if op == "stats":
            return protocol.ok_reply(stats={"replay": True, "published": st.sent})
        if op == "snapshot":
            snap: dict[str, Any] = {"tick": st.tick, "frames": st.last_frames}
            if st.scene is not None:
                snap["scene"] = st.scene
            return protocol.ok_reply(**snap)
        return protocol.error_reply(f"{op!r} is not available from a replay (read-only)")

    def _devices(self) -> list[dict[str, Any]]:
        """The recorded devices, with the replay's own state: "open" while it plays,
        "ended" once it has, so a client can tell a finished replay from an outage."""
        recorded = self.rec.meta.get("devices")
        listed = [  # as the daemon described them; anything else in the file is left out
            d
            for d in (recorded if isinstance(recorded, list) else [])
            if isinstance(d, dict) and isinstance(d.get("name"), str)
        ]
        names = {d["name"] for d in listed}
        listed += [  # a recording made without the control endpoint lists none
            {"name": n, "spec": "replay", "kind": None, "surface_m": None, "mapping": None}
            for n in self.state.last_frames
            if n not in names
        ]
        state = "ended" if self.state.ended else "open"
        return [{**d, "state": state} for d in listed]

    def wait_for_subscriber(self, timeout: float | None) -> bool:
        end = None if timeout is None else time.monotonic() + timeout
        while self.state.subscribers == 0:
            left = 0.25 if end is None else min(0.25, end - time.monotonic())
            if left <= 0:
                return False
            self.service(left)
        return True

    def hold(self, stop: Callable[[], bool], seconds: float | None = None) -> None:
        """Keep answering control requests after the stream ended (until ``stop()``
        is true or ``seconds`` pass), so a late client still gets the last state."""
        end = None if seconds is None else time.monotonic() + seconds
        while not stop():
            left = 0.1 if end is None else min(0.1, end - time.monotonic())
            if left <= 0:
                return
            self.service(left)

    # -- the stream ------------------------------------------------------------

    def run(
        self,
        speed: float = 1.0,
        fast: bool = False,
        loops: int = 1,
        progress: Callable[[int], None] | None = None,
    ) -> int:
        """Publish the recording ``loops`` times (0: forever); returns messages sent."""
        if not (speed > 0):
            raise StictionError(f"--speed must be a positive number, got {speed}")
        done = 0
        while loops == 0 or done < loops:
            self._one_pass(speed, fast)
            done += 1
            if progress is not None:
                progress(done)
        self.state.ended = True
        return self.state.sent

    def _one_pass(self, speed: float, fast: bool) -> None:
        due = time.monotonic()
        prev_t: float | None = None
        for topic, payload in self.rec.messages():
            message = protocol.decode(payload)
            if message.get("kind") == "frame" and not fast:
                t = float(message["t"])
                step = 0.0 if prev_t is None else t - prev_t
                # Absolute deadlines from summed steps: no drift over a long file.
                # A step backwards or longer than MAX_PAUSE is a discontinuity
                # (the daemon restarted or was away) and is not waited out.
                if 0 < step <= MAX_PAUSE:
                    due += step / speed
                prev_t = t
                while (left := due - time.monotonic()) > 0:
                    self.service(left)
            else:
                self.service(0)
            self.pub.send_multipart([topic, payload])
            st = self.state
            st.sent += 1
            if message.get("kind") == "frame":
                st.tick = int(message["tick"])
                st.last_frames[str(message["device"])] = message
            elif isinstance(message.get("scene"), dict):
                st.scene = message["scene"]


def replay(
    path: str | Path,
    *,
    pub: str = protocol.DEFAULT_PUB,
    control: str | None = None,
    speed: float = 1.0,
    fast: bool = False,
    loops: int = 1,
    wait: float | None = None,
    no_wait: bool = False,
    hold: float | None = None,
) -> int:
    rec = recording.read(path)
    recording.check_messages(rec, str(path))
    r = Replayer(rec, pub, control)
    try:
        if not no_wait:
            print(f"stiction replay: waiting for a subscriber on {pub}", file=sys.stderr)
            if not r.wait_for_subscriber(wait):
                raise StictionError(f"no subscriber connected to {pub} within {wait:g} s")
        sent = r.run(speed=speed, fast=fast, loops=loops)
        if hold is not None:
            with contextlib.suppress(KeyboardInterrupt):
                r.hold(lambda: False, None if hold == float("inf") else hold)
    finally:
        r.close()
    print(f"stiction replay: published {sent} messages from {path}", file=sys.stderr)
    return 0
