"""An idle daemon: frames with nothing new are held back, the loop stops
ticking, and whatever makes work (input, a control request, a stop) wakes it.

Real clock and real sockets, but no sleeps: every wait is for an event the
daemon signals, with a timeout only as a safety net.
"""

from __future__ import annotations

import itertools
import queue
import threading
from collections.abc import Iterator
from typing import Any

import msgpack
import pytest
import zmq
from daemon_support import Runner, make_daemon, request, subscribe

from stiction import protocol
from stiction.daemon.clock import Schedule
from stiction.daemon.service import Daemon
from stiction.daemon.wake import Waker
from stiction.drivers.sample import PenSample


class FedSource:
    """A device whose samples the test hands over one batch at a time."""

    name = "fed-pen"
    surface_size = (0.2, 0.1)
    kind = "pen"

    def __init__(self) -> None:
        self.inbox: queue.SimpleQueue[PenSample | None] = queue.SimpleQueue()

    def samples(self) -> Iterator[PenSample]:
        while (s := self.inbox.get()) is not None:
            yield s

    def feed(self, *samples: PenSample) -> None:
        for s in samples:
            self.inbox.put(s)

    def close(self) -> None:
        self.inbox.put(None)

    def stats(self) -> dict[str, int]:
        return {}


def _tap(d: Daemon) -> threading.Event:
    """An event that is set while the loop is in an idle wait."""
    entered = threading.Event()
    wait = d.waker.wait

    def watched(timeout: float) -> bool:
        entered.set()
        try:
            return wait(timeout)
        finally:
            entered.clear()

    d.waker.wait = watched  # type: ignore[method-assign]
    return entered


def _frames(sub: zmq.Socket[Any], n: int) -> list[dict[str, Any]]:
    out: list[dict[str, Any]] = []
    while len(out) < n:
        assert sub.poll(5000), f"only {len(out)} of {n} frames within 5 s each"
        _, payload = sub.recv_multipart()
        m = msgpack.unpackb(payload)
        if m["kind"] == "frame":
            out.append(m)
    return out


def test_waker_keeps_a_wake_up_that_comes_between_check_and_wait() -> None:
    w = Waker()
    w.wake()  # not armed: nothing is kept, nothing counted
    assert w.wakes == 0 and not w.wait(0)
    w.arm()
    w.wake()  # the producer made work visible after the loop checked
    assert w.wait(10) is True and w.wakes == 1
    w.disarm()
    w.arm()  # re-arming forgets the old wake-up
    assert w.wait(0) is False


def test_waker_wait_forever_ends_when_woken_from_another_thread() -> None:
    w = Waker()
    w.arm()
    threading.Thread(target=w.wake).start()
    assert w.wait(float("inf")) is True


def test_resume_rejoins_the_grid_without_counting_late_or_skipped() -> None:
    s = Schedule(100.0, 10.0)
    s.begin(10.0)
    s.finish(10.0001)
    s.resume(12.3456)  # idle for 2.3 s
    assert s.index == 235 and s.deadline == pytest.approx(12.35)
    assert s.slept == 234 and s.late == 0 and s.skipped == 0
    s.resume(12.35)  # exactly on a deadline: that one is next
    assert s.index == 235
    s.resume(12.0)  # the past never moves it back
    assert s.index == 235 and s.slept == 234


def test_a_quiet_device_lets_the_loop_sleep_and_input_wakes_it(
    endpoints: tuple[str, str],
) -> None:
    src = FedSource()
    d = make_daemon(endpoints, {"pen": src}, keepalive=30.0)
    entered = _tap(d)
    ctx = zmq.Context.instance()
    sub = subscribe(ctx, d, endpoints[0])
    with Runner(d):
        first = _frames(sub, 1)[0]
        assert first["prev_tick"] == -1 and first["contacts"] == []
        # Nothing to say: the loop waits, no longer ticking.
        assert entered.wait(5)
        ticks = d.schedule.ticks
        # A control request is answered while idle, by the loop itself.
        reply = request(ctx, endpoints[1], protocol.make_request("stats"))
        assert reply["ok"] and reply["stats"]["ticks"] == ticks
        assert entered.wait(5)
        # A pen comes into range: the loop wakes and publishes on the grid.
        src.feed(PenSample(t=0.0, x=0.05, y=0.05, tip=False))
        hover = _frames(sub, 1)[0]
        assert [c["phase"] for c in hover["contacts"]] == ["hover"]
        assert hover["prev_tick"] == first["tick"] and hover["tick"] > first["tick"] + 1
        start, rate = d.schedule.start, d.schedule.rate
        assert hover["t"] == pytest.approx(start + hover["tick"] / rate, abs=1e-9)
        # While a contact lasts the device is active: a frame every tick.
        assert not entered.is_set()
        src.feed(PenSample(t=0.01, x=0.05, y=0.05, tip=False, in_range=False))
        frames = _frames(sub, 2)
        assert [c["phase"] for c in frames[0]["contacts"]] == ["up"]
        # The hover frame said all there was until the pen left: held back till then.
        assert frames[0]["prev_tick"] == hover["tick"]
        assert frames[1]["contacts"] == [] and frames[1]["prev_tick"] == frames[0]["tick"]
        assert entered.wait(5)  # and quiet again
        stats = request(ctx, endpoints[1], protocol.make_request("stats"))["stats"]
        # How many deadlines passed while idle depends on this machine's speed;
        # that the loop was woken (request, input) does not.
        assert stats["idle_deadlines"] >= 0 and stats["idle_wakes"] >= 2
        assert stats["skipped_deadlines"] == 0
    assert not d.waker.armed
    sub.close()


def test_keepalive_frames_come_on_time_and_chain(endpoints: tuple[str, str]) -> None:
    d = make_daemon(endpoints, {"pen": FedSource()}, keepalive=0.05)
    ctx = zmq.Context.instance()
    sub = subscribe(ctx, d, endpoints[0])
    with Runner(d):
        frames = _frames(sub, 6)
    sub.close()
    assert frames[0]["prev_tick"] == -1
    for a, b in itertools.pairwise(frames):
        assert b["prev_tick"] == a["tick"]
        # at least the keep-alive apart, and no more than one tick late
        assert 0.05 - 1e-9 <= b["t"] - a["t"] <= 0.06 + 1e-9
        assert b["contacts"] == []


def test_stop_ends_an_idle_loop_at_once(endpoints: tuple[str, str]) -> None:
    d = make_daemon(endpoints, {"pen": FedSource()}, keepalive=3600.0)
    entered = _tap(d)
    result: list[int] = []
    t = threading.Thread(target=lambda: result.append(d.run()))
    t.start()
    try:
        assert entered.wait(5)
        d.request_stop()
        t.join(5)
        assert not t.is_alive() and result == [0]
    finally:
        d.request_stop()
        t.join(5)
        d.close()


def test_keepalive_zero_publishes_every_tick_and_never_idles(endpoints: tuple[str, str]) -> None:
    d = make_daemon(endpoints, {"pen": FedSource()}, keepalive=0)
    entered = _tap(d)
    ctx = zmq.Context.instance()
    sub = subscribe(ctx, d, endpoints[0])
    with Runner(d):
        frames = _frames(sub, 20)
        assert not entered.is_set()
    sub.close()
    # Every deadline the loop ran has its frame; a gap in the ticks is only
    # ever a deadline the machine made it skip (counted), never an idle one.
    assert all(b["prev_tick"] == a["tick"] for a, b in itertools.pairwise(frames))
    gaps = sum(b["tick"] - a["tick"] - 1 for a, b in itertools.pairwise(frames))
    assert gaps <= d.schedule.skipped and d.schedule.slept == 0
