"""The stats reply's two measures of a live tick: wall clock and CPU time.

`tick_cost_ms` is the wall-clock time from the wake-up to the end of the
tick, so a tick whose thread is preempted (or blocked) counts the wait;
`tick_cpu_ms` is the loop thread's CPU time in the same tick, the work
alone. `stiction bench daemon` reports both (issue 15's tick-work target).
Here one tick is held up by a publisher that blocks, as a preemption
would: its wall-clock time must show it, its CPU time must not.
"""

from __future__ import annotations

import threading
from typing import Any

from daemon_support import ListSource, Runner, make_daemon, stroke

from stiction.daemon.publisher import Recorder

HELD_S = 0.02


class BlockingOnce(Recorder):
    """A publisher whose fifth send blocks HELD_S without using the CPU."""

    def __init__(self) -> None:
        super().__init__()
        self._gate = threading.Event()  # never set: wait() only times out

    def send_payload(self, topic: bytes, payload: bytes) -> None:
        # Both sends end here: a message's (Recorder.send) and a payload
        # encoded before the deadline (the loop's prepared tick).
        if self.sent == 4:
            self._gate.wait(HELD_S)
        super().send_payload(topic, payload)


def test_a_held_up_tick_costs_wall_clock_time_but_no_cpu_time(
    endpoints: tuple[str, str],
) -> None:
    pub = BlockingOnce()
    gate = threading.Event()  # keeps the device open after its stroke
    pen = ListSource(stroke(n=30), gate=gate)
    d = make_daemon(endpoints, {"pen": pen}, publisher=pub, keepalive=0)
    seen: dict[str, Any] = {}
    done = threading.Event()

    def on_tick(n: int) -> None:
        if n == 10 and not done.is_set():
            seen.update(d.stats())
            done.set()

    d.on_tick = on_tick
    with Runner(d):
        assert done.wait(10)
        gate.set()
    wall, cpu = seen["tick_cost_ms"], seen["tick_cpu_ms"]
    assert wall["max"] >= HELD_S * 1e3
    assert 0 <= cpu["p50"] <= wall["p50"] + 0.05
    assert cpu["max"] < HELD_S * 1e3 / 2  # the 20 ms wait is not work
