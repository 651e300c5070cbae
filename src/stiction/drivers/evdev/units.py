"""Device units -> SI: positions in surface metres, pressure 0..1, tilt in degrees.

Positions count from the axis minimum (the top-left corner) and divide by the
kernel's resolution in units/mm (Documentation/input/event-codes.rst:
"ABS_X/ABS_Y ... resolution in units per millimetre"). Tilt resolution is in
units per radian; when a driver reports none (old Wacom kernels, tilt 0..127),
or one that puts the range's ends beyond 90 degrees from upright, the range
is taken to span -64..+64 degrees around its midpoint, as libinput does for
Wacom-style tilt without a resolution. A tilt beyond the range the device
declared is clamped to its end, as positions are to the surface and pressure
to 0..1: firmware garbage must not become a pen leaning 3000 degrees.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from evdev import ecodes

from stiction.drivers.blank_sample import BlankSample
from stiction.drivers.evdev.description import AbsAxis, DeviceDescription
from stiction.drivers.evdev.frames import Contact
from stiction.drivers.sample import PenSample

_FALLBACK_TILT_DEG = 64.0
_MAX_TILT_DEG = 90.0
"""A pen leans at most flat on the surface: 90 degrees from upright."""


@dataclass(frozen=True)
class _Linear:
    offset: float
    scale: float
    #: what a value converts to at most and at least (the axis range's ends)
    lo: float = -math.inf
    hi: float = math.inf

    def __call__(self, value: int) -> float:
        return (value - self.offset) * self.scale


def _pressure_scale(axis: AbsAxis | None) -> _Linear | None:
    if axis is None or axis.maximum <= axis.minimum:
        return None
    return _Linear(axis.minimum, 1.0 / (axis.maximum - axis.minimum))


def _tilt_plausible(axis: AbsAxis) -> bool:
    """The resolution puts both ends of the range within 90 degrees of upright,
    give or take the kernel's rounding of units/radian to an integer (HID's
    -90..90 degrees becomes resolution 57, so 90.5 degrees): a driver claiming
    more (resolution 1 on a +-9000 range: 500,000 degrees) has not said what
    a unit is, and is read as one that gives no resolution."""
    res = axis.resolution
    reach = math.degrees(max(-axis.minimum, axis.maximum) / res)
    return reach <= _MAX_TILT_DEG * (res + 0.5) / res


def _tilt_scale(axis: AbsAxis | None) -> _Linear | None:
    if axis is None or axis.maximum <= axis.minimum:
        return None
    if axis.resolution > 0 and axis.minimum < 0 < axis.maximum and _tilt_plausible(axis):
        off, scale = 0.0, math.degrees(1.0 / axis.resolution)
    else:
        off = (axis.minimum + axis.maximum) / 2.0
        scale = 2 * _FALLBACK_TILT_DEG / (axis.maximum - axis.minimum)
    # the same operations as the samples' (value - offset) * scale, at the ends
    return _Linear(off, scale, (axis.minimum - off) * scale, (axis.maximum - off) * scale)


class SurfaceUnits:
    """Conversions for one device; `resolution_known` is False when only units are known."""

    def __init__(self, desc: DeviceDescription) -> None:
        cx, cy = desc.position_codes
        ax, ay = desc.axes.get(cx), desc.axes.get(cy)
        self.x_axis = ax or AbsAxis(0, 0, 0)
        self.y_axis = ay or AbsAxis(0, 0, 0)
        rx, ry = self.x_axis.resolution, self.y_axis.resolution
        self.resolution_known = rx > 0 and ry > 0
        self._bounds = (
            self.x_axis.minimum,
            self.x_axis.maximum,
            self.y_axis.minimum,
            self.y_axis.maximum,
        )
        # Divided, not multiplied by a reciprocal: x_m = (x - min) / res / 1000 exactly as
        # docs/design/architecture.md writes it, so every implementation agrees to the last bit.
        self._rx = rx if rx > 0 else 1.0
        self._ry = ry if ry > 0 else 1.0
        press = ecodes.ABS_MT_PRESSURE if desc.is_multitouch else ecodes.ABS_PRESSURE
        self._pressure = _pressure_scale(desc.axes.get(press))
        self._tilt_x = _tilt_scale(desc.axes.get(ecodes.ABS_TILT_X))
        self._tilt_y = _tilt_scale(desc.axes.get(ecodes.ABS_TILT_Y))
        # the closure shadows the method below: no bound-method call per contact
        self.sample = _sample_function(self)  # type: ignore[method-assign,assignment]

    @property
    def surface_size(self) -> tuple[float, float] | None:
        if not self.resolution_known:
            return None
        return (
            (self.x_axis.maximum - self.x_axis.minimum) / self._rx / 1000,
            (self.y_axis.maximum - self.y_axis.minimum) / self._ry / 1000,
        )

    def x_m(self, x: int) -> float | None:
        return (x - self.x_axis.minimum) / self._rx / 1000 if self.resolution_known else None

    def y_m(self, y: int) -> float | None:
        return (y - self.y_axis.minimum) / self._ry / 1000 if self.resolution_known else None

    def pressure(self, raw: int | None) -> float | None:
        if raw is None or self._pressure is None:
            return None
        p = self._pressure(raw)
        return 0.0 if p < 0.0 else 1.0 if p > 1.0 else p

    def sample(self, c: Contact, t: float) -> PenSample:
        """The PenSample for a contact; requires a known resolution.

        Positions beyond the advertised range (real firmware does this, e.g.
        the Synaptics recording's X down to 1298 with a minimum of 1472) are
        clamped onto the surface, as the HID driver does, so the daemon never
        maps a touch off the surface; the assembler counts them as
        `value_out_of_range`. `decode` shows the unclamped values.

        __init__ shadows this method with a closure over this device's numbers
        (`_sample_function`); the method stays as its documentation and type.
        """
        return _sample_function(self)(c, t)

    def contact_json(self, c: Contact) -> dict[str, object]:
        """The `stiction evdev decode --json` form of a contact (docs/design/architecture.md)."""
        return {
            "slot": c.slot,
            "tracking_id": c.tracking_id,
            "tool": c.tool.value,
            "x": c.x,
            "y": c.y,
            "x_m": self.x_m(c.x),
            "y_m": self.y_m(c.y),
            "pressure": self.pressure(c.pressure),
            "tip": c.tip,
        }


def _sample_function(units: SurfaceUnits) -> Callable[[Contact, float], PenSample]:
    """units.sample for one device: its bounds and scales bound as closure cells.

    A closure reads its cells as fast as locals, where the method read a dozen
    attributes per contact; the branches for axes the device lacks (tilt,
    pressure) are decided here once. Same arithmetic, operation for operation,
    as the keyword construction in tests/evdev/test_evdev_units_samples.py.
    """
    x0, x1, y0, y1 = units._bounds
    rx, ry = units._rx, units._ry
    ps, tx, ty = units._pressure, units._tilt_x, units._tilt_y
    p_off, p_scale = (ps.offset, ps.scale) if ps is not None else (0.0, 0.0)
    has_p = ps is not None
    tx_off, tx_scale = (tx.offset, tx.scale) if tx is not None else (0.0, 0.0)
    ty_off, ty_scale = (ty.offset, ty.scale) if ty is not None else (0.0, 0.0)
    tx_lo, tx_hi = (tx.lo, tx.hi) if tx is not None else (0.0, 0.0)
    ty_lo, ty_hi = (ty.lo, ty.hi) if ty is not None else (0.0, 0.0)
    has_tx, has_ty = tx is not None, ty is not None
    blank = BlankSample
    pen_sample = PenSample

    def sample(c: Contact, t: float) -> PenSample:
        cid, _slot, _tid, tool, x, y, p, tip, in_range, tlx, tly, buttons = c
        if x < x0:
            x = x0
        elif x > x1:
            x = x1
        if y < y0:
            y = y0
        elif y > y1:
            y = y1
        # PenSample(...) field by field, at a fifth of the keyword __init__'s
        # cost (stiction.drivers.blank_sample).
        s: Any = blank()
        s.t = t
        s.x = (x - x0) / rx / 1000
        s.y = (y - y0) / ry / 1000
        s.tip = tip
        s.in_range = in_range
        s.contact = cid
        if p is not None and has_p:
            pf = (p - p_off) * p_scale
            s.pressure = 0.0 if pf < 0.0 else 1.0 if pf > 1.0 else pf
        else:
            s.pressure = None
        s.tool = tool
        if has_tx and tlx is not None:
            v = (tlx - tx_off) * tx_scale
            s.tilt_x = tx_lo if v < tx_lo else tx_hi if v > tx_hi else v
        else:
            s.tilt_x = None
        if has_ty and tly is not None:
            v = (tly - ty_off) * ty_scale
            s.tilt_y = ty_lo if v < ty_lo else ty_hi if v > ty_hi else v
        else:
            s.tilt_y = None
        s.buttons = buttons
        s.__class__ = pen_sample
        return s  # type: ignore[no-any-return]

    return sample
