"""The asyncio form of Subscriber, for clients that already run an event loop
(the web bridge, GUI toolkits with asyncio integration). Same filtering,
counting, conflation and snapshot behaviour: both use stream.StreamState."""

from __future__ import annotations

import asyncio
import contextlib
import signal
from collections.abc import AsyncIterator, Iterable, Iterator, Sequence
from typing import cast

import zmq
import zmq.asyncio
from zmq.utils.monitor import parse_monitor_message

from stiction import protocol
from stiction.clients import control
from stiction.clients.curve import CurveKeys
from stiction.clients.messages import Frame, Message
from stiction.clients.stream import StreamState, SubscriberStats, normalise_kinds, subscriptions
from stiction.clients.subscriber import DRAIN_LIMIT, close_sub, open_sub


class AsyncSubscriber:
    """``async for msg in AsyncSubscriber(...)``; see Subscriber for the arguments.

    Create it inside a running loop, or call ``await sub.start()`` to also
    fetch the snapshot when ``control`` is given.
    """

    def __init__(
        self,
        endpoint: str | Sequence[str] = protocol.DEFAULT_PUB,
        *,
        devices: Iterable[str] | None = None,
        kinds: Iterable[str] = ("frame",),
        conflate: bool = False,
        control: str | None = None,
        context: zmq.asyncio.Context | None = None,
        hwm: int = 10_000,
        heartbeat: float = 1.0,
        snapshot_timeout: float = 1.0,
        curve: CurveKeys | None = None,
    ) -> None:
        kinds_t = normalise_kinds(kinds)
        devs = None if devices is None else tuple(devices)
        self.endpoints = [endpoint] if isinstance(endpoint, str) else list(endpoint)
        self._state = StreamState(kinds_t, devs, conflate)
        self._ctx = context or zmq.asyncio.Context.instance()
        self._sock, self._monitor = open_sub(
            self._ctx,
            self.endpoints,
            subscriptions(kinds_t, devs),
            hwm=hwm,
            heartbeat=heartbeat,
            curve=curve,
        )
        self._curve = curve
        self._control = control
        self._snapshot_timeout = snapshot_timeout
        self._ready: list[Message] = []
        self._started = control is None

    @property
    def stats(self) -> SubscriberStats:
        return self._state.stats

    async def start(self) -> None:
        """Fetch the snapshot (once) when a control endpoint was given."""
        if self._started:
            return
        self._started = True
        assert self._control is not None
        reply = await control.request_async(
            self._control,
            "snapshot",
            timeout=self._snapshot_timeout,
            context=self._ctx,
            curve=self._curve,
        )
        self._ready = self._state.snapshot_messages(reply)

    async def recv(self, timeout: float | None = None) -> Message | None:
        """The next message, or None after ``timeout`` seconds without one."""
        await self.start()
        if self._ready:
            return self._ready.pop(0)
        loop = asyncio.get_running_loop()
        deadline = None if timeout is None else loop.time() + timeout
        while True:
            msg = self._next_available()
            if msg is not None:
                return msg
            if deadline is None:
                await self._sock.poll(None)
                continue
            remaining = deadline - loop.time()
            if remaining <= 0 or not await self._sock.poll(max(1, int(remaining * 1000))):
                return self._next_available()

    def _next_available(self) -> Message | None:
        # Non-blocking reads on an asyncio socket complete at once or raise Again.
        state = self._state
        while True:
            try:
                fut = cast("asyncio.Future[list[bytes]]", self._monitor.recv_multipart(zmq.NOBLOCK))
                state.connection_event(parse_monitor_message(fut.result())["event"])
            except zmq.Again:
                break
        limit = DRAIN_LIMIT if state.conflate else 1 << 62
        for _ in range(limit):
            # On an asyncio socket a NOBLOCK read returns a future that is
            # already done: the parts, or zmq.Again when nothing is queued.
            try:
                fut = cast("asyncio.Future[list[bytes]]", self._sock.recv_multipart(zmq.NOBLOCK))
                parts = fut.result()
            except zmq.Again:
                break
            if state.conflate:
                state.keep_latest(list(parts))
                continue
            msg = state.accept(list(parts))
            if msg is not None:
                return msg
        return state.pop_pending()

    async def __aiter__(self) -> AsyncIterator[Message]:
        while True:
            msg = await self.recv()
            if msg is not None:
                yield msg

    async def frames(self, count: int | None = None) -> AsyncIterator[Frame]:
        n = 0
        async for msg in self:
            if isinstance(msg, Frame):
                yield msg
                n += 1
                if count is not None and n >= count:
                    return

    def close(self) -> None:
        close_sub(self._sock, self._monitor)

    async def __aenter__(self) -> AsyncSubscriber:
        await self.start()
        return self

    async def __aexit__(self, *exc: object) -> None:
        self.close()


@contextlib.contextmanager
def stop_on_signals() -> Iterator[asyncio.Event]:
    """An event that Ctrl-C or SIGTERM sets while the block runs, on the running loop.

    For servers that must shut down in order (close pages, clean up sockets)
    rather than die in KeyboardInterrupt. Where the loop cannot take signal
    handlers (not the main thread, another platform) the event is only set by
    the caller. The handlers are removed when the block ends.
    """
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    sigs = (signal.SIGINT, signal.SIGTERM)
    for sig in sigs:
        with contextlib.suppress(NotImplementedError, RuntimeError, ValueError):
            loop.add_signal_handler(sig, stop.set)
    try:
        yield stop
    finally:
        for sig in sigs:
            with contextlib.suppress(NotImplementedError, RuntimeError, ValueError):
                loop.remove_signal_handler(sig)
