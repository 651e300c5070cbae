"""Helpers for the daemon tests: a tiny in-test SampleSource, endpoints, a running daemon."""

from __future__ import annotations

import threading
from collections.abc import Iterator, Sequence
from typing import Any

import msgpack
import zmq

from stiction.daemon.devices import DeviceConfig, Spec
from stiction.daemon.options import Options
from stiction.daemon.publisher import Sink
from stiction.daemon.service import Daemon
from stiction.drivers.sample import PenSample
from stiction.errors import DeviceError


class ListSource:
    """Yields fixed samples, then ends -- or raises DeviceError like an unplug."""

    def __init__(
        self,
        samples: Sequence[PenSample],
        name: str = "test-pen",
        size: tuple[float, float] | None = (0.2, 0.1),
        kind: str = "pen",
        fail_at_end: bool = False,
        gate: threading.Event | None = None,
    ) -> None:
        self._samples = list(samples)
        self._name = name
        self._size = size
        self._kind = kind
        self.fail_at_end = fail_at_end
        self.gate = gate
        self.closed = threading.Event()

    @property
    def name(self) -> str:
        return self._name

    @property
    def surface_size(self) -> tuple[float, float] | None:
        return self._size

    @property
    def kind(self) -> str:
        return self._kind

    def samples(self) -> Iterator[PenSample]:
        yield from self._samples
        if self.gate is not None:
            self.gate.wait(10)
        if self.fail_at_end:
            raise DeviceError(f"{self._name} was unplugged")

    def close(self) -> None:
        self.closed.set()

    def stats(self) -> dict[str, int]:
        return {"reports": len(self._samples)}


def stroke(
    t0: float = 0.0, n: int = 200, dt: float = 0.004, speed: float = 0.05, contact: int = 0
) -> list[PenSample]:
    """Hover in, press, drag right at `speed` m/s, lift, leave."""
    out = [PenSample(t=t0, x=0.05, y=0.05, tip=False, contact=contact)]
    for i in range(1, n + 1):
        out.append(
            PenSample(t=t0 + i * dt, x=0.05 + speed * i * dt, y=0.05, tip=True, contact=contact)
        )
    end = t0 + (n + 1) * dt
    out.append(PenSample(t=end, x=out[-1].x, y=0.05, tip=False, contact=contact))
    out.append(
        PenSample(t=end + dt, x=out[-1].x, y=0.05, tip=False, in_range=False, contact=contact)
    )
    return out


def opener_for(sources: dict[str, Any]) -> Any:
    def opener(spec: Spec, cfg: DeviceConfig, realtime: bool, loop: bool) -> Any:
        src = sources[cfg.spec]
        if isinstance(src, Exception):
            raise src
        return src() if callable(src) else src

    return opener


def make_daemon(
    endpoints: tuple[str, str],
    sources: dict[str, Any],
    publisher: Sink | None = None,
    **opts: Any,
) -> Daemon:
    """An opened daemon on `sources`; `publisher` (e.g. a Recorder) replaces the PUB socket."""
    o = Options(pub=endpoints[0], control=endpoints[1], hotplug=False, **opts)
    if not o.devices:
        o.devices = [DeviceConfig(spec) for spec in sources]
    d = Daemon(o, opener=opener_for(sources), publisher=publisher)
    d.open()
    return d


def subscribe(ctx: zmq.Context[Any], d: Daemon, endpoint: str) -> zmq.Socket[Any]:
    """A SUB socket that is known to be subscribed (no slow-joiner loss):
    republish the scene until it arrives, then drain."""
    sub = ctx.socket(zmq.SUB)
    sub.rcvhwm = 0
    sub.linger = 0
    sub.connect(endpoint)
    sub.setsockopt(zmq.SUBSCRIBE, b"")
    for _ in range(200):
        d._publish_scene()
        if sub.poll(20):
            break
    else:
        raise AssertionError("subscriber never joined")
    while sub.poll(0):
        sub.recv_multipart()
    return sub


def drain(sub: zmq.Socket[Any], timeout_ms: int = 200) -> list[tuple[bytes, dict[str, Any]]]:
    out = []
    while sub.poll(timeout_ms):
        topic, payload = sub.recv_multipart()
        out.append((topic, msgpack.unpackb(payload)))
    return out


def request(ctx: zmq.Context[Any], endpoint: str, payload: bytes, timeout_ms: int = 5000) -> Any:
    req = ctx.socket(zmq.REQ)
    req.linger = 0
    req.connect(endpoint)
    try:
        req.send(payload)
        if not req.poll(timeout_ms):
            return None
        return msgpack.unpackb(req.recv())
    finally:
        req.close()


class Runner:
    """Runs a daemon's loop on a thread; stop() ends it and joins."""

    def __init__(self, d: Daemon) -> None:
        self.d = d
        self.thread = threading.Thread(target=d.run, daemon=True)

    def __enter__(self) -> Runner:
        self.thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.d.request_stop()
        self.thread.join(10)
        self.d.close()
