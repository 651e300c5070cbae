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


def read_states(stream: BinaryIO) -> Iterator[PenState]:
    """Pen states from `stream` until end of input; blank lines are skipped."""
    last_t = -math.inf
    for number, raw in enumerate(stream, start=1):
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
