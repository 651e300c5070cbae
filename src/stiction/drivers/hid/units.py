"""HID units (HID 1.11, 6.2.2.7) -> metres and degrees.

A field's physical extent is (Physical Max - Physical Min) * 10^exponent in
the unit's base: centimetres for the SI Linear system, inches for English
Linear, radians or degrees for the rotation systems. Only a pure length
(length nibble 1, every other nibble 0) can give surface metres; anything
else -- no unit, or the in^3 some firmwares declare -- means the size must
come from the device table or the user.
"""

from __future__ import annotations

import math

from stiction.drivers.hid.descriptor import Field
from stiction.drivers.sample import plausible_side

SI_LINEAR, SI_ROTATION, ENGLISH_LINEAR, ENGLISH_ROTATION = 1, 2, 3, 4
_LENGTH_BASE_M = {SI_LINEAR: 0.01, ENGLISH_LINEAR: 0.0254}
_ANGLE_BASE_DEG = {SI_ROTATION: 180.0 / math.pi, ENGLISH_ROTATION: 1.0}


MAX_EXPONENT = 15
"""HID 1.11 gives Unit Exponent one signed nibble (-8..7); the kernel also takes a
wider item as a plain signed value. Beyond +-15 no real device means a length
(10^15 cm is a light-year): the unit is treated as unknown instead of
overflowing a float."""


MAX_TILT_DEG = 90.0
"""A pen leans at most flat on the surface: 90 degrees from upright."""


def _power(exponent: int) -> float | None:
    return 10.0**exponent if -MAX_EXPONENT <= exponent <= MAX_EXPONENT else None


def _nibble(unit: int, index: int) -> int:
    v = (unit >> (4 * index)) & 0xF
    return v - 16 if v > 7 else v


def physical_range(f: Field) -> tuple[int, int]:
    """Physical min/max; both zero means 'same as logical' (HID 1.11, 6.2.2.7)."""
    if f.physical_min == 0 and f.physical_max == 0:
        return f.logical_min, f.logical_max
    return f.physical_min, f.physical_max


def metres_per_physical_unit(f: Field) -> float | None:
    """Metres per physical unit of a length field, None if the unit is not a length."""
    system = f.unit & 0xF
    if system not in _LENGTH_BASE_M or _nibble(f.unit, 1) != 1:
        return None
    if any(_nibble(f.unit, i) for i in range(2, 8)):
        return None
    power = _power(f.unit_exponent)
    return None if power is None else _LENGTH_BASE_M[system] * power


def extent_m(f: Field) -> float | None:
    """The length in metres that the field's logical range spans, None if unknown."""
    scale = metres_per_physical_unit(f)
    if scale is None:
        return None
    size = raw_extent_m(f, scale)
    if not plausible_side(size) or f.logical_max <= f.logical_min:
        return None  # none, or one no surface has (drivers.sample.MAX_SURFACE_M)
    return size


def raw_extent_m(f: Field, scale: float | None = None) -> float:
    """The length the field's physical range claims, in metres, whatever it is (NaN
    without a length unit): what an error message quotes."""
    scale = metres_per_physical_unit(f) if scale is None else scale
    if scale is None:
        return math.nan
    lo, hi = physical_range(f)
    return (hi - lo) * scale


def degrees_per_logical(f: Field) -> float:
    """Degrees per logical unit of an angle field (tilt): `tilt_map(f)[0]`."""
    return tilt_map(f)[0]


def tilt_map(f: Field) -> tuple[float, float]:
    """(degrees per logical unit, degrees at logical 0) of an angle field (tilt).

    The physical range is where the degrees are: a field declared logical
    0..18000 over physical -90..90 degrees (Elan pens in shared/data/coverage)
    is upright at 9000, not at 0. Without a rotation unit the logical value is
    taken as degrees, which is what tablets without one send (and what the
    kernel passes on). So is a unit that puts an end of the physical range
    beyond 90 degrees from upright, further than a pen can lean (a logical
    -1..1 declared as -180..180 radians would read 10,000 degrees): it says
    nothing usable.
    """
    system = f.unit & 0xF
    power = _power(f.unit_exponent)
    if (
        system in _ANGLE_BASE_DEG
        and _nibble(f.unit, 1) == 1
        and f.logical_max > f.logical_min
        and power is not None
    ):
        lo, hi = physical_range(f)
        per_physical = _ANGLE_BASE_DEG[system] * power
        degrees = (hi - lo) * per_physical / (f.logical_max - f.logical_min)
        reach = max(abs(lo), abs(hi)) * per_physical
        if math.isfinite(degrees) and degrees != 0 and reach <= MAX_TILT_DEG * (1 + 1e-9):
            return degrees, lo * per_physical - f.logical_min * degrees
    return 1.0, 0.0


def unit_name(unit: int) -> str:
    """A short human name ("cm", "in", "in^3", "deg", "rad", "none", or the hex value)."""
    if unit == 0:
        return "none"
    system = unit & 0xF
    names = {SI_LINEAR: "cm", ENGLISH_LINEAR: "in", SI_ROTATION: "rad", ENGLISH_ROTATION: "deg"}
    base = names.get(system)
    length = _nibble(unit, 1)
    if base is None or any(_nibble(unit, i) for i in range(2, 8)) or length == 0:
        return f"0x{unit:x}"
    return base if length == 1 else f"{base}^{length}"
