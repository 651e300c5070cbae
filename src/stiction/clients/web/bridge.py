"""ZeroMQ -> WebSocket: the one place where msgpack frames become JSON.

Every frame is transcoded once, however many pages watch. Each page gets the
*latest* state of each stream (one per device, the scene, the status), never
a queue: a page that draws slower than the daemon publishes skips frames
instead of falling behind. The bridge survives anything the daemon sends: a
malformed frame is counted and skipped, a newer schema is reported to the
pages, a daemon that goes silent is reported as gone and picked up again
when it returns.
"""

from __future__ import annotations

import asyncio
import json
import logging
import math
import time
from dataclasses import asdict, dataclass, field
from typing import Any

from stiction import protocol
from stiction.clients import control as control_mod
from stiction.clients.aio import AsyncSubscriber
from stiction.clients.curve import CurveKeys
from stiction.clients.diagnose import why_silent_async
from stiction.clients.messages import Frame, SceneMessage, wire_to_json
from stiction.errors import ProtocolError

log = logging.getLogger("stiction.clients.web")

SILENT_AFTER = 2.5
"""Seconds without a frame before pages are told the daemon is gone. A live
daemon sends each device's frame at least once per keep-alive (1 s by
default) even with nothing in range; the snapshot reply says what the
daemon's keep-alive is, and the bridge waits 2.5 of them when it is longer."""

SAME_CLOCK_WITHIN = 10.0
"""A frame time within this many seconds of the bridge's monotonic clock is
taken to come from a daemon on this machine running in real time, so its age
is a latency. Otherwise (virtual clock, another machine) no latency is shown."""


@dataclass
class BridgeStats:
    frames: int = 0
    scenes: int = 0
    sent: int = 0
    skipped_for_slow_pages: int = 0
    pages: int = 0
    errors: int = 0
    last_error: str | None = None
    state: str = "waiting"


@dataclass(eq=False)
class Page:
    """One connected page: which streams changed since its last send."""

    dirty: set[str] = field(default_factory=set)
    wake: asyncio.Event = field(default_factory=asyncio.Event)

    def mark(self, key: str) -> bool:
        """Mark a stream changed; False when an unsent value was overwritten."""
        fresh = key not in self.dirty
        self.dirty.add(key)
        self.wake.set()
        return fresh


class Bridge:
    def __init__(self, pub: str, control: str | None, curve: CurveKeys | None = None) -> None:
        self.pub = pub
        self.control = control
        self.curve = curve
        self.stats = BridgeStats()
        self.latest: dict[str, str] = {}
        """Stream key ("frame:<device>", "scene", "status") -> JSON text to send."""
        self.pages: set[Page] = set()
        self._last_frame_at: float | None = None
        self._started_at: float | None = None
        self._diagnosed_at: float | None = None
        self._diagnosing = False
        self.silent_after = SILENT_AFTER
        self._tasks: set[asyncio.Future[None]] = set()
        self._sub: AsyncSubscriber | None = None
        self._own_errors = 0
        self._bad_seen = 0
        self._status_message = f"waiting for frames from {pub}"
        self._set_status("waiting", self._status_message)

    # -- state shared with the pages --------------------------------------------

    def _publish(self, key: str, text: str) -> None:
        self.latest[key] = text
        for page in self.pages:
            if not page.mark(key):
                self.stats.skipped_for_slow_pages += 1

    def _set_status(self, state: str, message: str, reason: str | None = None) -> None:
        """`reason` is the silence diagnosis (diagnose.Silence) where one was made."""
        self.stats.state = state
        self._status_message = message
        self._publish(
            "status",
            json.dumps(
                {
                    "type": "status",
                    "state": state,
                    "message": message,
                    "pub": self.pub,
                    "control": self.control,
                    "reason": reason,
                }
            ),
        )

    def frame_json(self, frame: Frame, received: float) -> str:
        """The page's frame message: the wire frame untouched, plus the bridge's
        measurement of its age when that is meaningful."""
        age = received - frame.t
        latency_ms = age * 1000 if 0 <= age < SAME_CLOCK_WITHIN else None
        wire = wire_to_json(frame.wire)
        lat = "null" if latency_ms is None else f"{latency_ms:.3f}"
        return f'{{"type":"frame","latency_ms":{lat},"frame":{wire}}}'

    def scene_json(self, scene: SceneMessage) -> str:
        return f'{{"type":"scene","tick":{scene.tick},"scene":{wire_to_json(scene.scene)}}}'

    # -- the ZeroMQ side ----------------------------------------------------------

    async def _fetch_snapshot(self) -> None:
        """Scene and last frames at once, so a page shows something before the next tick."""
        if self.control is None:
            return
        try:
            reply = await control_mod.request_async(
                self.control, "snapshot", timeout=1.0, curve=self.curve
            )
        except (control_mod.ControlUnavailable, ProtocolError) as exc:
            log.info("no snapshot from %s: %s", self.control, exc)
            return
        keepalive = reply.get("keepalive")
        if isinstance(keepalive, (int, float)) and math.isfinite(keepalive) and keepalive > 0:
            self.silent_after = max(SILENT_AFTER, 2.5 * float(keepalive))
        scene = reply.get("scene")
        tick = reply.get("tick", -1)
        if isinstance(scene, dict) and isinstance(tick, int):
            try:
                msg = protocol.validate_scene_message(protocol.scene_message(scene, tick))  # type: ignore[arg-type]
            except ProtocolError as exc:
                self._error(f"snapshot scene: {exc}")
            else:
                self._publish("scene", self.scene_json(SceneMessage.from_wire(msg)))
                self.stats.scenes += 1

    def _error(self, why: str) -> None:
        self._own_errors += 1
        self.stats.last_error = why
        self._count_errors()
        log.warning("%s", why)

    def _count_errors(self) -> None:
        """Errors seen here plus malformed messages the subscriber skipped."""
        sub = self._sub
        bad = sub.stats.bad if sub is not None else 0
        self.stats.errors = self._own_errors + bad
        if sub is not None and sub.stats.last_error and bad > self._bad_seen:
            self.stats.last_error = sub.stats.last_error
            self._bad_seen = bad

    async def run(self) -> None:
        """Read the daemon until cancelled; never raises for anything it receives."""
        sub = self._sub = AsyncSubscriber(self.pub, kinds=("frame", "scene"), curve=self.curve)
        await self._fetch_snapshot()
        try:
            while True:
                try:
                    msg = await sub.recv(timeout=0.25)
                except ProtocolError as exc:  # a newer schema: tell the pages, keep going
                    if self.stats.state != "error" or self._status_message != str(exc):
                        self._error(str(exc))  # logged once per episode, not per frame
                        self._set_status("error", str(exc))
                    else:
                        self._own_errors += 1
                    self._last_frame_at = time.monotonic()  # the daemon is there
                    continue
                try:
                    self._handle(msg)
                except Exception as exc:  # a bug here must not stop the pages' feed
                    log.exception("bridge: could not forward a message")
                    self._error(f"internal error forwarding a message: {exc!r}")
        finally:
            sub.close()

    def _handle(self, msg: Frame | SceneMessage | None) -> None:
        now = time.monotonic()
        if msg is None:
            self._check_silence(now)
            return
        if isinstance(msg, SceneMessage):
            self.stats.scenes += 1
            self._publish("scene", self.scene_json(msg))
            return
        self.stats.frames += 1
        if self.stats.state != "live":
            was_gone = self.stats.state == "gone"
            self._set_status("live", f"receiving frames from {self.pub}")
            if was_gone:  # a restarted daemon may run another scene
                task = asyncio.ensure_future(self._fetch_snapshot())
                self._tasks.add(task)
                task.add_done_callback(self._tasks.discard)
        self._last_frame_at = now
        self._diagnosed_at = None
        self._publish(f"frame:{msg.device}", self.frame_json(msg, now))
        self._count_errors()

    def _check_silence(self, now: float) -> None:
        """Past `silent_after` without a frame: say so at once, then ask the daemon why.

        The control endpoint tells "no daemon" (gone) from "a daemon with no
        device yet" (waiting, as a daemon without devices publishes nothing),
        asked again every `silent_after` while the silence lasts.
        """
        since = self._last_frame_at
        if since is None:
            since = self._started_at
            if since is None:
                self._started_at = since = now
        if now - since < self.silent_after:
            return
        if self._diagnosed_at is None and self.stats.state != "gone":
            what = "stopped sending frames" if self._last_frame_at else "sends no frames"
            self._set_status("gone", f"the daemon at {self.pub} {what}: is stictiond running?")
        if self._diagnosing or (
            self._diagnosed_at is not None and now - self._diagnosed_at < self.silent_after
        ):
            return
        try:
            asyncio.get_running_loop()
        except RuntimeError:  # called outside the bridge's loop (a unit test): no diagnosis
            return
        self._diagnosing = True
        task = asyncio.ensure_future(self._diagnose(now))
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)

    async def _diagnose(self, now: float) -> None:
        try:
            kind, message = await why_silent_async(self.pub, self.control, curve=self.curve)
        finally:
            self._diagnosing = False
        if self._last_frame_at is not None and self._last_frame_at > now:
            return  # frames came back while we asked
        self._diagnosed_at = now
        state = "waiting" if kind == "no-device" else "gone"
        if (state, message) != (self.stats.state, self._status_message):
            self._set_status(state, message, kind)

    # -- the WebSocket side -----------------------------------------------------

    def attach(self) -> Page:
        """A new page gets everything current at once, then updates."""
        page = Page()
        self.pages.add(page)
        self.stats.pages = len(self.pages)
        for key in self.latest:
            page.mark(key)
        return page

    def detach(self, page: Page) -> None:
        self.pages.discard(page)
        self.stats.pages = len(self.pages)

    def take(self, page: Page) -> list[str]:
        """The messages a page should get now, status first and scene before frames."""
        order = sorted(page.dirty, key=lambda k: (k != "status", k != "scene", k))
        page.dirty.clear()
        page.wake.clear()
        out = [self.latest[k] for k in order if k in self.latest]
        self.stats.sent += len(out)
        return out

    def summary(self) -> dict[str, Any]:
        self._count_errors()
        return {**asdict(self.stats), "pub": self.pub, "control": self.control}
