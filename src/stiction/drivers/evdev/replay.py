"""A recording played back as a SampleSource, at recorded pace or as fast as possible.

Sample times are always the recorded kernel times; `realtime` only decides
whether playback waits for them. The wait is on an Event so that close()
returns a blocked samples() at once, and the clock is injectable so tests
can check pacing without sleeping.
"""

from __future__ import annotations

import threading
import time
from collections import Counter
from collections.abc import Callable, Iterator
from pathlib import Path

from stiction.drivers.evdev import sizes
from stiction.drivers.evdev.frames import FrameAssembler
from stiction.drivers.evdev.recording import Recording, load
from stiction.drivers.evdev.source import frame_samples, kind_of, slug
from stiction.drivers.evdev.units import SurfaceUnits
from stiction.drivers.sample import PenSample


class ReplaySource:
    """SampleSource over an evemu or libinput record recording."""

    def __init__(
        self,
        recording: Recording,
        realtime: bool = False,
        size_mm: tuple[float, float] | None = None,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        desc = sizes.apply(recording.description, size_mm)
        sizes.require(desc)
        self.recording = recording
        self.description = desc
        self.realtime = realtime
        self._units = SurfaceUnits(desc)
        self._clock = clock
        self._closed = threading.Event()
        self._stats: Counter[str] = Counter()
        self._assembler: FrameAssembler | None = None

    @property
    def name(self) -> str:
        return slug(self.description.name)

    @property
    def surface_size(self) -> tuple[float, float] | None:
        return self._units.surface_size

    @property
    def kind(self) -> str:
        return kind_of(self.description)

    def samples(self) -> Iterator[PenSample]:
        asm = FrameAssembler(self.description)
        self._assembler = asm
        events = self.recording.events
        start_wall: float | None = None
        start_t = 0.0
        units = self._units
        feed = asm.feed
        last = (0, 0)
        for sec, usec, t, c, v in events:
            if self._closed.is_set():
                return
            self._stats["events"] += 1
            last = (sec, usec)
            frame = feed(sec, usec, t, c, v)
            if frame is None:
                continue
            if self.realtime:
                if start_wall is None:
                    start_wall, start_t = self._clock(), frame.time
                delay = start_wall + (frame.time - start_t) - self._clock()
                if delay > 0 and self._closed.wait(delay):
                    return
            for s in frame_samples(units, frame):
                self._stats["samples"] += 1
                yield s
        end = asm.finish(*last)
        if end is not None:
            for s in frame_samples(units, end):
                self._stats["samples"] += 1
                yield s

    def close(self) -> None:
        self._closed.set()

    def stats(self) -> dict[str, int]:
        out = dict(self._stats)
        if self._assembler is not None:
            out.update(self._assembler.stats)
        return out


def open_replay(
    path: str | Path,
    events_path: str | Path | None = None,
    realtime: bool = False,
    size_mm: tuple[float, float] | None = None,
) -> ReplaySource:
    return ReplaySource(load(path, events_path), realtime=realtime, size_mm=size_mm)
