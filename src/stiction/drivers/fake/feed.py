"""A synthetic pen steered from outside: pen states read line by line from a stream.

The scripted strokes (strokes.py) are fixed in advance; a simulated
participant (stiction.experiment.observer) must instead react to what the
daemon shows it, stopping a stroke when the pointer has travelled far
enough. ``stictiond --device synthetic:stdin`` reads one pen state per line
from its standard input and sends it through the same HID descriptor as the
scripted pen, so every sample takes the hardware's route through the decoder.

Line format (whitespace separated, surface metres, seconds)::

    t x y tip in_range pressure

``tip`` and ``in_range`` are 0 or 1, ``pressure`` 0..1. Lines must come in
time order. End of input ends the device (under ``--clock virtual`` the
daemon then exits). A malformed line ends the device with a DeviceError
naming the line, rather than guessing.
"""

from __future__ import annotations

import math
import os
import select
import threading
from collections.abc import Iterator
from typing import BinaryIO

from stiction.drivers.fake.strokes import PenState
from stiction.errors import DeviceError

FIELDS = ("t", "x", "y", "tip", "in_range", "pressure")


def format_state(s: PenState) -> str:
    """One feed line for `s` (the writer's side of `parse_line`)."""
    return f"{s.t:.6f} {s.x:.7f} {s.y:.7f} {int(s.tip)} {int(s.in_range)} {s.pressure:.4f}\n"


def parse_line(line: str, number: int) -> PenState:
    parts = line.split()
    if len(parts) != len(FIELDS):
        raise DeviceError(
            f"synthetic:stdin line {number}: expected {len(FIELDS)} fields "
            f"({' '.join(FIELDS)}), got {len(parts)}"
        )
    try:
        t, x, y, tip, in_range, pressure = (float(p) for p in parts)
    except ValueError:
        raise DeviceError(f"synthetic:stdin line {number}: not a number in {line!r}") from None
    if not all(math.isfinite(v) for v in (t, x, y, pressure)):
        raise DeviceError(f"synthetic:stdin line {number}: non-finite value in {line!r}")
    return PenState(t, x, y, tip != 0, in_range != 0, min(max(pressure, 0.0), 1.0))


def _lines(stream: BinaryIO, stop: threading.Event | None) -> Iterator[bytes]:
    """Lines of `stream`; with `stop`, read so that setting it ends a blocked read soon.

    A thread blocked in a plain read of stdin cannot be woken, and at
    interpreter exit it holds the stream's lock (CPython then aborts), so the
    daemon's reader polls the descriptor instead."""
    if stop is None:
        yield from stream
        return
    fd = stream.fileno()
    pending = b""
    while not stop.is_set():
        ready, _, _ = select.select([fd], [], [], 0.1)
        if not ready:
            continue
        chunk = os.read(fd, 65536)
        if not chunk:
            break
        pending += chunk
        *lines, pending = pending.split(b"\n")
        yield from lines
    if pending and not stop.is_set():
        yield pending


def read_states(stream: BinaryIO, stop: threading.Event | None = None) -> Iterator[PenState]:
    """Pen states from `stream` until end of input (or `stop`); blank lines are skipped."""
    last_t = -math.inf
    for number, raw in enumerate(_lines(stream, stop), start=1):
        line = raw.decode("ascii", errors="replace").strip()
        if not line:
            continue
        state = parse_line(line, number)
        if state.t < last_t:
            raise DeviceError(
                f"synthetic:stdin line {number}: time {state.t:g} goes back (last {last_t:g})"
            )
        last_t = state.t
        yield state
