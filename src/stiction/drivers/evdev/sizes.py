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
from dataclasses import dataclass

from stiction.drivers.catalogue.resolve import lookup as catalogue_lookup
from stiction.drivers.evdev.description import DeviceDescription
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


def _with_size(desc: DeviceDescription, w_mm: float, h_mm: float) -> DeviceDescription:
    cx, cy = desc.position_codes
    ax, ay = desc.axes.get(cx), desc.axes.get(cy)
    if ax is None or ay is None or ax.maximum <= ax.minimum or ay.maximum <= ay.minimum:
        raise DeviceError(f"{desc.name!r} ({desc.vid_pid}) has no usable X/Y axes to scale")
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
    if ax is not None and ay is not None and ax.resolution > 0 and ay.resolution > 0:
        if kernel_size_plausible(desc):
            return desc
        log.warning(
            "implausible_size device=%r resolution=%d,%d: a surface no device has "
            "(over 10 m or under 1 mm a side); taken as reporting no size",
            desc.name, ax.resolution, ay.resolution,
        )  # fmt: skip
        desc = desc.with_resolution(0, 0)  # as if none were given: the catalogue may fill in
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
    """Raise the user-facing error for a device whose size is still unknown."""
    cx, cy = desc.position_codes
    ax, ay = desc.axes.get(cx), desc.axes.get(cy)
    if ax is None or ay is None:
        raise DeviceError(
            f"{desc.name!r} ({desc.vid_pid}) has no X/Y position axes; it is not a pen, "
            "touchpad or touchscreen"
        )
    if ax.resolution > 0 and ay.resolution > 0:
        return
    raise SizeUnknown(
        f"{desc.name!r} ({desc.vid_pid}) reports no resolution, so its physical size is "
        "unknown (measure the active area)"
    )
