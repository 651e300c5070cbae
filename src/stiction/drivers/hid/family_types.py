"""What every vendor report family shares: the tablet's geometry, the pen state a report gives.

Kept apart from families.py so that the family modules (Wacom in families.py,
UC-Logic/XP-Pen in families_uclogic.py, KYE/Veikk in families_kye_veikk.py)
can share them without importing one another.
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from dataclasses import dataclass
from typing import NamedTuple, cast


@dataclass(frozen=True, slots=True)
class Geometry:
    """What the family's reports cannot say about themselves: ranges and the active area."""

    max_x: int
    max_y: int
    max_pressure: int
    width_mm: float
    height_mm: float
    source: str = ""


class PenState(NamedTuple):
    """One pen report, read. Tilt (degrees, where the protocol has it) is read for
    completeness of the layout but not forwarded: the normalised report has no tilt,
    as the friction model does not use it.

    A tuple, not a frozen dataclass: a family reader builds one per report,
    on the daemon's path, and a frozen dataclass's ``__init__`` stores each of
    its ten fields through ``object.__setattr__``, which cost more than the
    rest of the reader (docs/devices.md, Speed). The readers build it with
    `new_state`; tests and other callers as usual, fields by keyword."""

    x: int
    y: int
    pressure: int
    tip: bool
    in_range: bool
    barrel: bool = False
    barrel2: bool = False
    eraser: bool = False
    tilt_x: int = 0
    tilt_y: int = 0


Reader = Callable[[bytes], PenState | None]
"""One raw report -> the pen it describes, or None for a report that is not the pen's."""

Fields = tuple[int, int, int, bool, bool, bool, bool, bool, int, int]
"""A PenState's ten fields in order."""

new_state = cast(Callable[[type[PenState], Fields], PenState], tuple.__new__)
"""``new_state(PenState, fields)``: a PenState from all ten fields in one tuple.

What the readers build per report. ``tuple.__new__`` is C; the NamedTuple's
own ``__new__`` is a Python function taking the fields as arguments (with
defaults), which costs about as much again as the rest of a short reader
(and so does a functools.partial binding the class). The fields' types are
checked by mypy through `Fields`."""


def away(x: int, y: int) -> PenState:
    """The pen out of range, last seen at (x, y): what every reader returns
    for a report that says so (one call more than `new_state`, paid only
    while the pen is away)."""
    return new_state(PenState, (x, y, 0, False, False, False, False, False, 0, 0))


u16x2 = struct.Struct("<2H").unpack_from
"""Two little-endian 16-bit values at an offset (X and Y, most layouts)."""
u16x3 = struct.Struct("<3H").unpack_from
"""Three little-endian 16-bit values at an offset (X, Y and pressure, most layouts)."""
s8x2 = struct.Struct("<2b").unpack_from
"""Two signed bytes at an offset (tilt X and Y)."""


def u16le(d: bytes, i: int) -> int:
    return d[i] | (d[i + 1] << 8)


def s8(v: int) -> int:
    return v - 256 if v > 127 else v
