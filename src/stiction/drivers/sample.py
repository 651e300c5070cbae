"""The one value every driver produces.

Surface coordinates are metres from the device's top-left corner (the axis
minimum), so every consumer downstream works in SI units regardless of whether
the sample came from a HID report, an evdev frame or a synthetic stroke.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

MIN_SURFACE_M = 1e-3
"""The smallest surface side any size source may give: 1 mm (`--size-mm`, the
daemon's config and a device's own report are held to the same bounds)."""
MAX_SURFACE_M = 10.0
"""The largest: 10 m. A device reporting more (an evemu file claiming a
2,147 km axis) is treated as reporting no size, and so asks for one, rather
than moving the pointer by nothing."""


def plausible_side(metres: float) -> bool:
    """A surface side within [MIN_SURFACE_M, MAX_SURFACE_M] (NaN is not)."""
    return MIN_SURFACE_M <= metres <= MAX_SURFACE_M


class Tool(enum.Enum):
    """What is touching the surface."""

    PEN = "pen"
    ERASER = "eraser"
    FINGER = "finger"
    UNKNOWN = "unknown"


@dataclass(frozen=True, slots=True)
class PenSample:
    """One contact's state at one instant, in surface metres.

    `t` is the device's own clock where it has one (the kernel's event time for
    evdev, the recorded time for replays), in seconds. `tip` is True while the
    pen or finger touches the surface; `in_range` is False once the tool has
    left proximity (the last sample of a contact). `contact` identifies the
    contact within one device (0 for a single pen; the tracking/contact id for
    multi-touch).
    """

    t: float
    x: float
    y: float
    tip: bool
    in_range: bool = True
    contact: int = 0
    pressure: float | None = None
    tool: Tool = Tool.PEN
    tilt_x: float | None = None
    tilt_y: float | None = None
    buttons: int = 0
