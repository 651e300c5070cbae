"""An idle daemon: with nothing happening the loop stops ticking (a keep-alive
tick now and then), and whatever makes work (input, a control request, a
stop) wakes it. Ticks stay consecutive; `t` jumps over the idle deadlines.

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


def _until(sub: zmq.Socket[Any], pred: Any) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """The first frame that satisfies pred, and every frame before it."""
    before: list[dict[str, Any]] = []
    while True:
        f = _frames(sub, 1)[0]
        if pred(f):
            return f, before
        before.append(f)


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
        # A pen comes into range: the loop wakes and ticks on the same grid,
        # the tick after the last one it ran, with a frame for the device.
        src.feed(PenSample(t=0.0, x=0.05, y=0.05, tip=False))
        hover, quiet = _until(sub, lambda f: f["contacts"])
        assert [c["phase"] for c in hover["contacts"]] == ["hover"]
        chain = [first, *quiet, hover]
        assert [f["tick"] for f in chain] == list(range(len(chain)))  # consecutive
        assert all(b["prev_tick"] == a["tick"] for a, b in itertools.pairwise(chain))
        assert hover["tick"] == ticks  # no tick ran while idle
        start, rate = d.schedule.start, d.schedule.rate
        n = round((hover["t"] - start) * rate)
        assert hover["t"] == pytest.approx(start + n / rate, abs=1e-9)  # on the grid
        assert n >= hover["tick"]  # t jumps over idle deadlines, tick does not
        # While a contact lasts the device is active: a frame every tick.
        assert not entered.is_set()
        src.feed(PenSample(t=0.01, x=0.05, y=0.05, tip=False, in_range=False))
        up, hovering = _until(sub, lambda f: any(c["phase"] == "up" for c in f["contacts"]))
        ticks_seen = [hover["tick"], *(f["tick"] for f in hovering), up["tick"]]
        assert ticks_seen == list(range(hover["tick"], up["tick"] + 1))
        after = _frames(sub, 1)[0]
        assert after["contacts"] == [] and after["tick"] == up["tick"] + 1
        assert entered.wait(5)  # and quiet again
        stats = request(ctx, endpoints[1], protocol.make_request("stats"))["stats"]
        # How many deadlines passed while idle depends on this machine's speed;
        # that each was counted, and that the loop was woken, does not.
        assert stats["skipped_deadlines"] == 0
        assert stats["idle_deadlines"] >= n - hover["tick"]
        assert stats["idle_wakes"] >= 2
    assert not d.waker.armed
    sub.close()


def test_keepalive_ticks_come_on_time(endpoints: tuple[str, str]) -> None:
    d = make_daemon(endpoints, {"pen": FedSource()}, keepalive=0.05)
    ctx = zmq.Context.instance()
    sub = subscribe(ctx, d, endpoints[0])
    with Runner(d):
        frames = _frames(sub, 8)
    sub.close()
    assert [f["tick"] for f in frames] == list(range(8))
    assert [f["prev_tick"] for f in frames] == list(range(-1, 7))
    # After the first two ticks (the second one finds nothing new), one tick
    # per keep-alive: at least 50 ms apart and no more than a period late.
    for a, b in itertools.pairwise(frames[1:]):
        assert 0.04 - 1e-9 <= b["t"] - a["t"] <= 0.06 + 1e-9
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


def test_keepalive_zero_ticks_every_period_and_never_idles(endpoints: tuple[str, str]) -> None:
    d = make_daemon(endpoints, {"pen": FedSource()}, keepalive=0)
    entered = _tap(d)
    ctx = zmq.Context.instance()
    sub = subscribe(ctx, d, endpoints[0])
    with Runner(d):
        frames = _frames(sub, 20)
        assert not entered.is_set()
    sub.close()
    assert [f["tick"] for f in frames] == list(range(frames[0]["tick"], frames[0]["tick"] + 20))
    assert all(b["prev_tick"] == a["tick"] for a, b in itertools.pairwise(frames))
    assert d.schedule.slept == 0


def test_a_nap_is_ended_by_a_producer_and_not_counted_as_an_idle_wake_up() -> None:
    w = Waker()
    w.arm(count=False)
    threading.Thread(target=w.wake).start()
    assert w.nap(30.0) is True
    w.disarm()
    assert w.wakes == 0
    w.arm()
    w.wake()
    assert w.wait(0.0) is True and w.wakes == 1
    w.arm(count=False)
    assert w.nap(0.0) is False  # not woken: the nap ran its length
