"""A recording played back as a SampleSource, at recorded pace or as fast as possible.

Sample times are always the recorded kernel times; `realtime` only decides
whether playback waits for them. The wait is on an Event so that close()
returns a blocked samples() at once, and the clock is injectable so tests
can check pacing without sleeping.
"""

from __future__ import annotations

import math
import threading
import time
from collections import Counter
from collections.abc import Callable, Iterator
from pathlib import Path

from stiction.drivers.evdev import sizes
from stiction.drivers.evdev.base import EvdevSourceBase
from stiction.drivers.evdev.frames import Frame, FrameAssembler
from stiction.drivers.evdev.recording import Recording, load
from stiction.drivers.evdev.source import frame_samples
from stiction.drivers.evdev.units import SurfaceUnits
from stiction.drivers.limits import GapCompressor
from stiction.drivers.sample import PenSample

_CHUNK = 4096  # events framed at a time


class ReplaySource(EvdevSourceBase):
    """SampleSource over an evemu or libinput record recording."""

    def __init__(
        self,
        recording: Recording,
        realtime: bool = False,
        size_mm: tuple[float, float] | None = None,
        clock: Callable[[], float] = time.monotonic,
        wait: Callable[[float], bool] | None = None,
    ) -> None:
        desc = sizes.apply(recording.description, size_mm)
        sizes.require(desc)
        self.recording = recording
        self.description = desc
        self.realtime = realtime
        self._units = SurfaceUnits(desc)
        self._clock = clock
        self._closed = threading.Event()
        #: waits up to the given seconds; True if close() was called meanwhile
        self._wait = wait if wait is not None else self._closed.wait
        self._stats: Counter[str] = Counter()
        self._assembler: FrameAssembler | None = None

    def _frames(self, asm: FrameAssembler) -> Iterator[Frame]:
        """Frames in chunks of events: bounded memory for long recordings."""
        events = self.recording.events
        for i in range(0, len(events), _CHUNK):
            chunk = events[i : i + _CHUNK]
            self._stats["events"] += len(chunk)
            yield from asm.feed_many(chunk)
        if events:
            end = asm.finish(events[-1][0], events[-1][1])
            if end is not None:
                yield end

    def samples(self) -> Iterator[PenSample]:
        asm = FrameAssembler(self.description)
        self._assembler = asm
        units = self._units
        start_wall: float | None = None
        start_t = 0.0
        compress = GapCompressor(self.name)
        for frame in self._frames(asm):
            if self._closed.is_set():
                return
            t = compress(frame.time)
            if t != frame.time:
                sec = math.floor(t)
                frame = frame._replace(sec=sec, usec=min(round((t - sec) * 1e6), 999_999))
            if self.realtime:
                if start_wall is None:
                    start_wall, start_t = self._clock(), frame.time
                delay = start_wall + (frame.time - start_t) - self._clock()
                if delay > 0 and self._wait(delay):
                    return
            for s in frame_samples(units, frame):
                self._stats["samples"] += 1
                yield s

    def close(self) -> None:
        self._closed.set()


def open_replay(
    path: str | Path,
    events_path: str | Path | None = None,
    realtime: bool = False,
    size_mm: tuple[float, float] | None = None,
) -> ReplaySource:
    return ReplaySource(load(path, events_path), realtime=realtime, size_mm=size_mm)
