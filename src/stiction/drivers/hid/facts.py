"""What stiction makes of one HID device: its kind, its surface, and where the size came from.

`stiction hid describe` prints these facts so that a user can see, before
plugging anything into the daemon, whether a tablet will give contacts and,
if not, what is missing and how to give it. The precedence is ReportStream's
(docs/devices.md): the user's overlay (config) and hand-written catalogue
entries win over the descriptor, because such an entry with a size exists
only where the descriptor's own size is known to be wrong (the VEIKK S640's
physical maxima, Huion's in^3 units); a generated (OpenTabletDriver) size
only fills in where the descriptor gives none.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from stiction.drivers.hid.descriptor import ReportDescriptor, parse_descriptor
from stiction.drivers.hid.devices import DeviceEntry, lookup
from stiction.drivers.hid.pen import device_kind
from stiction.drivers.hid.stream import ReportStream
from stiction.errors import StictionError


@dataclass(frozen=True, slots=True)
class DeviceFacts:
    kind: str | None
    surface_m: tuple[float, float] | None
    size_from: str | None  # "descriptor", "catalogue", "vendor-init", "config" or None
    catalogue: str | None
    backend: str
    problem: str | None

    def as_json(self) -> dict[str, object]:
        return {
            "kind": self.kind,
            "surface_m": list(self.surface_m) if self.surface_m else None,
            "size_from": self.size_from,
            "catalogue": self.catalogue,
            "backend": self.backend,
            "problem": self.problem,
        }

    def as_text(self) -> str:
        if self.kind is None:
            return f"device: not a pen, touch screen or touchpad ({self.problem})"
        where = f" ({self.catalogue})" if self.catalogue else ""
        if self.surface_m is not None:
            w, h = (v * 1000 for v in self.surface_m)
            size = f"surface {w:.1f} x {h:.1f} mm from the {self.size_from}{where}"
        elif self.size_from == "vendor-init":
            size = f"surface read from the tablet when it is opened live{where}"
        else:
            size = f"no surface size: {self.problem}"
        return f"device: {self.kind}, {size}, read through {self.backend}"


def describe_device(
    vid: int,
    pid: int,
    name: str,
    raw: bytes,
    *,
    strings: Mapping[int, str] | None = None,
) -> DeviceFacts:
    """The facts for a device with this id and report descriptor (as a recording holds them).

    `strings`: USB string descriptors (index -> text) where known (a live
    device); a recording has none, so only catalogue entries that need no
    strings apply.
    """
    entry: DeviceEntry | None = lookup(vid, pid, strings, name or None, descriptor=raw)
    catalogue = entry.name if entry is not None else None
    desc: ReportDescriptor = parse_descriptor(
        entry.descriptor if entry and entry.descriptor else raw
    )
    kind = device_kind(desc, entry.pen_reports if entry else frozenset())
    if kind == "other":
        return DeviceFacts(None, None, None, catalogue, "hidraw", "no pen, touch screen or "
                           "touchpad report in its descriptor")  # fmt: skip
    vendor_init = entry is not None and entry.init == "huion-string-descriptor"
    try:
        stream = ReportStream(desc, name or f"{vid:04x}:{pid:04x}", None, entry)
    except StictionError as exc:
        if vendor_init:  # the size comes from the tablet's string descriptor when opened
            return DeviceFacts(kind, None, "vendor-init", catalogue, "hidraw", None)
        return DeviceFacts(kind, None, None, catalogue, "hidraw", str(exc).split(": ", 1)[-1])
    size_from = stream.size_from
    if size_from == "catalogue" and entry is not None and entry.size_layer == "user":
        size_from = "config"
    return DeviceFacts(kind, stream.surface_size, size_from, catalogue, "hidraw", None)
