"""`stiction web`: serve the renderer page and the WebSocket that feeds it."""

from __future__ import annotations

import asyncio
import contextlib
import errno
import logging
import signal
import sys
from pathlib import Path
from typing import Any

from aiohttp import WSMsgType, web

from stiction import __version__
from stiction.clients.web.bridge import Bridge
from stiction.errors import StictionError

log = logging.getLogger("stiction.clients.web")

STATIC = Path(__file__).resolve().parent / "static"

BRIDGE_KEY = web.AppKey("bridge", Bridge)


async def _index(request: web.Request) -> web.FileResponse:
    return web.FileResponse(STATIC / "index.html", headers={"Cache-Control": "no-cache"})


async def _status(request: web.Request) -> web.Response:
    return web.json_response(request.app[BRIDGE_KEY].summary())


async def _ws(request: web.Request) -> web.WebSocketResponse:
    bridge = request.app[BRIDGE_KEY]
    ws = web.WebSocketResponse(heartbeat=10.0, max_msg_size=1 << 16)
    await ws.prepare(request)
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
    except (ConnectionResetError, asyncio.CancelledError):
        pass
    finally:
        read_task.cancel()
        bridge.detach(page)
        await ws.close()
    return ws


def make_app(bridge: Bridge) -> web.Application:
    app = web.Application()
    app[BRIDGE_KEY] = bridge
    app.router.add_get("/", _index)
    app.router.add_get("/ws", _ws)
    app.router.add_get("/status", _status)
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
) -> None:
    """Serve until cancelled, SIGINT/SIGTERM, or ``seconds`` pass.

    ``ready`` gets the page's URL once serving; ``bridges`` (if given) gets the
    Bridge, so an embedding program (stiction demo) can read its counters."""
    bridge = Bridge(pub, control)
    if bridges is not None:
        bridges.append(bridge)
    runner = web.AppRunner(make_app(bridge), access_log=None)
    await runner.setup()
    site = web.TCPSite(runner, host, port)
    try:
        await site.start()
    except OSError as exc:
        await runner.cleanup()
        if exc.errno == errno.EADDRINUSE:
            raise StictionError(
                f"port {port} on {host} is in use; choose another with --port"
            ) from exc
        raise StictionError(f"cannot serve on {host}:{port}: {exc}") from exc
    sockets = getattr(site._server, "sockets", None) or []
    actual = sockets[0].getsockname()[1] if sockets else port
    shown = "127.0.0.1" if host in ("0.0.0.0", "") else host
    url = f"http://{shown}:{actual}/"
    if announce:
        print(f"stiction web: open {url}  (frames from {pub})", file=sys.stderr, flush=True)
    if ready is not None and not ready.done():
        ready.set_result(url)
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for sig in (signal.SIGINT, signal.SIGTERM):
        with contextlib.suppress(NotImplementedError, RuntimeError, ValueError):
            loop.add_signal_handler(sig, stop.set)
    try:
        if seconds is None:
            await stop.wait()
        else:
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(stop.wait(), seconds)
    finally:
        for sig in (signal.SIGINT, signal.SIGTERM):
            with contextlib.suppress(NotImplementedError, RuntimeError, ValueError):
                loop.remove_signal_handler(sig)
        await runner.cleanup()


def serve(
    *, pub: str, control: str | None, host: str, port: int, seconds: float | None = None
) -> int:
    with contextlib.suppress(KeyboardInterrupt):
        asyncio.run(run(pub, control, host, port, seconds))
    return 0
