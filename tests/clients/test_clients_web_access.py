"""Who may read the pen through `stiction web`: loopback by default, a token
elsewhere, and WebSockets only from the page's own origin (issue 12).

Real HTTP and WebSocket requests (aiohttp's client) against the real server;
the non-loopback case binds 0.0.0.0 and is reached over 127.0.0.1, so no
traffic leaves the machine.
"""

from __future__ import annotations

import asyncio
import contextlib
import threading
from collections.abc import Iterator
from typing import Any

import aiohttp
import pytest

from stiction.clients.web import server


@contextlib.contextmanager
def serving(host: str, **kw: Any) -> Iterator[str]:
    loop = asyncio.new_event_loop()
    ready: asyncio.Future[str] = loop.create_future()
    task: list[asyncio.Task[None]] = []

    def main() -> None:
        asyncio.set_event_loop(loop)
        task.append(
            loop.create_task(
                server.run("ipc:///nowhere", None, host, 0, ready=ready, announce=False, **kw)
            )
        )
        with contextlib.suppress(asyncio.CancelledError):
            loop.run_until_complete(task[0])
        loop.close()

    t = threading.Thread(target=main, daemon=True)
    t.start()
    url = asyncio.run_coroutine_threadsafe(_wait(ready), loop).result(30)
    try:
        yield url
    finally:
        loop.call_soon_threadsafe(task[0].cancel)
        t.join(30)


async def _wait(f: asyncio.Future[str]) -> str:
    return await f


def _local(url: str) -> str:
    """The served URL, reached over loopback (the host part may be the hostname)."""
    rest = url.split("://", 1)[1]
    port_and_path = rest.split(":", 1)[1]
    return f"http://127.0.0.1:{port_and_path}"


async def _get(url: str) -> int:
    async with aiohttp.ClientSession() as s, s.get(url) as r:
        return r.status


async def _ws(url: str, origin: str | None) -> int | str:
    headers = {"Origin": origin} if origin else {}
    async with aiohttp.ClientSession() as s:
        try:
            async with s.ws_connect(url, headers=headers) as ws:
                msg = await ws.receive_json(timeout=10)
                return str(msg["type"])
        except aiohttp.WSServerHandshakeError as exc:
            return exc.status


def test_loopback_needs_no_token_but_refuses_foreign_origins() -> None:
    with serving("127.0.0.1") as url:
        assert "token=" not in url
        base = url.rstrip("/")
        assert asyncio.run(_get(url)) == 200
        ws = base.replace("http", "ws") + "/ws"
        assert asyncio.run(_ws(ws, base)) == "hello"  # the page's own origin
        assert asyncio.run(_ws(ws, None)) == "hello"  # a program, not a browser page
        assert asyncio.run(_ws(ws, "http://evil.example")) == 403


def test_allow_origin_admits_one_more_page() -> None:
    with serving("127.0.0.1", allow_origins=("https://lab.example",)) as url:
        ws = url.rstrip("/").replace("http", "ws") + "/ws"
        assert asyncio.run(_ws(ws, "https://lab.example")) == "hello"
        assert asyncio.run(_ws(ws, "https://other.example")) == 403


def test_any_other_host_needs_the_printed_token() -> None:
    with serving("0.0.0.0") as url:
        assert "?token=" in url and "127.0.0.1" not in url  # the URL it really serves
        token = url.split("?token=", 1)[1]
        local = _local(url)
        bare = local.split("?", 1)[0]
        assert asyncio.run(_get(bare)) == 403
        assert asyncio.run(_get(bare + "?token=wrong")) == 403
        assert asyncio.run(_get(bare + "status")) == 403
        assert asyncio.run(_get(local)) == 200
        ws = bare.replace("http", "ws") + "ws"
        origin = bare.rstrip("/")
        assert asyncio.run(_ws(ws, origin)) == 403
        assert asyncio.run(_ws(f"{ws}?token={token}", origin)) == "hello"


def test_a_given_token_is_used(capsys: pytest.CaptureFixture[str]) -> None:
    with serving("0.0.0.0", token="s3cret") as url:
        assert url.endswith("?token=s3cret")
        assert asyncio.run(_get(_local(url))) == 200


def test_an_empty_token_is_refused_not_matched_by_every_request(
    capsys: pytest.CaptureFixture[str],
) -> None:
    """--host 0.0.0.0 --token '' served the pen to anyone: '' equals a missing token."""
    from stiction import cli

    argv = ["web", "--host", "0.0.0.0", "--port", "0", "--token", "", "--seconds", "0.1"]
    assert cli.main([*argv, "--no-control"]) == 2
    assert "--token is empty" in capsys.readouterr().err


def test_a_token_with_url_characters_reaches_the_server_whole() -> None:
    with serving("0.0.0.0", token="a&b#c d") as url:
        assert url.endswith("?token=a%26b%23c%20d")
        assert asyncio.run(_get(_local(url))) == 200
