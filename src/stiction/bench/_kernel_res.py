"""The size the Linux kernel and libinput derive from a HID axis, to explain libinput's figures.

libinput's size is (axis maximum - minimum) / resolution, and the kernel's
resolution is an integer number of units per millimetre, rounded from the
descriptor's logical and physical extents (hidinput_calc_abs_res in
drivers/hid/hid-input.c: only the exact units 0x11 (cm) and 0x13 (in) count,
the unit exponent is applied by multiplying one extent by 10, and the result
is DIV_ROUND_CLOSEST). A panel of 1872 units over 17.4 cm has 10.76 units per
mm, which the kernel makes 11, so libinput says 170 mm, not 174 mm. The
coverage benchmark uses this model to tell "libinput's size is the kernel's
rounding of the descriptor's" apart from "stiction read the descriptor wrong";
stiction itself keeps the exact physical extent.
"""

from __future__ import annotations

from stiction.drivers.hid.descriptor import Field

_CM, _IN = 0x11, 0x13
_INT32_MAX = (1 << 31) - 1


def kernel_resolution(f: Field) -> int:
    """Units per millimetre as the kernel computes it for an X/Y axis (0: no resolution)."""
    logical = f.logical_max - f.logical_min
    physical = f.physical_max - f.physical_min
    if logical <= 0 or physical <= 0:
        return 0
    exponent = f.unit_exponent
    if f.unit == _CM:
        exponent += 1
    elif f.unit == _IN:
        physical *= 254
        exponent -= 1
    else:
        return 0
    for _ in range(max(0, -exponent)):
        logical *= 10
    for _ in range(max(0, exponent)):
        physical *= 10
    if logical > _INT32_MAX or physical > _INT32_MAX:  # the kernel's overflow checks
        return 0
    return (logical + physical // 2) // physical


def kernel_extent_mm(f: Field) -> float | None:
    """libinput's size for this axis in mm, None where the kernel gives no resolution."""
    res = kernel_resolution(f)
    if res == 0:
        return None
    return (f.logical_max - f.logical_min) / res
