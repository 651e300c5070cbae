"""What `stiction bench daemon` measures of the naive loop's own tick work and
of encoding after a sleep (stiction.bench.daemon). The clock is scripted:
nothing here sleeps or is timed."""

from __future__ import annotations

import time
from typing import Any

import msgpack
import numpy as np
import pytest

from stiction.bench import daemon as bench


class _Clock:
    """monotonic, thread_time and sleep on a made-up timeline."""

    def __init__(self) -> None:
        self.wall = 100.0
        self.cpu = 5.0
        self.slept = False

    def monotonic(self) -> float:
        return self.wall

    def thread_time(self) -> float:
        return self.cpu

    def sleep(self, s: float) -> None:
        self.wall += s + 0.00012  # every wake-up 0.12 ms late
        self.slept = True

    def cold(self, after_sleep: float, again: float) -> None:
        """Take `after_sleep` seconds if nothing ran since the last sleep, else `again`."""
        self.wall += after_sleep if self.slept else again
        self.slept = False


class _Socket:
    """A PUB socket whose send takes 0.3 ms of wall clock, 0.2 ms of it CPU time."""

    def __init__(self, clock: _Clock) -> None:
        self.clock = clock
        self.sent: list[tuple[bytes, bytes]] = []

    def send_multipart(self, parts: tuple[bytes, bytes]) -> None:
        self.sent.append(parts)
        self.clock.wall += 0.0003
        self.clock.cpu += 0.0002


@pytest.fixture
def clock(monkeypatch: pytest.MonkeyPatch) -> _Clock:
    c = _Clock()
    for name in ("monotonic", "thread_time", "sleep"):
        monkeypatch.setattr(time, name, getattr(c, name))
    monkeypatch.setattr(bench, "_schedstat_fd", lambda: None)
    return c


def test_the_publishing_bare_loop_records_each_ticks_work_from_waking_to_the_send(
    clock: _Clock,
) -> None:
    sock = _Socket(clock)
    jitter, late, _, start, _, work = bench.bare_loop(0.05, 100.0, sock, start=clock.wall + 0.01)
    assert len(sock.sent) == 5 and work.shape == (5, 2)
    assert np.allclose(work[:, 0], 0.0003) and np.allclose(work[:, 1], 0.0002)
    assert np.allclose(jitter, 0.00012) and late == 0
    topic, payload = sock.sent[-1]
    msg = msgpack.unpackb(payload)
    assert topic == b"frame.bare" and msg["kind"] == "bare" and msg["tick"] == 4
    assert msg["t"] == pytest.approx(start + 0.04)
    assert msg["contacts"] == [bench.CONTACT]


def test_the_silent_bare_loop_has_no_work_to_report(clock: _Clock) -> None:
    *_, work = bench.bare_loop(0.03, 100.0, None, start=clock.wall + 0.01)
    assert work.shape == (0, 2)


def test_encoding_after_a_sleep_reports_both_ways_and_their_ratio(clock: _Clock) -> None:
    calls: list[str] = []
    real_packb = msgpack.packb

    def packb(obj: Any, **kw: Any) -> bytes:
        calls.append("packb")
        clock.cold(0.00004, 0.000004)  # the naive way: 40 us after a sleep, 4 us again
        return bytes(real_packb(obj, **kw))

    def encode(obj: Any) -> bytes:
        calls.append("encode")
        clock.cold(0.00002, 0.000002)  # the kept Packer: 20 us after a sleep, 2 us again
        return bytes(real_packb(obj, use_bin_type=True))

    # perf_counter is what it reads: the scripted wall clock
    mp = pytest.MonkeyPatch()
    try:
        mp.setattr(time, "perf_counter", clock.monotonic)
        mp.setattr(msgpack, "packb", packb)
        mp.setattr("stiction.protocol.encode", encode)
        got = bench.encode_after_sleep(rounds=5, sleep_s=0.005)
    finally:
        mp.undo()
    # one call of each to check they agree, then interleaved round by round
    assert calls[2:] == ["packb", "packb", "encode", "encode"] * 5
    assert got["packb_p50_us"] == pytest.approx(40.0)
    assert got["encode_p50_us"] == pytest.approx(20.0)
    assert got["packb_over_encode"] == pytest.approx(2.0)
    assert got["packb_again_p50_us"] == pytest.approx(4.0)
    assert got["encode_again_p50_us"] == pytest.approx(2.0)
    assert got["sleep_ms"] == 5.0 and got["rounds"] == 5


def test_late_ticks_that_cannot_be_set_beside_the_bare_loop_are_said_to_be() -> None:
    d = {"late": 3, "late_own": [17], "late_with_bare_held_up": 1}
    assert bench.late_split(d) == "1 with the bare loop on time, 1 not set beside it"
    d = {"late": 2, "late_own": [17], "late_with_bare_held_up": 1}
    assert bench.late_split(d) == "1 with the bare loop on time"
