"""Fixed-rate tick deadlines that never drift and never cascade.

Deadline n is ``start + n / rate`` computed from n, never by adding a period
to the previous deadline, so rounding cannot accumulate over a long run. A
tick that starts more than `late_threshold` after its deadline is counted as
late; if the loop falls so far behind that the next deadline has already
passed, the missed deadlines are skipped (and counted) rather than run back
to back, so one hiccup costs one late tick, not a burst of them.

The clock is separate from the schedule: `RealClock` sleeps on the monotonic
clock, `VirtualClock` jumps straight to each deadline, so a replay runs as
fast as the machine allows and gives the same ticks every time.
"""

from __future__ import annotations

import math
import time
from typing import Protocol


class Clock(Protocol):
    def now(self) -> float: ...
    def sleep_until(self, deadline: float) -> None: ...


class RealClock:
    """time.monotonic; sleeping uses the OS's high-resolution sleep."""

    virtual = False

    def now(self) -> float:
        return time.monotonic()

    def sleep_until(self, deadline: float) -> None:
        remaining = deadline - time.monotonic()
        if remaining > 0:
            time.sleep(remaining)


class VirtualClock:
    """Time is whatever the last deadline was: ticks cost no waiting."""

    virtual = True

    def __init__(self, start: float = 0.0) -> None:
        self._now = start

    def now(self) -> float:
        return self._now

    def sleep_until(self, deadline: float) -> None:
        self._now = max(self._now, deadline)


class Schedule:
    """Deadlines on a fixed grid, with late and skipped ticks counted."""

    def __init__(self, rate: float, start: float, late_threshold: float | None = None) -> None:
        if not (math.isfinite(rate) and rate > 0):
            raise ValueError(f"rate must be a positive number, got {rate}")
        self.rate = rate
        self.start = start
        self.late_threshold = 0.5 / rate if late_threshold is None else late_threshold
        self.index = 0
        """Grid index of the next deadline (skipped deadlines advance it too)."""
        self.ticks = 0
        """Ticks run so far: the wire tick number of the next tick."""
        self.late = 0
        self.skipped = 0

    @property
    def deadline(self) -> float:
        return self.start + self.index / self.rate

    def begin(self, now: float) -> float:
        """Record that the tick for the current deadline starts at `now`;
        returns its lateness (seconds, negative if early)."""
        lateness = now - self.deadline
        if lateness > self.late_threshold:
            self.late += 1
        return lateness

    def finish(self, now: float) -> None:
        """Move to the next deadline after `now`, skipping any already missed."""
        self.ticks += 1
        self.index += 1
        if self.deadline < now:
            behind = math.floor((now - self.start) * self.rate) + 1
            self.skipped += behind - self.index
            self.index = behind
