"""Helpers for the client tests: a stand-in daemon on real ZeroMQ sockets that
sends real protocol.encode()d messages, frame builders and a test scene.

The stand-in publishes through XPUB so a test can wait until a subscriber's
subscription has arrived (no sleeps: after that, every message sent reaches
the subscriber), and answers control requests like stictiond's REP endpoint.
"""

from __future__ import annotations

import math
import sys
import threading
from pathlib import Path
from typing import Any

import zmq
import zmq.auth

from stiction import protocol
from stiction.errors import ProtocolError

REPO = Path(__file__).resolve().parents[2]

SCENE: dict[str, Any] = {
    "name": "test scene",
    "source": "<test>",
    "display": [400, 300],
    "effects": ["stick_slip", "string"],
    "outside": "pass-through",
    "materials": {
        "sticky": {"mu_s": 1.0, "mu_k": 0.1, "k": 0.1, "m": 1e-4, "g": 9.8, "C_l": 2000.0},
        "slippery": {
            "mu_s": 0.05,
            "mu_k": 0.02,
            "k": 0.1,
            "m": 1e-4,
            "g": 9.8,
            "C_l": 2000.0,
            "color": "#a8e6ff",
        },
    },
    "regions": [
        {"name": "band", "material": "sticky", "shape": "rect", "rect": [0, 0, 200, 300]},
        {
            "name": "disc",
            "material": "slippery",
            "shape": "circle",
            "center": [300, 150],
            "radius": 60,
        },
        {
            "name": "wedge",
            "material": "slippery",
            "shape": "polygon",
            "points": [[220, 280], [380, 280], [300, 230]],
        },
    ],
}


def run_in_thread(fn: Any, *args: Any, **kwargs: Any) -> tuple[threading.Thread, dict[str, Any]]:
    """Start fn on a daemon thread; the box gets its "result" or its "error"."""
    box: dict[str, Any] = {}

    def target() -> None:
        try:
            box["result"] = fn(*args, **kwargs)
        except BaseException as exc:
            box["error"] = exc

    t = threading.Thread(target=target, daemon=True)
    t.start()
    return t, box


def scene_message(tick: int = -1) -> dict[str, Any]:
    return {"v": protocol.SCHEMA_VERSION, "kind": "scene", "tick": tick, "scene": SCENE}


def make_contact(
    pointer_px: tuple[float, float],
    touch_px: tuple[float, float],
    phase: str = "stick",
    string: bool = True,
    cid: int = 0,
) -> dict[str, Any]:
    c: dict[str, Any] = {
        "id": cid,
        "phase": phase,
        "touch_m": [touch_px[0] / 10000, touch_px[1] / 10000],
        "pointer_m": [pointer_px[0] / 10000, pointer_px[1] / 10000],
        "touch_px": [float(touch_px[0]), float(touch_px[1])],
        "pointer_px": [float(pointer_px[0]), float(pointer_px[1])],
        "tension": 0.001,
        "material": "sticky",
    }
    if string:
        dx, dy = touch_px[0] - pointer_px[0], touch_px[1] - pointer_px[1]
        n = math.hypot(dx, dy)
        c["string"] = {
            "length_px": 2000 * math.sqrt(0.001),
            "dir": [dx / n, dy / n] if n else [0.0, 0.0],
        }
    return c


def make_frame(
    tick: int, device: str = "pen", contacts: list[dict[str, Any]] | None = None, **extra: Any
) -> dict[str, Any]:
    return {
        "v": protocol.SCHEMA_VERSION,
        "kind": "frame",
        "tick": tick,
        "t": 100.0 + tick * 0.01,
        "t_input": 100.0 + tick * 0.01 - 0.002,
        "device": device,
        "contacts": contacts if contacts is not None else [],
        **extra,
    }


def stroke(n: int = 50, device: str = "pen") -> list[dict[str, Any]]:
    """A horizontal stroke: the pointer sticks while the touch moves away."""
    out = []
    for i in range(n):
        touch = (100.0 + 2 * i, 150.0)
        pointer = (100.0, 150.0) if i < n // 2 else touch
        phase = "stick" if i < n // 2 else "slip"
        out.append(make_frame(i, device, [make_contact(pointer, touch, phase)]))
    return out


class FakeDaemon:
    def __init__(
        self,
        pub: str,
        control: str | None = None,
        context: zmq.Context[Any] | None = None,
        curve_secret: Path | None = None,
    ) -> None:
        self.pub_endpoint = pub
        self.control_endpoint = control
        self._own_ctx = context is None
        self.ctx = context or zmq.Context()
        self.pub = self.ctx.socket(zmq.XPUB)
        self.pub.setsockopt(zmq.LINGER, 0)
        self.pub.setsockopt(zmq.SNDHWM, 100_000)
        if curve_secret is not None:  # a network daemon: CURVE server, ZAP-checked clients
            public, secret = zmq.auth.load_certificate(str(curve_secret))
            self.pub.zap_domain = b"stiction"
            self.pub.curve_publickey = public
            self.pub.curve_secretkey = secret
            self.pub.curve_server = True
        self.pub.bind(pub)
        self.snapshot: dict[str, Any] = {"tick": -1, "scene": SCENE, "frames": {}}
        self.params: dict[str, Any] = {"k": 0.1, "m": 1e-4, "mu_k": 0.1, "C_l": 2000.0}
        self.requests: list[str] = []
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        if control is not None:
            self._thread = threading.Thread(target=self._serve, args=(control,), daemon=True)
            ready = threading.Event()
            self._ready = ready
            self._thread.start()
            assert ready.wait(10)

    def _serve(self, endpoint: str) -> None:
        rep = self.ctx.socket(zmq.REP)
        rep.setsockopt(zmq.LINGER, 0)
        rep.bind(endpoint)
        self._ready.set()
        try:
            while not self._stop.is_set():
                if not rep.poll(50):
                    continue
                try:
                    op, _args = protocol.parse_request(rep.recv())
                except ProtocolError as exc:
                    rep.send(protocol.error_reply(str(exc)))
                    continue
                self.requests.append(op)
                if op == "snapshot":
                    rep.send(protocol.ok_reply(**self.snapshot))
                elif op == "get_scene":
                    rep.send(protocol.ok_reply(scene=SCENE, toml=""))
                elif op == "get_params":
                    rep.send(protocol.ok_reply(params=self.params))
                else:
                    rep.send(protocol.ok_reply())
        finally:
            rep.close(0)

    def wait_subscribers(self, n: int = 1, timeout: float = 10.0) -> list[bytes]:
        """Block until n subscription messages arrived; returns their topics."""
        topics = []
        while len(topics) < n:
            if not self.pub.poll(int(timeout * 1000)):
                raise TimeoutError(f"only {len(topics)} of {n} subscriptions arrived")
            msg = self.pub.recv()
            if msg[:1] == b"\x01":
                topics.append(msg[1:])
        return topics

    def send(self, message: dict[str, Any], topic: bytes | None = None) -> None:
        if topic is None:
            topic = (
                protocol.frame_topic(message["device"])
                if message.get("kind") == "frame"
                else protocol.TOPIC_SCENE
            )
        self.pub.send_multipart([topic, protocol.encode(message)])

    def send_raw(self, *parts: bytes) -> None:
        self.pub.send_multipart(list(parts))

    def close(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(5)
        self.pub.close(0)
        if self._own_ctx:
            self.ctx.term()


CHROMIUM = "/usr/bin/chromium"
CHROMIUM_ARGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
]


STICTIOND = Path(sys.executable).with_name("stictiond")
WAITED_FOR = "name:A tablet not plugged in"  # a device spec that never turns up
DEMO_SCENE = REPO / "src" / "stiction" / "scene" / "examples" / "demo.toml"
