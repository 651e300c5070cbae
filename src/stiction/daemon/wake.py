"""How an idle loop learns that there is work again.

An idle daemon (no contact anywhere, no input arriving) stops ticking and
waits here instead of waking 100 times a second to publish unchanged
frames. Anything that makes work for the loop -- a reader handing over a
sample, a device going away, a control request, a hot-plugged device, a
signal -- calls `wake()`.

The loop arms the waker *before* it checks for work and waits only if it
found none; a producer makes its work visible *before* it wakes. Either the
check sees the work or the producer sees the waker armed, so no wake-up is
lost. Producers call `wake()` only while the waker is armed, so a busy
reader pays one attribute read per sample, not a lock.
"""

from __future__ import annotations

import math
import threading


class Waker:
    def __init__(self) -> None:
        self._event = threading.Event()
        self.armed = False
        self.wakes = 0
        """Times a producer woke the idle loop (a statistic)."""
        self._counting = True

    def arm(self, count: bool = True) -> None:
        """About to look for work; wake-ups from now on are kept.

        `count=False`: a wait that is not idling (the nap between the tick's
        preparation and its deadline, stiction.daemon.prepare): its wake-ups
        are not counted as ends of an idle wait."""
        self._event.clear()
        self._counting = count
        self.armed = True

    def disarm(self) -> None:
        self.armed = False

    def wake(self) -> None:
        """Work is visible: end an idle wait (cheap no-op when not armed)."""
        if self.armed:
            if self._counting:
                self.wakes += 1
            self._event.set()

    def nap(self, timeout: float) -> bool:
        """`wait` for a bounded nap that is not idling (armed with count=False):
        the loop's nap between a prepared tick and its deadline."""
        return self._event.wait(max(0.0, timeout))

    def wait(self, timeout: float) -> bool:
        """Sleep until woken or `timeout` seconds pass (inf: until woken); True if woken."""
        if timeout == math.inf:
            return self._event.wait()
        return self._event.wait(max(0.0, timeout))
