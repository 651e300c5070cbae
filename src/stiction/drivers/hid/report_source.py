"""A SampleSource over any stream of timestamped raw reports.

The hidraw backend, the replay of a recording and the synthetic tablet all
end here, so pacing, closing and the counters behave the same for each.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterable, Iterator

from stiction.drivers.hid.stream import ReportStream
from stiction.drivers.limits import GapCompressor
from stiction.drivers.sample import PenSample


class ReportSource:
    """Decodes `reports` (an iterable of (t, bytes)) through `stream`.

    A backend yields (t, None) when a read timed out with nothing to read,
    so the stream can notice a tablet that went silent (`ReportStream.idle`).

    With `realtime`, samples are released at their recorded spacing from the
    moment `samples()` starts (the replay speed of hid-recorder's files);
    otherwise as fast as the consumer takes them. `on_close` releases the
    backend (the hidraw handle); it runs once.
    """

    def __init__(
        self,
        name: str,
        stream: ReportStream,
        reports: Iterable[tuple[float, bytes | None]],
        realtime: bool = False,
        on_close: Callable[[], None] | None = None,
        compress_gaps: bool = False,
    ) -> None:
        """`compress_gaps`: a recording's pauses are cut to limits.MAX_GAP_S (replays only;
        a live device's times are the clock's)."""
        self._name = name
        self._compress_gaps = compress_gaps
        self.stream = stream
        self._reports = reports
        self._realtime = realtime
        self._closed = threading.Event()
        self._on_close = on_close
        self._close_lock = threading.Lock()

    @property
    def name(self) -> str:
        return self._name

    @property
    def surface_size(self) -> tuple[float, float] | None:
        return self.stream.surface_size

    @property
    def kind(self) -> str:
        return self.stream.kind if self.stream.kind != "other" else "pen"

    @property
    def closed(self) -> bool:
        return self._closed.is_set()

    def samples(self) -> Iterator[PenSample]:
        start_wall: float | None = None
        start_t = 0.0
        feed = self.stream.feed
        compress = GapCompressor(self.name) if self._compress_gaps else None
        for t, data in self._reports:
            if self._closed.is_set():
                return
            if compress is not None:
                t = compress(t)
            if self._realtime:
                now = time.monotonic()
                if start_wall is None:
                    start_wall, start_t = now, t
                delay = start_wall + (t - start_t) - now
                if delay > 0 and self._closed.wait(delay):
                    return
            if data is None:
                yield from self.stream.idle(t)
            else:
                yield from feed(t, data)

    def close(self) -> None:
        with self._close_lock:
            if self._closed.is_set():
                return
            self._closed.set()
        if self._on_close is not None:
            self._on_close()

    def stats(self) -> dict[str, int]:
        return dict(self.stream.stats)
