"""`stiction experiment run`: a person, a running stictiond, and the participant's page.

The runner subscribes to the daemon's frames, hands them to the `Session`,
applies each stimulus's scene through the control socket (only while no pen
touches: parameters change between stimuli, never under the hand), and
serves two pages:

- ``/`` the participant's page: instructions, progress, the dot to start
  on, the pointer and (in the string condition) the string, and the answer
  buttons. It is sent only what it draws: pointer position, string length
  and direction, and the session's view. Never the scene, the material or
  mu_s, so nothing in the page (or its traffic) names the condition.
- ``/experimenter?token=...`` pause and resume, and where the session is;
  the token is printed in the terminal, so the participant's page cannot
  pause itself.

Pages talk over one WebSocket each; a closed or reloaded page gets the
current state again, so it loses nothing.
"""

from __future__ import annotations

import asyncio
import contextlib
import hmac
import json
import logging
import secrets
import sys
import time
from pathlib import Path
from typing import Any

import zmq
import zmq.asyncio
from aiohttp import WSMsgType, web

from stiction import protocol
from stiction.clients import control as control_mod
from stiction.clients.aio import stop_on_signals
from stiction.errors import ProtocolError, StictionError
from stiction.experiment.runner import AnswerError, Session
from stiction.experiment.stimulus import TOUCHING
from stiction.userfiles import shown

log = logging.getLogger("stiction.experiment")
STATIC = Path(__file__).resolve().parent / "static"
WEB_STATIC = Path(__file__).resolve().parents[1] / "clients" / "web" / "static"


def page_frame(frame: dict[str, Any]) -> dict[str, Any]:
    """Only what the participant sees of a frame: the pointer and the string."""
    contacts = frame.get("contacts") or []
    c = contacts[0] if contacts else None
    if c is None or c.get("phase") == "up":
        return {"type": "frame", "pointer": None}
    s = c.get("string")
    return {
        "type": "frame",
        "pointer": [round(float(v), 1) for v in c["pointer_px"]],
        "touching": c.get("phase") in TOUCHING,
        "string": None
        if s is None
        else {"length_px": round(float(s["length_px"]), 1), "dir": s["dir"]},
    }


class LiveRunner:
    """Ties one Session to a daemon's sockets and to the pages."""

    def __init__(
        self,
        session: Session,
        pub: str,
        control: str,
        *,
        device: str | None = None,
        token: str | None = None,
    ) -> None:
        self.session = session
        self.pub = pub
        self.control = control
        self.device = device
        self.token = token or secrets.token_urlsafe(12)
        self.pages: set[web.WebSocketResponse] = set()
        self.touching = False
        self.latest_frame: dict[str, Any] = {"type": "frame", "pointer": None}
        self.changed = asyncio.Event()
        self.done = asyncio.Event()

    # ------------------------------------------------------------ daemon side
    async def describe(self) -> None:
        ping = await control_mod.request_async(self.control, "ping", timeout=2.0)
        devices = (await control_mod.request_async(self.control, "devices"))["devices"]
        dev = next((d for d in devices if self.device in (None, d["name"])), None)
        if self.device is not None and dev is None:
            names = ", ".join(d["name"] for d in devices) or "none"
            raise StictionError(f"the daemon has no device {self.device!r} (it has: {names})")
        self.session.describe(
            daemon_version=ping.get("version"),
            rate_hz=ping.get("rate"),
            device=dev.get("name") if dev else None,
            device_spec=dev.get("spec") if dev else None,
            device_size_m=dev.get("surface_m") if dev else None,
            mapping=dev.get("mapping") if dev else None,
            scene=(await control_mod.request_async(self.control, "get_scene"))["scene"],
            clock="real",
            simulated=False,
        )

    async def frames(self) -> None:
        ctx = zmq.asyncio.Context.instance()
        sock = ctx.socket(zmq.SUB)
        sock.setsockopt(zmq.LINGER, 0)
        topic = protocol.frame_topic(self.device) if self.device else b"frame."
        sock.setsockopt(zmq.SUBSCRIBE, topic)
        sock.connect(self.pub)
        try:
            while True:
                parts = await sock.recv_multipart()
                if len(parts) != 2:
                    continue
                try:
                    frame = dict(protocol.decode_frame(parts[1]))
                except ProtocolError as exc:
                    log.warning("skipped a bad frame: %s", exc)
                    continue
                self.on_frame(frame)
        finally:
            sock.close()

    def on_frame(self, frame: dict[str, Any]) -> None:
        contacts = frame.get("contacts") or []
        self.touching = bool(contacts) and contacts[0].get("phase") in TOUCHING
        before = self.session.state
        if self.session.on_frame(frame) or self.session.state != before:
            self.changed.set()
        self.latest_frame = page_frame(frame)
        self.changed.set()

    async def scenes(self) -> None:
        """Apply each stimulus's scene as soon as no pen touches."""
        while True:
            scene = self.session.pending_scene()
            if scene is not None and not self.touching and self.session.state == "stimulus":
                try:
                    await control_mod.request_async(self.control, "set_scene", toml=scene)
                except control_mod.ControlUnavailable as exc:
                    log.warning("could not set the stimulus scene, retrying: %s", exc)
                    await asyncio.sleep(0.5)
                    continue
                self.session.scene_applied()
                self.changed.set()
            if self.session.state == "done":
                self.done.set()
            await asyncio.sleep(0.02)

    # ------------------------------------------------------------ page side
    def view(self) -> dict[str, Any]:
        v = self.session.view()
        v["type"] = "view"
        v["display"] = list(self.session.study.display)
        v["ratio_method"] = self.session.study.method == "ratio"
        return v

    async def broadcast(self) -> None:
        last_view = ""
        while True:
            await self.changed.wait()
            self.changed.clear()
            view = json.dumps(self.view())
            frame = json.dumps(self.latest_frame)
            for ws in list(self.pages):
                with contextlib.suppress(ConnectionResetError, RuntimeError):
                    if view != last_view:
                        await ws.send_str(view)
                    await ws.send_str(frame)
            last_view = view
            await asyncio.sleep(0.008)  # at most ~120 page updates a second

    async def page(self, request: web.Request) -> web.FileResponse:
        return web.FileResponse(STATIC / "experiment.html", headers={"Cache-Control": "no-cache"})

    async def websocket(self, request: web.Request) -> web.WebSocketResponse:
        origin = request.headers.get("Origin")
        if origin is not None and origin != f"{request.scheme}://{request.host}":
            raise web.HTTPForbidden(text="stiction experiment: foreign origin\n")
        ws = web.WebSocketResponse(heartbeat=10.0, max_msg_size=1 << 12)
        await ws.prepare(request)
        self.pages.add(ws)
        await ws.send_str(json.dumps(self.view()))
        try:
            async for msg in ws:
                if msg.type != WSMsgType.TEXT:
                    continue
                refused = self.press(msg.data)
                if refused is not None:
                    await ws.send_str(json.dumps({"type": "refused", "error": refused}))
                self.changed.set()
        finally:
            self.pages.discard(ws)
        return ws

    def press(self, data: str) -> str | None:
        """Apply a page's ``{"press": BUTTON}``; the reason it was refused, or None.

        The page is the participant's, but its message is still input: JSON that
        is not an object, or nested past the decoder's recursion limit (a 4 KiB
        message of brackets), is refused like a wrong button.
        """
        try:
            message = json.loads(data)
            if not isinstance(message, dict):
                raise ValueError(f"expected a JSON object, got {type(message).__name__}")
            self.session.press(str(message.get("press")))
        except (AnswerError, ValueError, RecursionError) as exc:
            return shown(str(exc))
        return None

    def _check_token(self, request: web.Request) -> None:
        given = request.query.get("token", "")
        if not hmac.compare_digest(given.encode(), self.token.encode()):
            raise web.HTTPForbidden(text="stiction experiment: the experimenter token is wrong\n")

    async def experimenter(self, request: web.Request) -> web.Response:
        self._check_token(request)
        if request.method == "POST":
            action = request.query.get("action", "")
            if action == "pause":
                self.session.pause()
            elif action == "resume":
                self.session.resume()
            else:
                raise web.HTTPBadRequest(text="action must be pause or resume\n")
            self.changed.set()
        s = self.session
        return web.json_response(
            {"state": s.state, "trial": s.position + 1, "trials": len(s.schedule)}
        )

    def app(self) -> web.Application:
        app = web.Application()
        app.router.add_get("/", self.page)
        app.router.add_get("/ws", self.websocket)
        app.router.add_get("/experimenter", self.experimenter)
        app.router.add_post("/experimenter", self.experimenter)
        app.router.add_static("/exp/", STATIC, append_version=False)
        app.router.add_static("/static/", WEB_STATIC, append_version=False)
        return app


async def serve(
    runner: LiveRunner,
    host: str,
    port: int,
    *,
    ready: asyncio.Future[str] | None = None,
    announce: bool = True,
) -> None:
    """Serve the pages and drive the session until it is done or interrupted."""
    await runner.describe()
    app_runner = web.AppRunner(runner.app(), access_log=None)
    await app_runner.setup()
    site = web.TCPSite(app_runner, host, port)
    try:
        await site.start()
    except OSError as exc:
        await app_runner.cleanup()
        raise StictionError(f"cannot serve the participant page on {host}:{port}: {exc}") from exc
    sockets = getattr(site._server, "sockets", None) or []
    actual = sockets[0].getsockname()[1] if sockets else port
    url = f"http://{host}:{actual}/"
    if announce:
        print(f"stiction experiment: participant page {url}", file=sys.stderr, flush=True)
        print(
            f"stiction experiment: pause/resume: curl -X POST "
            f"'{url}experimenter?token={runner.token}&action=pause' (or resume)",
            file=sys.stderr,
            flush=True,
        )
    if ready is not None and not ready.done():
        ready.set_result(url)
    try:
        with stop_on_signals() as stop:
            await _serve_until_done(runner, stop)
    finally:
        for ws in list(runner.pages):
            with contextlib.suppress(Exception):
                await ws.close()
        await app_runner.cleanup()


async def _serve_until_done(runner: LiveRunner, stop: asyncio.Event) -> None:
    """Until the study is done, a signal, or a feed fails (its error is raised)."""
    tasks = [
        asyncio.ensure_future(c) for c in (runner.frames(), runner.scenes(), runner.broadcast())
    ]
    waiters = [asyncio.ensure_future(stop.wait()), asyncio.ensure_future(runner.done.wait())]
    try:
        done, _ = await asyncio.wait([*tasks, *waiters], return_when=asyncio.FIRST_COMPLETED)
        for t in done:
            if t in tasks and t.exception() is not None:
                raise t.exception()  # type: ignore[misc]
        if runner.done.is_set():
            runner.changed.set()
            await asyncio.sleep(1.0)  # let the pages show the end
    finally:
        for t in [*tasks, *waiters]:
            t.cancel()
        for t in [*tasks, *waiters]:
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await t


def run_live(
    session: Session,
    *,
    pub: str,
    control: str,
    host: str,
    port: int,
    device: str | None = None,
) -> int:
    runner = LiveRunner(session, pub, control, device=device)
    started = time.monotonic()
    try:
        with contextlib.suppress(KeyboardInterrupt):
            asyncio.run(serve(runner, host, port))
    finally:
        session.close()
    state = session.state
    print(
        f"stiction experiment: {session.participant}: {session.position}/{len(session.schedule)} "
        f"trials done ({state}) after {time.monotonic() - started:.0f} s; data in {session.csv}",
        file=sys.stderr,
    )
    return 0
