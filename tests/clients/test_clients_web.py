"""The web renderer in real headless Chromium: the page connects through the
bridge, and after a replayed stroke the canvas shows the pointer and the
string where the last frame says."""

from __future__ import annotations

import asyncio
import contextlib
import json
import threading
import urllib.request
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from clients_support import SCENE, WAITED_FOR, FakeDaemon, make_frame, scene_message

from stiction import protocol
from stiction.clients import SceneMessage, Subscriber, recording
from stiction.clients.messages import Frame
from stiction.clients.replay import Replayer
from stiction.clients.web import server
from stiction.clients.web.bridge import Bridge

pytest_plugins = ["clients_fixtures"]

pytestmark = pytest.mark.browser


class WebServer:
    """`stiction web` in a thread with its own event loop, on a free port."""

    def __init__(self, pub: str, control: str | None) -> None:
        self.loop = asyncio.new_event_loop()
        self.ready: asyncio.Future[str] = self.loop.create_future()
        self.task: asyncio.Task[None] | None = None
        self.thread = threading.Thread(target=self._main, args=(pub, control), daemon=True)
        self.thread.start()
        self.url = asyncio.run_coroutine_threadsafe(self._url(), self.loop).result(30)

    async def _url(self) -> str:
        return await self.ready

    def _main(self, pub: str, control: str | None) -> None:
        asyncio.set_event_loop(self.loop)
        self.task = self.loop.create_task(
            server.run(pub, control, "127.0.0.1", 0, ready=self.ready)
        )
        with contextlib.suppress(asyncio.CancelledError):
            self.loop.run_until_complete(self.task)
        self.loop.close()

    def status(self) -> dict[str, Any]:
        with urllib.request.urlopen(self.url + "status", timeout=10) as r:
            return dict(json.loads(r.read()))

    def stop(self) -> None:
        if self.task is not None:
            self.loop.call_soon_threadsafe(self.task.cancel)
        self.thread.join(30)


@contextlib.contextmanager
def web_page(
    browser: Any, pub: str, ctl: str | None, width: int, height: int
) -> Iterator[tuple[WebServer, Any]]:
    """A `WebServer` on pub/ctl and a browser page of that viewport showing it."""
    web = WebServer(pub, ctl)
    try:
        page = browser.new_page(viewport={"width": width, "height": height})
        try:
            page.goto(web.url)
            yield web, page
        finally:
            page.close()
    finally:
        web.stop()


@contextlib.contextmanager
def replaying(rec: recording.Recording, pub: str, ctl: str, **run: Any) -> Iterator[None]:
    """Replay `rec` on pub/ctl from a thread once a page subscribes, with
    `Replayer.run(**run)`, then keep its endpoints up until the block ends."""
    player = Replayer(rec, pub, ctl)
    done = threading.Event()

    def play() -> None:
        if player.wait_for_subscriber(30):
            player.run(**run)
        player.hold(done.is_set, 120)

    t = threading.Thread(target=play, daemon=True)
    t.start()
    try:
        yield
    finally:
        done.set()
        t.join(30)
        player.close()


def stroke_frames() -> list[dict[str, Any]]:
    """Slip from x=40 to 98, then stick at 100 while the touch runs on to 218."""
    frames = []
    for i in range(30):
        x = 40.0 + 2 * i
        c = {
            "id": 0,
            "phase": "slip",
            "touch_m": [x / 1e4, 0.015],
            "pointer_m": [x / 1e4, 0.015],
            "touch_px": [x, 150.0],
            "pointer_px": [x, 150.0],
            "tension": 0.0,
            "material": "sticky",
            "string": {"length_px": 0.0, "dir": [0.0, 0.0]},
        }
        frames.append(make_frame(i, contacts=[c]))
    for j in range(30):
        tx = 100.0 + 4 * (j + 1)
        c = {
            "id": 0,
            "phase": "stick",
            "touch_m": [tx / 1e4, 0.015],
            "pointer_m": [0.01, 0.015],
            "touch_px": [tx, 150.0],
            "pointer_px": [100.0, 150.0],
            "tension": 0.1 * (tx - 100) / 1e4,
            "material": "sticky",
            "string": {"length_px": 0.8 * (tx - 100.0), "dir": [1.0, 0.0]},
        }
        frames.append(make_frame(30 + j, contacts=[c]))
    return frames


def write_recording(path: Path) -> list[dict[str, Any]]:
    frames = stroke_frames()
    messages = [(protocol.TOPIC_SCENE, protocol.encode(scene_message(-1)), 0.0)]
    messages += [
        (protocol.frame_topic("pen"), protocol.encode(f), 0.01 * i) for i, f in enumerate(frames)
    ]
    typed = [Frame.from_wire(protocol.validate_frame(f)) for f in frames]
    recording.write(path, messages, typed, {"scene": SCENE})
    return frames


PIXELS_JS = """
([points]) => {
  const c = document.getElementById('view');
  const ctx = c.getContext('2d');
  return {size: [c.width, c.height],
          px: points.map(([x, y]) => Array.from(ctx.getImageData(x, y, 1, 1).data))};
}
"""


def is_black(p: list[int]) -> bool:
    return p[0] < 40 and p[1] < 40 and p[2] < 40


def is_string(p: list[int]) -> bool:  # #e8710a
    return p[0] > 200 and 80 < p[1] < 140 and p[2] < 50


def test_replayed_stroke_is_drawn_where_the_frames_say(browser: Any, short_dir: Path) -> None:
    frames = write_recording(short_dir / "stroke.npz")
    rec = recording.read(short_dir / "stroke.npz")
    pub, ctl = f"ipc://{short_dir}/pub", f"ipc://{short_dir}/ctl"
    with replaying(rec, pub, ctl, speed=4.0), web_page(browser, pub, ctl, 800, 600) as (_, page):
        last = frames[-1]["tick"]
        page.wait_for_function(
            f"window.stiction && window.stiction.drawnTick === {last}", timeout=30_000
        )
        # Everything below reads the canvas itself: what a person would see.
        points = [
            (100, 150),  # the pointer, stuck
            (147, 150),  # the middle of the string
            (185, 150),  # just inside the string's end (100 + 0.8 * 120 = 196)
            (206, 150),  # beyond the string's end, before the touch ring at 220
            (60, 150),  # where the pointer was during the slip: cleared since
            (30, 40),  # inside the sticky region, away from everything
            (10, 290),  # still the sticky band
        ]
        got = page.evaluate(PIXELS_JS, [points])
        assert got["size"] == [400, 300]  # the scene's display size, 1:1 pixels
        px = got["px"]
        assert is_black(px[0]), px[0]
        assert is_string(px[1]) and is_string(px[2]), px[1:3]
        assert not is_string(px[3]) and not is_black(px[3]), px[3]
        assert not is_black(px[4]) and not is_string(px[4]), px[4]
        assert px[5] == px[6] and px[5][:3] != [250, 250, 250], px[5]
        # The status line says the same in words. Waited for rather than read once:
        # on a loaded machine the page's WebSocket can miss a heartbeat, and the
        # page then says so ("no connection to the bridge") until it reconnects.
        words = ("stick", "string 96.0 px", "sticky", "frames/s", "latency")
        js = "(w) => w.every((x) => document.getElementById('status').innerText.includes(x))"
        page.wait_for_function(js, arg=list(words), timeout=30_000)
        # "f": full screen at one canvas pixel per device pixel.
        page.keyboard.press("f")
        page.wait_for_function("document.body.classList.contains('exact')", timeout=10_000)
        assert page.evaluate("[view.style.width, view.style.height]") == ["400px", "300px"]
        assert not page.is_visible("#status")
        # When the stream stops the page says so, in words: the replay still
        # answers on its control endpoint, and says that its device has ended.
        page.wait_for_function("window.stiction.reason === 'ended'", timeout=30_000)
        assert page.evaluate("window.stiction.status") == "gone"
        assert page.is_visible("#banner")
        assert "its devices have ended" in page.inner_text("#banner")


def test_the_page_tells_a_daemon_without_device_from_no_daemon(
    browser: Any, stictiond_without_device: tuple[str, str], short_dir: Path
) -> None:
    pub, ctl = stictiond_without_device
    with web_page(browser, pub, ctl, 800, 600) as (_, page):
        page.wait_for_function("window.stiction.reason === 'no-device'", timeout=30_000)
        assert page.evaluate("window.stiction.status") == "waiting"
        banner = page.inner_text("#banner")
        assert f"has no device yet: waiting for {WAITED_FOR} (waiting)" in banner, banner
        assert "has no device yet" in page.inner_text("#status")
    nobody = f"ipc://{short_dir}/nobody-pub", f"ipc://{short_dir}/nobody-ctl"
    with web_page(browser, *nobody, 800, 600) as (_, page):
        page.wait_for_function("window.stiction.reason === 'no-daemon'", timeout=30_000)
        assert page.evaluate("window.stiction.status") == "gone"
        banner = page.inner_text("#banner")
        assert f"no daemon answers at {nobody[1]}: is stictiond running?" in banner, banner


def test_bridge_survives_bad_frames_and_reports_a_newer_schema(
    browser: Any, daemon: FakeDaemon
) -> None:
    pub, ctl = daemon.pub_endpoint, daemon.control_endpoint
    with web_page(browser, pub, ctl, 800, 600) as (web, page):
        daemon.wait_subscribers(2)
        page.wait_for_function("window.stiction.scene !== null", timeout=30_000)  # from snapshot
        daemon.send_raw(b"frame.pen", b"\xc1 not msgpack")
        daemon.send({**make_frame(0), "v": protocol.SCHEMA_VERSION + 1})
        page.wait_for_function("window.stiction.status === 'error'", timeout=30_000)
        assert "newer than this client" in page.inner_text("#banner")
        good = stroke_frames()[-1]
        daemon.send(good)
        page.wait_for_function(f"window.stiction.drawnTick === {good['tick']}", timeout=30_000)
        assert page.evaluate("window.stiction.status") == "live"
        px = page.evaluate(PIXELS_JS, [[(100, 150)]])["px"][0]
        assert is_black(px)
        st = web.status()
        assert st["errors"] >= 2 and st["frames"] == 1 and st["pages"] == 1


def test_real_daemon_stroke_replayed_is_drawn_where_its_frames_say(
    browser: Any, stictiond: tuple[str, str], short_dir: Path
) -> None:
    """Frames from the real simulator: record the daemon until the pointer is
    stuck with a long string, cut the recording there, replay it to the page."""
    pub, ctl = stictiond
    messages: list[tuple[bytes, bytes, float]] = []
    typed: list[Frame] = []
    with Subscriber(pub, control=ctl, kinds=["frame", "scene"]) as sub:
        for _ in range(2000):  # at most 20 s of frames
            msg = sub.recv(timeout=10)
            assert msg is not None, "the daemon stopped publishing"
            if isinstance(msg, SceneMessage):
                messages.append((protocol.TOPIC_SCENE, protocol.encode(msg.wire), 0.0))
                continue
            messages.append((protocol.frame_topic(msg.device), protocol.encode(msg.wire), 0.0))
            typed.append(msg)
            stuck = [
                c
                for c in msg.contacts
                if c.phase == "stick" and c.string is not None and c.string.length_px > 30
            ]
            if stuck:
                break
        else:
            pytest.fail("the synthetic stroke never stuck with a string longer than 30 px")
    scene = next(recording_scene(messages))
    recording.write(short_dir / "real.npz", messages, typed, {"scene": scene})
    rec = recording.read(short_dir / "real.npz")
    rpub, rctl = f"ipc://{short_dir}/rp", f"ipc://{short_dir}/rc"
    with (
        replaying(rec, rpub, rctl, fast=True),
        web_page(browser, rpub, rctl, 1000, 640) as (_, page),
    ):
        last = typed[-1]
        page.wait_for_function(f"window.stiction.drawnTick === {last.tick}", timeout=30_000)
        c = stuck[0]
        assert c.string is not None
        px, py = c.pointer_px
        dx, dy = c.string.dir
        along = max(14.0, 0.6 * c.string.length_px)  # past the pointer's ring
        mid = (px + dx * along, py + dy * along)
        got = page.evaluate(PIXELS_JS, [[(round(px), round(py)), (round(mid[0]), round(mid[1]))]])
        assert got["size"] == scene["display"]
        assert is_black(got["px"][0]), got
        assert is_string(got["px"][1]), got


def recording_scene(messages: list[tuple[bytes, bytes, float]]) -> Iterator[dict[str, Any]]:
    for topic, payload, _ in messages:
        if topic == protocol.TOPIC_SCENE:
            yield protocol.decode(payload)["scene"]


def test_a_slow_page_gets_the_latest_frame_not_a_queue() -> None:
    bridge = Bridge("ipc:///nowhere", None)
    page = bridge.attach()
    assert [json.loads(m)["type"] for m in bridge.take(page)] == ["status"]
    for wire in stroke_frames():
        frame = Frame.from_wire(protocol.validate_frame(wire))
        bridge._publish(f"frame:{frame.device}", bridge.frame_json(frame, received=0.0))
    sent = [json.loads(m) for m in bridge.take(page)]
    assert [m["frame"]["tick"] for m in sent] == [59]  # only the newest
    assert bridge.stats.skipped_for_slow_pages == 59
    assert sent[0]["latency_ms"] is None  # t=100.59 is not this clock: no fake latency
    assert bridge.take(page) == []


def test_the_bridge_waits_out_the_daemons_keepalive_before_calling_it_gone(
    endpoints: tuple[str, str],
) -> None:
    """A quiet daemon sends a frame per keep-alive; silence shorter than 2.5 of
    them is not an outage. The keep-alive comes from the snapshot reply."""
    from stiction.clients.web.bridge import SILENT_AFTER

    daemon = FakeDaemon(*endpoints)
    daemon.snapshot["keepalive"] = 4.0
    try:
        bridge = Bridge(*endpoints)
        assert bridge.silent_after == SILENT_AFTER >= 2.5  # the default keep-alive is 1 s
        # Its own thread: a browser test may have left this thread's loop running.
        t = threading.Thread(target=lambda: asyncio.run(bridge._fetch_snapshot()))
        t.start()
        t.join(30)
        assert bridge.silent_after == 10.0
        bridge._check_silence(100.0)  # the silence starts
        bridge._check_silence(109.9)
        assert bridge.stats.state != "gone"
        bridge._check_silence(110.0)
        assert bridge.stats.state == "gone"
    finally:
        daemon.close()


def is_pen(p: list[int]) -> bool:  # #7b1fa2
    return 100 < p[0] < 150 and p[1] < 60 and 140 < p[2] < 190


@pytest.mark.parametrize(("width", "height"), [(1280, 800), (1920, 1080)])
def test_a_newcomer_sees_pen_pointer_legend_and_plain_status(
    browser: Any, short_dir: Path, width: int, height: int
) -> None:
    """Issue 13's demo: the pen apart from the pointer, a legend, a favicon, no
    negative latency, and a status that says the stream stopped instead of
    showing stale rates."""
    frames = write_recording(short_dir / "stroke.npz")
    rec = recording.read(short_dir / "stroke.npz")
    pub, ctl = f"ipc://{short_dir}/pub", f"ipc://{short_dir}/ctl"
    with (
        replaying(rec, pub, ctl, speed=4.0),
        web_page(browser, pub, ctl, width, height) as (web, page),
    ):
        last = frames[-1]
        page.wait_for_function(
            f"window.stiction && window.stiction.drawnTick === {last['tick']}", timeout=30_000
        )
        c = last["contacts"][0]
        tx, ty = c["touch_px"]
        scale = page.evaluate("view.width / view.clientWidth")
        ring = 22 * max(1.0, scale)  # draw.js PEN_RADIUS in CSS px, on the canvas
        got = page.evaluate(PIXELS_JS, [[(round(tx), round(ty - ring)), c["pointer_px"]]])
        assert is_pen(got["px"][0]), got  # the pen's ring, where the pen is
        assert is_black(got["px"][1]), got  # the pointer, apart from it
        legend = page.inner_text("#legend")
        for words in ("sticking", "slipping", "pen", "virtual string"):
            assert words in legend
        status = page.inner_text("#status")
        assert "-" not in status.split("latency", 1)[1], status  # no negative figure
        with urllib.request.urlopen(web.url + "favicon.ico", timeout=10) as r:
            assert r.status == 200 and r.headers["Content-Type"].startswith("image/svg")
        # The replayer stops sending: the status says so instead of old rates.
        page.wait_for_function(
            "['stale', 'gone'].includes(window.stiction.statusState)", timeout=30_000
        )
        stale = page.inner_text("#status")
        assert "frames/s" not in stale and ("no frames" in stale or "no connection" in stale)
        page.screenshot(path=str(short_dir / f"demo-{width}.png"))
