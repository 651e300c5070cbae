"""Where the physical size of a device comes from, in order of trust.

1. a size the user configured (``size_mm``): they measured their device;
2. the kernel's ``absinfo.resolution`` on the position axes;
3. the device table, ``sizes.toml`` beside this module (quirks as data).

A device with none of these has no surface size: the driver refuses to guess
and raises a DeviceError naming the device and how to configure it.
"""

from __future__ import annotations

import functools
import tomllib
from dataclasses import dataclass
from importlib import resources
from typing import Any

from stiction.drivers.evdev.description import DeviceDescription
from stiction.errors import DeviceError, SizeUnknown, StictionError


@dataclass(frozen=True)
class SizeEntry:
    vendor: int
    product: int
    name: str | None
    resolution_mm: tuple[float, float] | None
    size_mm: tuple[float, float] | None
    source: str


def _pair(entry: dict[str, Any], key: str) -> tuple[float, float] | None:
    v = entry.get(key)
    if v is None:
        return None
    if (
        not isinstance(v, list)
        or len(v) != 2
        or not all(isinstance(x, int | float) and x > 0 for x in v)
    ):
        raise StictionError(f"sizes.toml: {key} must be two positive numbers, got {v!r}")
    return float(v[0]), float(v[1])


@functools.cache
def table() -> tuple[SizeEntry, ...]:
    text = resources.files("stiction.drivers.evdev").joinpath("sizes.toml").read_text("utf-8")
    data = tomllib.loads(text)
    out = []
    for e in data.get("device", []):
        out.append(
            SizeEntry(
                int(e["vendor"]),
                int(e["product"]),
                e.get("name"),
                _pair(e, "resolution_mm"),
                _pair(e, "size_mm"),
                str(e.get("source", "")),
            )
        )
    return tuple(out)


def lookup(desc: DeviceDescription) -> SizeEntry | None:
    for e in table():
        if (e.vendor, e.product) == (desc.vendor, desc.product) and (
            e.name is None or e.name in desc.name
        ):
            return e
    return None


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
        return desc
    entry = lookup(desc)
    if entry is None:
        return desc
    if entry.resolution_mm is not None:
        return desc.with_resolution(*entry.resolution_mm)
    assert entry.size_mm is not None
    return _with_size(desc, *entry.size_mm)


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
