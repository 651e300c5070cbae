"""The resource policy for what drivers read from users' files (docs/security.md).

Recordings and traces come from anywhere: a file may be a FIFO, /dev/zero,
gigabytes long, or carry times that are NaN, run backwards or jump by a
billion seconds. Each limit here is stated once and enforced where the file
is read, so a hostile file is one RecordingError, never a hang or a crash.
"""

from __future__ import annotations

import logging
import math
from pathlib import Path

from stiction.errors import RecordingError
from stiction.userfiles import read_regular_text

log = logging.getLogger(__name__)

MAX_RECORDING_BYTES = 256 << 20
"""A hid-recorder, evemu or libinput-record file: hours of a real tablet fit in
a tenth of this; anything larger is refused before it is read."""

MAX_GAP_S = 10.0
"""A replay compresses any pause longer than this to this long (and logs it):
a recording with a 1e9 s gap would otherwise tick through 1e11 periods on the
virtual clock, or wait for three decades on the real one."""

MAX_SLOTS = 1024
"""Multi-touch slots: the kernel's input_mt_init_slots refuses more."""


def read_text(path: str | Path, limit: int = MAX_RECORDING_BYTES, what: str = "recording") -> str:
    """A regular file's text, refused unread when it is not one or is larger than `limit`."""
    return read_regular_text(path, limit, RecordingError, what)


class TimeCheck:
    """Refuses a recorded time that is not finite or runs backwards, naming where."""

    __slots__ = ("last",)

    def __init__(self) -> None:
        self.last = -math.inf

    def __call__(self, t: float, where: str) -> float:
        if not math.isfinite(t):
            raise RecordingError(f"{where}: time {t} is not a finite number")
        if t < self.last:
            raise RecordingError(f"{where}: time {t} runs backwards (after {self.last})")
        self.last = t
        return t


class GapCompressor:
    """Maps recorded times to replay times with every pause cut to at most MAX_GAP_S."""

    __slots__ = ("logged", "max_gap", "name", "prev", "shift")

    def __init__(self, name: str, max_gap: float = MAX_GAP_S) -> None:
        self.name = name
        self.max_gap = max_gap
        self.prev: float | None = None
        self.shift = 0.0
        self.logged = False

    def __call__(self, t: float) -> float:
        prev = self.prev
        self.prev = t
        if prev is not None and t - prev > self.max_gap:
            self.shift += t - prev - self.max_gap
            if not self.logged:
                log.info(
                    "%s: a pause of %.1f s replayed as %.1f s", self.name, t - prev, self.max_gap
                )
                self.logged = True
        return t - self.shift
