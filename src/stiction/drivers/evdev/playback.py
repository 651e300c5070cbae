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

import numpy as np

from stiction.drivers import limits
from stiction.drivers.evdev import columns, sizes
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
        self._data: bytes | None = None  # the events packed, at the first fast replay

    def _frames(self, asm: FrameAssembler) -> Iterator[Frame]:
        """Frames in chunks of events: bounded memory for long recordings."""
        events = self.recording.events
        for i in range(0, len(events), _CHUNK):
            chunk = events[i : i + _CHUNK]
            self._stats["events"] += len(chunk)
            yield from asm.feed_many(chunk)
        yield from self._end(asm)

    def _end(self, asm: FrameAssembler) -> Iterator[Frame]:
        events = self.recording.events
        if events:
            end = asm.finish(events[-1][0], events[-1][1])
            if end is not None:
                yield end

    def samples(self) -> Iterator[PenSample]:
        asm = FrameAssembler(self.description)
        self._assembler = asm
        compress = GapCompressor(self.name)
        if self.realtime:
            yield from self._paced(asm, compress)
            return
        closed = self._closed.is_set
        stats = self._stats
        for made in self._batches(asm, compress):
            for i, s in enumerate(made):
                if closed():
                    stats["samples"] += i
                    return
                yield s
            stats["samples"] += len(made)

    def _batches(self, asm: FrameAssembler, compress: GapCompressor) -> Iterator[list[PenSample]]:
        """As fast as possible: each chunk of frames in one compiled pass (columns.py).

        Chunks end at a SYN_REPORT, so each starts on a frame boundary; a chunk
        the compiled loop refuses (SYN_DROPPED in it, a short one) goes frame
        by frame, as `_paced` does. Same samples either way
        (tests/evdev/test_evdev_columns.py). The first chunk compiles the loop
        (seconds once, then loaded from numba's cache)."""
        events = self.recording.events
        data = self._packed()
        units = self._units
        size = columns.EVENT.itemsize

        def retime(t: np.ndarray) -> np.ndarray:
            return _compress_many(compress, t)

        start = 0
        for end in self._chunk_ends():
            self._stats["events"] += end - start
            made = None
            if data is not None and end - start >= columns.MIN_EVENTS:
                made = columns.samples(asm, units, data[start * size : end * size], retime)
            if made is None:
                made = []
                for frame in asm.feed_many(events[start:end]):
                    made += frame_samples(units, _retimed(frame, compress))
            yield made
            start = end
        for frame in self._end(asm):
            yield frame_samples(units, _retimed(frame, compress))

    def _chunk_ends(self) -> list[int]:
        """Where the chunks end: the first SYN_REPORT at or after every _CHUNK events."""
        events = self.recording.events
        ends = []
        i = 0
        n = len(events)
        while i < n:
            j = min(i + _CHUNK, n) - 1
            while j < n - 1 and not (events[j][2] == 0 and events[j][3] == 0):
                j += 1
            ends.append(j + 1)
            i = j + 1
        return ends

    def _packed(self) -> bytes | None:
        """The recording as read() would return it, packed at the first fast replay.

        None when it cannot be packed (values beyond input_event's fields, or
        no compiled loop on this platform): then every chunk goes frame by frame."""
        if self._data is None and columns.AVAILABLE:
            try:
                self._data = np.array(self.recording.events, dtype=columns.EVENT).tobytes()
            except (OverflowError, ValueError, TypeError):
                self._data = b""  # values beyond input_event's fields: event by event
        return self._data or None

    def _paced(self, asm: FrameAssembler, compress: GapCompressor) -> Iterator[PenSample]:
        """At the recorded pace: frame by frame, waiting for each one's time."""
        units = self._units
        start_wall: float | None = None
        start_t = 0.0
        for frame in self._frames(asm):
            if self._closed.is_set():
                return
            frame = _retimed(frame, compress)
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


def _retimed(frame: Frame, compress: GapCompressor) -> Frame:
    """The frame with its pause-compressed time (microsecond resolution, as recorded)."""
    t = compress(frame.time)
    if t != frame.time:
        sec = math.floor(t)
        frame = frame._replace(sec=sec, usec=min(round((t - sec) * 1e6), 999_999))
    return frame


def _compress_many(compress: GapCompressor, t: np.ndarray) -> np.ndarray:
    """`_retimed(frame, compress).time` of many frames at once: the same floats.

    The compressor's shift grows by each pause's excess, in order: a
    cumulative sum (np.add.accumulate adds one by one, like the loop it
    replaces); its state is left as the frame-by-frame calls would leave it."""
    if t.size == 0:
        return t
    prev = compress.prev
    before = np.empty(t.size)
    before[0] = t[0] if prev is None else prev
    before[1:] = t[:-1]
    gap = t - before
    over = gap > compress.max_gap
    compress.prev = float(t[-1])
    if not over.any():
        shift = compress.shift
        if shift == 0.0:
            return t
        shifted = t - shift
    else:
        if not compress.logged:
            first = int(np.flatnonzero(over)[0])
            limits.log.info(
                "%s: a pause of %.1f s replayed as %.1f s",
                compress.name,
                gap[first],
                compress.max_gap,
            )
            compress.logged = True
        extra = np.where(over, gap - compress.max_gap, 0.0)
        extra[0] += compress.shift
        shifts = np.add.accumulate(extra)
        compress.shift = float(shifts[-1])
        shifted = t - shifts
    sec = np.floor(shifted)
    usec = np.minimum(np.round((shifted - sec) * 1e6), 999_999)
    return np.where(shifted != t, sec + usec / 1e6, t)


def open_replay(
    path: str | Path,
    events_path: str | Path | None = None,
    realtime: bool = False,
    size_mm: tuple[float, float] | None = None,
) -> ReplaySource:
    return ReplaySource(load(path, events_path), realtime=realtime, size_mm=size_mm)
