"""Where the physical size of a device comes from, in order of trust.

1. a size the user configured (``size_mm``): they measured their device;
2. the kernel's ``absinfo.resolution`` on the position axes;
3. the device catalogue (stiction.drivers.catalogue): hand-written entries
   matched by vid:pid and node name, and OpenTabletDriver's pen areas for pen
   nodes (docs/devices.md).

A device with none of these has no surface size: the driver refuses to guess
and raises a DeviceError naming the device and how to configure it.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, replace

from evdev import ecodes

from stiction.drivers.catalogue.resolve import lookup as catalogue_lookup
from stiction.drivers.evdev.description import FINGER_TOOLS, PEN_TOOLS, DeviceDescription
from stiction.drivers.sample import plausible_side
from stiction.errors import DeviceError, SizeUnknown

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class SizeEntry:
    vendor: int
    product: int
    name: str | None
    resolution_mm: tuple[float, float] | None
    size_mm: tuple[float, float] | None
    source: str


def _pair(v: object) -> tuple[float, float] | None:
    if not isinstance(v, list):
        return None
    return float(v[0]), float(v[1])


def lookup(desc: DeviceDescription) -> SizeEntry | None:
    """The catalogue's size for this node, matched by vid:pid and the node's name.

    Generated (OpenTabletDriver) sizes are a tablet's pen area, so they
    apply to pen nodes only; hand-written entries name the node they are for.
    """
    r = catalogue_lookup(desc.vendor, desc.product, None, desc.name)
    if r is None:
        return None
    eff = {
        k: v
        for k, v in r.effects.items()
        if k in ("size_mm", "resolution_mm")
        and (r.origin[k].layer != "generated" or desc.kind == "pen")
    }
    if not eff:
        return None
    key = "resolution_mm" if "resolution_mm" in eff else "size_mm"
    origin = r.origin[key]
    return SizeEntry(
        desc.vendor,
        desc.product,
        origin.match.name,
        _pair(eff.get("resolution_mm")),
        _pair(eff.get("size_mm")) if key == "size_mm" else None,
        origin.source,
    )


_CONTACT_KEYS = frozenset(
    (*PEN_TOOLS, *FINGER_TOOLS, ecodes.BTN_TOUCH, ecodes.BTN_STYLUS, ecodes.BTN_STYLUS2)
)


def unusable(desc: DeviceDescription) -> str | None:
    """Why no size can make this node a surface, in words naming it; None if one can.

    These are properties of the capabilities, not of a missing size: a button
    pad, a touch screen speaking only multi-touch protocol A, a node without
    both position axes, an axis whose range is empty or inverted. Asking such
    a device's user for a size would send them measuring for nothing.
    """
    who = f"{desc.name!r} ({desc.vid_pid})"
    if desc.is_pad:
        return (
            f"{who} is a tablet's button pad (ExpressKeys, rings, strips), not a surface; "
            "open the tablet's pen node instead (`stiction devices` lists it)"
        )
    if desc.mt_protocol_a_only:
        return (
            f"{who} reports touches only through the multi-touch protocol A "
            "(ABS_MT_POSITION_X/Y without slots and tracking ids), which stiction "
            "does not read; "
            "its hidraw node may be readable instead (`stiction devices`)"
        )
    cx, cy = desc.position_codes
    ax, ay = desc.axes.get(cx), desc.axes.get(cy)
    if ax is None or ay is None:
        return f"{who} has no X/Y position axes; it is not a pen, touchpad or touchscreen"
    for name, code, a in (("X", cx, ax), ("Y", cy, ay)):
        if a.maximum <= a.minimum:
            return (
                f"{who} declares an empty {name} range ({ecodes.ABS[code]} "
                f"{a.minimum}..{a.maximum}): no size can make it a surface"
            )
    # X/Y and nothing that touches: a joystick, a virtual machine's absolute
    # pointer (BTN_LEFT only). A pen with mouse and lens tools only, or a pen
    # with pressure and no key at all, is still read.
    touches = desc.keys & _CONTACT_KEYS or desc.is_multitouch or ecodes.ABS_PRESSURE in desc.axes
    if desc.kind == "other" and not touches:
        return (
            f"{who} is not a pen, touchpad or touchscreen: it has X/Y axes but no "
            "touch, tool or stylus key (a joystick, or an absolute pointer)"
        )
    return None


def _with_size(desc: DeviceDescription, w_mm: float, h_mm: float) -> DeviceDescription:
    why = unusable(desc)
    if why is not None:
        raise DeviceError(why)
    cx, cy = desc.position_codes
    ax, ay = desc.axes[cx], desc.axes[cy]
    return desc.with_resolution((ax.maximum - ax.minimum) / w_mm, (ay.maximum - ay.minimum) / h_mm)


def apply(desc: DeviceDescription, size_mm: tuple[float, float] | None = None) -> DeviceDescription:
    """The description with position resolutions filled in where a size is known."""
    if size_mm is not None:
        w, h = size_mm
        if not (w > 0 and h > 0):
            raise DeviceError(f"size for {desc.name!r} must be positive millimetres, got {size_mm}")
        return _with_size(desc, w, h)
    cx, cy = desc.position_codes
    ax, ay = desc.axes.get(cx), desc.axes.get(cy)
    if unusable(desc) is not None:
        return desc  # require() says why; a diagnostic read still shows its frames
    if ax is not None and ay is not None and (ax.resolution > 0) != (ay.resolution > 0):
        # one axis without: no size either way (a wrong hwdb entry, a driver bug)
        note = (
            f"reports a resolution on one axis only (X {ax.resolution:g}, "
            f"Y {ay.resolution:g} units/mm)"
        )
        desc = replace(desc.with_resolution(0, 0), size_note=note)
    elif ax is not None and ay is not None and ax.resolution > 0 and ay.resolution > 0:
        if kernel_size_plausible(desc):
            return desc
        log.warning(
            "implausible_size device=%r resolution=%d,%d: a surface no device has "
            "(over 10 m or under 1 mm a side); taken as reporting no size",
            desc.name, ax.resolution, ay.resolution,
        )  # fmt: skip
        w = (ax.maximum - ax.minimum) / ax.resolution
        h = (ay.maximum - ay.minimum) / ay.resolution
        note = (
            f"reports resolutions that make a {w:.6g} x {h:.6g} mm surface, "
            "which no device has (over 10 m or under 1 mm a side)"
        )
        # as if none were given: the catalogue may fill in
        desc = replace(desc.with_resolution(0, 0), size_note=note)
    entry = lookup(desc)
    if entry is None:
        return desc
    if entry.resolution_mm is not None:
        return desc.with_resolution(*entry.resolution_mm)
    assert entry.size_mm is not None
    return _with_size(desc, *entry.size_mm)


def kernel_size_plausible(desc: DeviceDescription) -> bool:
    """The size the node's ranges and resolutions give is one a surface can have
    (drivers.sample.MAX_SURFACE_M); True where there is none to judge."""
    cx, cy = desc.position_codes
    ax, ay = desc.axes.get(cx), desc.axes.get(cy)
    if ax is None or ay is None or ax.resolution <= 0 or ay.resolution <= 0:
        return True
    return all(plausible_side((a.maximum - a.minimum) / a.resolution / 1000) for a in (ax, ay))


def require(desc: DeviceDescription) -> None:
    """Raise the user-facing error for a device that cannot be a surface (DeviceError)
    or whose size is still unknown (SizeUnknown, which asks for one)."""
    why = unusable(desc)
    if why is not None:
        raise DeviceError(why)
    cx, cy = desc.position_codes
    ax, ay = desc.axes[cx], desc.axes[cy]
    if ax.resolution > 0 and ay.resolution > 0:
        return
    said = desc.size_note or "reports no resolution"
    raise SizeUnknown(
        f"{desc.name!r} ({desc.vid_pid}) {said}, so its physical size is "
        "unknown (measure the active area)"
    )
