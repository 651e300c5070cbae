"""`stiction web`: serve the renderer page and the WebSocket that feeds it."""

from __future__ import annotations

import asyncio
import contextlib
import errno
import hmac
import logging
import secrets
import socket
import sys
from pathlib import Path
from typing import Any
from urllib.parse import quote

from aiohttp import WSCloseCode, WSMsgType, web

from stiction import __version__
from stiction.clients.aio import stop_on_signals
from stiction.clients.curve import CurveKeys
from stiction.clients.web.bridge import Bridge
from stiction.clients.web.errors import PortInUse
from stiction.errors import StictionError

log = logging.getLogger("stiction.clients.web")

STATIC = Path(__file__).resolve().parent / "static"


class Site:
    """The HTTP side: the page, its WebSocket, and a status endpoint.

    The pen stream is private: on loopback only local programs reach it; on
    any other address the page, the status and the WebSocket need `token`
    (``?token=`` in the URL, which the page passes on to its WebSocket). The
    WebSocket accepts only its own page's Origin (and `allow_origins`), so a
    web page from elsewhere open in the same browser cannot read the pen.
    """

    def __init__(
        self, bridge: Bridge, token: str | None = None, allow_origins: tuple[str, ...] = ()
    ) -> None:
        self.bridge = bridge
        self.token = token
        self.allow_origins = frozenset(o.rstrip("/") for o in allow_origins)
        self.sockets: set[web.WebSocketResponse] = set()

    def check(self, request: web.Request, websocket: bool = False) -> None:
        """Raise 403 for a request without the token, or a WebSocket from another origin."""
        if self.token is not None:
            given = request.query.get("token", "")
            if not hmac.compare_digest(given.encode(), self.token.encode()):
                raise web.HTTPForbidden(text="stiction web: the access token is missing or wrong\n")
        if websocket:
            origin = request.headers.get("Origin")
            own = f"{request.scheme}://{request.host}"
            if origin is not None and origin != own and origin not in self.allow_origins:
                log.warning("refused a WebSocket from origin %s", origin)
                raise web.HTTPForbidden(
                    text=f"stiction web: origin {origin} is not allowed (--allow-origin)\n"
                )

    async def index(self, request: web.Request) -> web.FileResponse:
        self.check(request)
        return web.FileResponse(STATIC / "index.html", headers={"Cache-Control": "no-cache"})

    async def status(self, request: web.Request) -> web.Response:
        self.check(request)
        return web.json_response(self.bridge.summary())

    async def websocket(self, request: web.Request) -> web.WebSocketResponse:
        self.check(request, websocket=True)
        bridge = self.bridge
        ws = web.WebSocketResponse(heartbeat=10.0, max_msg_size=1 << 16)
        await ws.prepare(request)
        self.sockets.add(ws)
        page = bridge.attach()

        async def reader() -> None:
            # Pages send nothing meaningful; reading notices when they go away.
            async for msg in ws:
                if msg.type == WSMsgType.ERROR:
                    break

        read_task = asyncio.ensure_future(reader())
        try:
            await ws.send_json({"type": "hello", "version": __version__})
            while not ws.closed and not read_task.done():
                wake = asyncio.ensure_future(page.wake.wait())
                done, _ = await asyncio.wait({wake, read_task}, return_when=asyncio.FIRST_COMPLETED)
                if wake not in done:
                    wake.cancel()
                    break
                for text in bridge.take(page):
                    await ws.send_str(text)
        except ConnectionResetError:
            pass  # the page went away mid-send
        finally:
            read_task.cancel()
            bridge.detach(page)
            self.sockets.discard(ws)
            await ws.close()
        return ws

    async def close_pages(self, app: web.Application) -> None:
        """Without this, shutdown waits for every open page's socket to time out."""
        for ws in list(self.sockets):
            await ws.close(code=WSCloseCode.GOING_AWAY, message=b"stiction web is stopping")


async def favicon(request: web.Request) -> web.FileResponse:
    """Browsers ask for /favicon.ico whatever the page says; an SVG answers it."""
    return web.FileResponse(STATIC / "favicon.svg", headers={"Content-Type": "image/svg+xml"})


def make_app(
    bridge: Bridge, token: str | None = None, allow_origins: tuple[str, ...] = ()
) -> web.Application:
    site = Site(bridge, token, allow_origins)
    app = web.Application()
    app.on_shutdown.append(site.close_pages)
    app.router.add_get("/", site.index)
    app.router.add_get("/ws", site.websocket)
    app.router.add_get("/status", site.status)
    app.router.add_get("/favicon.ico", favicon)
    app.router.add_static("/static/", STATIC, append_version=False)

    async def bridge_task(app: web.Application) -> Any:
        task = asyncio.ensure_future(bridge.run())
        yield
        task.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await task

    app.cleanup_ctx.append(bridge_task)
    return app


async def run(
    pub: str,
    control: str | None,
    host: str,
    port: int,
    seconds: float | None = None,
    ready: asyncio.Future[str] | None = None,
    bridges: list[Bridge] | None = None,
    announce: bool = True,
    curve: CurveKeys | None = None,
    token: str | None = None,
    allow_origins: tuple[str, ...] = (),
) -> None:
    """Serve until cancelled, SIGINT/SIGTERM, or ``seconds`` pass.

    ``ready`` gets the page's URL once serving; ``bridges`` (if given) gets the
    Bridge, so an embedding program (stiction demo) can read its counters."""
    local = is_local_host(host)
    if token is not None and not token.strip():
        # "" compared equal to the token-less request of anyone on the network
        raise StictionError("--token is empty: it would let anyone in; omit it for a generated one")
    if not local and token is None:
        token = secrets.token_urlsafe(16)  # printed once below, with the URL
    bridge = Bridge(pub, control, curve)
    if bridges is not None:
        bridges.append(bridge)
    runner = web.AppRunner(make_app(bridge, token, allow_origins), access_log=None)
    await runner.setup()
    site = web.TCPSite(runner, host, port)
    try:
        await site.start()
    except OSError as exc:
        await runner.cleanup()
        if exc.errno == errno.EADDRINUSE:
            raise PortInUse(f"port {port} on {host} is in use; choose another with --port") from exc
        raise StictionError(f"cannot serve on {host}:{port}: {exc}") from exc
    sockets = getattr(site._server, "sockets", None) or []
    actual = sockets[0].getsockname()[1] if sockets else port
    wildcard = host in ("0.0.0.0", "", "::")
    shown = socket.gethostname() if wildcard else host
    if ":" in shown:
        shown = f"[{shown}]"
    # quoted: a chosen token with '&' or '#' would otherwise not reach the server whole
    url = f"http://{shown}:{actual}/" + (f"?token={quote(token, safe='')}" if token else "")
    if announce:
        print(f"stiction web: open {url}  (frames from {pub})", file=sys.stderr, flush=True)
        if not local:
            where = "every network interface" if wildcard else host
            print(
                f"stiction web: serving the pen stream on {where}: anyone with this URL "
                "(its token) can watch it; loopback (the default) needs none",
                file=sys.stderr,
                flush=True,
            )
    if ready is not None and not ready.done():
        ready.set_result(url)
    try:
        with stop_on_signals() as stop:
            if seconds is None:
                await stop.wait()
            else:
                with contextlib.suppress(TimeoutError):
                    await asyncio.wait_for(stop.wait(), seconds)
    finally:
        await runner.cleanup()


def is_local_host(host: str) -> bool:
    """Loopback names and addresses: what only this machine's programs reach."""
    from stiction.protocol import is_local_endpoint

    return host != "" and is_local_endpoint(f"tcp://{host}:0")


def serve(
    *,
    pub: str,
    control: str | None,
    host: str,
    port: int,
    seconds: float | None = None,
    curve: CurveKeys | None = None,
    token: str | None = None,
    allow_origins: tuple[str, ...] = (),
) -> int:
    with contextlib.suppress(KeyboardInterrupt):
        asyncio.run(
            run(
                pub, control, host, port, seconds, curve=curve, token=token,
                allow_origins=allow_origins,
            )
        )  # fmt: skip
    return 0
