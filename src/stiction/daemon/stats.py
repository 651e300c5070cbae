"""Counters and recent-value windows for the stats reply.

Recording a value must cost the loop next to nothing (one store into a
preallocated array); percentiles are computed only when someone asks.
"""

from __future__ import annotations

import math

import numpy as np


class Window:
    """The last `size` values of one measurement, in a ring."""

    def __init__(self, size: int = 10_000) -> None:
        self._values = np.zeros(size, dtype=np.float64)
        self._n = 0

    def add(self, value: float) -> None:
        self._values[self._n % len(self._values)] = value
        self._n += 1

    @property
    def count(self) -> int:
        return self._n

    def values(self) -> np.ndarray:
        return self._values[: min(self._n, len(self._values))]

    def summary(self, scale: float = 1.0) -> dict[str, float | None]:
        """p50, p99 and max of the window, times `scale` (e.g. 1e3 for ms)."""
        v = self.values()
        if len(v) == 0:
            return {"p50": None, "p99": None, "max": None}
        p50, p99 = np.percentile(v, [50, 99])
        return {
            "p50": round(float(p50) * scale, 4),
            "p99": round(float(p99) * scale, 4),
            "max": round(float(v.max()) * scale, 4),
        }


class RateMeter:
    """Samples per second over the last few seconds of loop time."""

    def __init__(self, span: float = 2.0) -> None:
        self.span = span
        self._t0 = math.nan
        self._count = 0
        # None until one full span has been measured: "no rate yet" is not "0 samples/s".
        self.rate: float | None = None

    def add(self, n: int, now: float) -> None:
        if math.isnan(self._t0):
            self._t0 = now
        self._count += n
        elapsed = now - self._t0
        if elapsed >= self.span:
            self.rate = self._count / elapsed
            self._t0 = now
            self._count = 0
